//! Text to syntax tree: the lalrpop parser over the `logos` lexer.
//!
//! Every lalrpop `ParseError` becomes a [`FormulaError`] in exactly one place,
//! [`syntax_error`].

use super::ast::{Ast, Span};
use super::error::{ErrorKind, FormulaError};
use super::lexer::{LexError, Lexer, SpannedLexError, Token};
use lalrpop_util::ParseError;

#[allow(clippy::all, unused_parens, missing_docs)]
mod grammar {
    lalrpop_util::lalrpop_mod!(formula);
    pub use formula::*;
}

/// Parses formula text into a syntax tree.
///
/// ```
/// let ast = lgc::lang::parse("let r = 2; x^2 + y^2 - r").unwrap();
/// assert_eq!(ast.bindings.len(), 1);
/// let err = lgc::lang::parse("x^2 +").unwrap_err();
/// assert_eq!(err.line_column("x^2 +"), (1, 6));
/// ```
pub fn parse(source: &str) -> Result<Ast, FormulaError> {
    if Lexer::new(source).next().is_none() {
        let span = source.trim_end().len()..source.trim_end().len();
        return Err(
            FormulaError::new(ErrorKind::EmptyInput, span, "empty formula")
                .with_label("expected an expression")
                .with_note("write a formula in x, y and z, such as `x^2 + y^2 + z^2 - 1`"),
        );
    }
    check_length(source)?;
    let mut ast = Ast::default();
    grammar::ProgramParser::new()
        .parse(&mut ast, Lexer::new(source))
        .map_err(|e| syntax_error(e, source))?;
    Ok(ast)
}

/// The most tokens a formula or scene may have: about two million
/// operations, a sum of a million terms, some 250 times the longest real
/// model. (The memory a formula of this length takes still depends on its
/// derivatives: a million nested `sin` take 2 GB.)
pub const MAX_TOKENS: usize = 1 << 23;

/// Refuses a text of more than [`MAX_TOKENS`] tokens, before parsing it:
/// memory stays bounded whatever the input.
fn check_length(source: &str) -> Result<(), FormulaError> {
    // Every token is at least a byte: most texts need no count.
    if source.len() <= MAX_TOKENS {
        return Ok(());
    }
    let span = match Lexer::new(source).nth(MAX_TOKENS) {
        Some(Ok((start, _, end))) => start..end,
        Some(Err(e)) => e.span,
        None => return Ok(()),
    };
    Err(FormulaError::new(
        ErrorKind::TooLong,
        span,
        format!("the text is too long: lgc reads at most {MAX_TOKENS} tokens"),
    )
    .with_label("the first token past the limit"))
}

/// Parses a scene file into a syntax tree (its items; see [`crate::scene`]).
pub fn parse_scene(source: &str) -> Result<Ast, FormulaError> {
    check_length(source)?;
    let mut ast = Ast::default();
    grammar::SceneParser::new()
        .parse(&mut ast, Lexer::new(source))
        .map_err(|e| syntax_error(e, source))?;
    Ok(ast)
}

/// Names a token the parser expected, in words a user reads.
fn describe_expected(raw: &str) -> String {
    match raw.trim_matches('"') {
        "number" => "a number".to_string(),
        "name" => "a name".to_string(),
        other => format!("`{other}`"),
    }
}

fn expected_list(expected: &[String]) -> String {
    let items: Vec<String> = expected.iter().map(|e| describe_expected(e)).collect();
    match items.len() {
        0 => "nothing more".to_string(),
        1 => items[0].clone(),
        _ => format!("one of {}", items.join(", ")),
    }
}

/// True when the expected set means "an expression may start here".
fn expects_operand(expected: &[String]) -> bool {
    expected
        .iter()
        .any(|e| e == "\"number\"" || e == "\"name\"")
}

/// True when the expected set means "a complete expression stands before".
fn expects_operator(expected: &[String]) -> bool {
    expected.iter().any(|e| e == "\"+\"" || e == "\"*\"")
}

/// The `(` left open at the end of `source`, if any.
fn unclosed_paren(source: &str) -> Option<Span> {
    let mut open = Vec::new();
    for (start, token, end) in Lexer::new(source).flatten() {
        match token {
            Token::LParen => open.push(start..end),
            Token::RParen => {
                open.pop();
            }
            _ => {}
        }
    }
    open.pop()
}

