//! Tokens of the formula language, produced by a `logos` lexer.
//!
//! [`Lexer`] adapts the `logos` token stream to the `(start, Token, end)` triples
//! the lalrpop parser consumes, turning lexical errors into spanned [`LexError`]s.

use logos::{Logos, SpannedIter};
use std::ops::Range;

/// A lexical error: something that is not a token of the language.
#[derive(Debug, Clone, PartialEq, Default)]
pub enum LexError {
    /// A character that starts no token.
    #[default]
    InvalidCharacter,
    /// A run that starts like a number but is not one (`1.2.3`, `1e`, `2x`).
    MalformedNumber,
    /// A number beyond f64's range (`1e400`), or one that is not 0 but
    /// rounds to it (`1e-400`).
    NumberOutOfRange,
}

/// One token of the formula language.
#[derive(Logos, Debug, Clone, Copy, PartialEq)]
#[logos(error = LexError)]
// (U+FEFF: a byte-order mark, which editors write at the start of a file.)
#[logos(skip r"[ \t\r\n\f\u{feff}]+")]
// A comment runs to the end of its line, never past it.
#[logos(skip(r"#[^\n]*", allow_greedy = true))]
pub enum Token<'src> {
    /// A number literal; the lexer has already checked and converted it.
    // The pattern is deliberately wider than a number so that `1.2.3` or `2x`
    // becomes one malformed-number error instead of a confusing token sequence.
    #[regex(r"(\.?[0-9])([0-9a-zA-Z_.]|[eE][+-])*", parse_number)]
    Number(f64),
    /// A name: a variable, a constant, a function or a `let` binding.
    #[regex(r"[a-zA-Z_][a-zA-Z0-9_]*")]
    Ident(&'src str),
    /// The `let` keyword.
    #[token("let")]
    Let,
    /// The `fn` keyword (scene files: user functions).
    #[token("fn")]
    Fn,
    /// `{`
    #[token("{")]
    LBrace,
    /// `}`
    #[token("}")]
    RBrace,
    /// `+`
    #[token("+")]
    Plus,
    /// `-`
    #[token("-")]
    Minus,
    /// `*`
    #[token("*")]
    Star,
    /// `/`
    #[token("/")]
    Slash,
    /// `^`
    #[token("^")]
    Caret,
    /// `(`
    #[token("(")]
    LParen,
    /// `)`
    #[token(")")]
    RParen,
    /// `,`
    #[token(",")]
    Comma,
    /// `=`
    #[token("=")]
    Equals,
    /// `;`
    #[token(";")]
    Semicolon,
}

/// Accepts exactly `digits[.digits][e[+-]digits]` or `.digits[e[+-]digits]`.
fn is_number_literal(text: &str) -> bool {
    let bytes = text.as_bytes();
    let mut i = 0;
    let digits = |i: &mut usize| {
        let start = *i;
        while *i < bytes.len() && bytes[*i].is_ascii_digit() {
            *i += 1;
        }
        *i - start
    };
    let int = digits(&mut i);
    let mut frac = 0;
    if i < bytes.len() && bytes[i] == b'.' {
        i += 1;
        frac = digits(&mut i);
    }
    if int + frac == 0 {
        return false;
    }
    if i < bytes.len() && (bytes[i] == b'e' || bytes[i] == b'E') {
        i += 1;
        if i < bytes.len() && (bytes[i] == b'+' || bytes[i] == b'-') {
            i += 1;
        }
        if digits(&mut i) == 0 {
            return false;
        }
    }
    i == bytes.len()
}

fn parse_number<'src>(lex: &mut logos::Lexer<'src, Token<'src>>) -> Result<f64, LexError> {
    let text = lex.slice();
    if !is_number_literal(text) {
        return Err(LexError::MalformedNumber);
    }
    match text.parse::<f64>() {
        Ok(v) if in_range(text, v) => Ok(v),
        Ok(_) => Err(LexError::NumberOutOfRange),
        Err(_) => Err(LexError::MalformedNumber),
    }
}

/// `text` as a number, as the formula language reads one: the nearest f64,
/// or why it is none (written for "`text` …").
///
/// ```
/// assert_eq!(lgc::lang::read_number("2.5e-3"), Ok(2.5e-3));
/// assert!(lgc::lang::read_number("1e-400").unwrap_err().contains("range"));
/// assert!(lgc::lang::read_number("inf").is_err());
/// ```
pub fn read_number(text: &str) -> Result<f64, &'static str> {
    match text.parse::<f64>() {
        Ok(v) if in_range(text, v) => Ok(v),
        Ok(_) if text.bytes().any(|b| b.is_ascii_digit()) => {
            Err("is beyond f64's range (magnitudes from about 4.9e-324 to 1.8e308, and 0)")
        }
        _ => Err("is not a finite number"),
    }
}