/// Converts a lalrpop error into lgc's spanned error.
fn syntax_error(
    error: ParseError<usize, Token<'_>, SpannedLexError>,
    source: &str,
) -> FormulaError {
    match error {
        ParseError::User { error } => match error.error {
            LexError::MalformedNumber => FormulaError::new(
                ErrorKind::MalformedNumber,
                error.span.clone(),
                format!("malformed number `{}`", &source[error.span.clone()]),
            )
            .with_label("not a number")
            .with_note(
                "numbers look like 2, 0.5, .5, 1e-3 or 2.5E+4; write a product as 2*x, not 2x",
            ),
            LexError::NumberOutOfRange => FormulaError::new(
                ErrorKind::NumberOutOfRange,
                error.span.clone(),
                format!(
                    "number `{}` is beyond f64's range",
                    &source[error.span.clone()]
                ),
            )
            .with_label("f64 holds magnitudes from about 4.9e-324 to 1.8e308, and 0")
            .with_note("lgc computes in f64: scale the formula so that its constants fit"),
            LexError::InvalidCharacter => {
                let text = &source[error.span.clone()];
                let message = match text.chars().next() {
                    Some(c) if super::error::is_invisible(c) => {
                        format!("unexpected invisible character U+{:04X}", c as u32)
                    }
                    _ => format!("unexpected character `{text}`"),
                };
                FormulaError::new(ErrorKind::InvalidCharacter, error.span, message)
                .with_label("not part of the formula language")
                .with_note("formulas use numbers, names, + - * / ^, parentheses, commas, `let … = …;` and # comments")
            }
        },
        ParseError::InvalidToken { location } => FormulaError::new(
            ErrorKind::InvalidCharacter,
            location..location + 1,
            "unexpected character",
        ),
        ParseError::UnrecognizedEof { location, expected } => {
            let at = location..location;
            let last = Lexer::new(source).flatten().last().map(|(_, t, _)| t);
            if expected.iter().any(|e| e == "\")\"") && !expects_operand(&expected) {
                let err =
                    FormulaError::new(ErrorKind::UnclosedParenthesis, at, "unclosed parenthesis")
                        .with_label(format!("expected {}", expected_list(&expected)));
                match unclosed_paren(source) {
                    Some(open) => err.with_related(open, "this `(` is never closed"),
                    None => err,
                }
            } else if expected.iter().any(|e| e == "\";\"") {
                FormulaError::new(ErrorKind::UnexpectedEnd, at, "unfinished `let` binding")
                    .with_label("expected `;` and then the formula")
            } else if last == Some(Token::Semicolon) {
                FormulaError::new(
                    ErrorKind::UnexpectedEnd,
                    at,
                    "the formula ends after its `let` bindings",
                )
                .with_label("expected the formula itself after the last `;`")
            } else if expects_operand(&expected) {
                let after = last.map(|t| format!(" after {t}")).unwrap_or_default();
                FormulaError::new(ErrorKind::UnexpectedEnd, at, "unexpected end of formula")
                    .with_label(format!("expected an expression{after}"))
            } else {
                FormulaError::new(ErrorKind::UnexpectedEnd, at, "unexpected end of formula")
                    .with_label(format!("expected {}", expected_list(&expected)))
            }
        }
        ParseError::UnrecognizedToken {
            token: (start, token, end),
            expected,
        } => {
            let span = start..end;
            if token == Token::RParen && !expected.iter().any(|e| e == "\")\"") {
                FormulaError::new(ErrorKind::UnmatchedParenthesis, span, "unmatched `)`")
                    .with_label("no `(` is open here")
            } else if expected.iter().any(|e| e == "\";\"") {
                FormulaError::new(
                    ErrorKind::UnexpectedToken,
                    span,
                    format!("unexpected {token}"),
                )
                .with_label("expected `;` to end the `let` binding, or an operator")
            } else if expects_operator(&expected) && !expects_operand(&expected) {
                FormulaError::new(
                    ErrorKind::TrailingInput,
                    span,
                    format!("unexpected {token} after a complete expression"),
                )
                .with_label(format!(
                    "expected an operator or the end of the formula, found {token}"
                ))
                .with_note("write a product as 2*x; separate `let` bindings with `;`")
            } else {
                FormulaError::new(
                    ErrorKind::UnexpectedToken,
                    span,
                    format!("unexpected {token}"),
                )
                .with_label(format!("expected {}", expected_list(&expected)))
            }
        }
        ParseError::ExtraToken {
            token: (start, token, end),
        } => FormulaError::new(
            ErrorKind::TrailingInput,
            start..end,
            format!("unexpected {token} after a complete expression"),
        )
        .with_label("expected the end of the formula"),
    }
}