/// Whether `v`, read from the literal `text`, is the literal's value rounded
/// to f64 and not a value lost to its range: finite, and 0 only where the
/// literal is (`1e-400` is not 0, but f64 holds nothing nearer).
pub(crate) fn in_range(text: &str, v: f64) -> bool {
    let mantissa = text.split(['e', 'E']).next().unwrap_or(text);
    v.is_finite() && (v != 0.0 || !mantissa.bytes().any(|b| (b'1'..=b'9').contains(&b)))
}

impl std::fmt::Display for Token<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Token::Number(v) => write!(f, "number `{v}`"),
            Token::Ident(name) => write!(f, "name `{name}`"),
            Token::Let => f.write_str("`let`"),
            Token::Fn => f.write_str("`fn`"),
            Token::LBrace => f.write_str("`{`"),
            Token::RBrace => f.write_str("`}`"),
            Token::Plus => f.write_str("`+`"),
            Token::Minus => f.write_str("`-`"),
            Token::Star => f.write_str("`*`"),
            Token::Slash => f.write_str("`/`"),
            Token::Caret => f.write_str("`^`"),
            Token::LParen => f.write_str("`(`"),
            Token::RParen => f.write_str("`)`"),
            Token::Comma => f.write_str("`,`"),
            Token::Equals => f.write_str("`=`"),
            Token::Semicolon => f.write_str("`;`"),
        }
    }
}

/// A spanned lexical error, as the parser receives it.
#[derive(Debug, Clone, PartialEq)]
pub struct SpannedLexError {
    /// What went wrong.
    pub error: LexError,
    /// Byte range of the offending text.
    pub span: Range<usize>,
}

/// The adapter between `logos` and lalrpop: yields `(start, Token, end)`.
pub struct Lexer<'src> {
    tokens: SpannedIter<'src, Token<'src>>,
}

impl<'src> Lexer<'src> {
    /// Starts lexing `source`.
    pub fn new(source: &'src str) -> Self {
        Self {
            tokens: Token::lexer(source).spanned(),
        }
    }
}

impl<'src> Iterator for Lexer<'src> {
    type Item = Result<(usize, Token<'src>, usize), SpannedLexError>;

    fn next(&mut self) -> Option<Self::Item> {
        let (token, span) = self.tokens.next()?;
        Some(match token {
            Ok(token) => Ok((span.start, token, span.end)),
            Err(error) => Err(SpannedLexError { error, span }),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn kinds(src: &str) -> Vec<Result<Token<'_>, LexError>> {
        Lexer::new(src)
            .map(|r| r.map(|(_, t, _)| t).map_err(|e| e.error))
            .collect()
    }

    #[test]
    fn numbers_in_every_documented_form() {
        for (text, value) in [
            ("2", 2.0),
            ("0.5", 0.5),
            (".5", 0.5),
            ("1e-3", 1e-3),
            ("2.5E+4", 2.5e4),
            ("5.", 5.0),
        ] {
            assert_eq!(kinds(text), vec![Ok(Token::Number(value))], "{text}");
        }
    }

    #[test]
    fn malformed_numbers_are_one_error() {
        for text in ["1.2.3", "1e", "1e+", "2x", "3.5ee2"] {
            assert_eq!(kinds(text), vec![Err(LexError::MalformedNumber)], "{text}");
        }
    }

    #[test]
    fn numbers_beyond_f64_are_out_of_range_not_zero() {
        for text in ["1e400", "1e-400", "2.7426e-340", "0.0000001e-320"] {
            assert_eq!(kinds(text), vec![Err(LexError::NumberOutOfRange)], "{text}");
        }
        for (text, value) in [("0e-400", 0.0), ("0.000", 0.0), ("5e-324", 5e-324)] {
            assert_eq!(kinds(text), vec![Ok(Token::Number(value))], "{text}");
        }
    }

    #[test]
    fn comments_and_newlines_are_skipped() {
        assert_eq!(
            kinds("x # a comment\n + 1"),
            vec![
                Ok(Token::Ident("x")),
                Ok(Token::Plus),
                Ok(Token::Number(1.0))
            ]
        );
    }

    #[test]
    fn let_is_a_keyword_but_letter_is_a_name() {
        assert_eq!(
            kinds("let letter"),
            vec![Ok(Token::Let), Ok(Token::Ident("letter"))]
        );
    }

    #[test]
    fn constant_e_followed_by_minus_is_not_a_number() {
        assert_eq!(
            kinds("e-1"),
            vec![
                Ok(Token::Ident("e")),
                Ok(Token::Minus),
                Ok(Token::Number(1.0))
            ]
        );
    }
}
