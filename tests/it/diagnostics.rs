//! Every class of bad input gives a located, worded error with a caret, never
//! a panic.

use lgc::{ErrorKind, Formula};

/// Parses `src`, expecting an error of `kind` at 1-based `line:column`, whose
/// message contains `message`; returns the rendered text.
fn expect_error(src: &str, kind: ErrorKind, line: usize, column: usize, message: &str) -> String {
    let err = match Formula::parse(src) {
        Ok(_) => panic!("`{src}` parsed, but should fail with {kind:?}"),
        Err(e) => e,
    };
    assert_eq!(err.kind, kind, "`{src}`: {}", err.message);
    assert_eq!(
        err.line_column(src),
        (line, column),
        "`{src}`: {}",
        err.message
    );
    assert!(
        err.message.contains(message),
        "`{src}`: message `{}` lacks `{message}`",
        err.message
    );
    let rendered = err.render(src, "<formula>");
    assert!(
        rendered.contains(&format!("<formula>:{line}:{column}")),
        "{rendered}"
    );
    // The caret sits under the reported column of the quoted source line.
    let lines: Vec<&str> = rendered.lines().collect();
    let source_line = src.lines().nth(line - 1).unwrap_or("");
    let at = lines
        .iter()
        .position(|l| {
            l.ends_with(&format!("| {source_line}"))
                || (source_line.is_empty() && l.trim_end().ends_with(&format!("{line} |")))
        })
        .unwrap_or_else(|| panic!("source line not quoted:\n{rendered}"));
    let caret_line = lines[at + 1];
    let gutter = lines[at].find('|').unwrap() + 2;
    let caret = caret_line
        .find('^')
        .unwrap_or_else(|| panic!("no caret:\n{rendered}"));
    let col_chars = source_line.chars().take(column - 1).count();
    assert_eq!(caret - gutter, col_chars, "caret misplaced:\n{rendered}");
    rendered
}

#[test]
fn unknown_function_suggests_the_closest() {
    let r = expect_error(
        "x + sn(y)",
        ErrorKind::UnknownFunction,
        1,
        5,
        "unknown function `sn`, did you mean `sin`?",
    );
    assert!(r.contains("did you mean `sin`?"));
    expect_error(
        "squirt(x)",
        ErrorKind::UnknownFunction,
        1,
        1,
        "unknown function `squirt`",
    );
}

#[test]
fn unknown_name_suggests_a_binding_or_variable() {
    let r = expect_error(
        "let radius = 2; x^2 - radus",
        ErrorKind::UnknownName,
        1,
        23,
        "unknown name `radus`",
    );
    assert!(r.contains("did you mean `radius`?"), "{r}");
    expect_error("x + w", ErrorKind::UnknownName, 1, 5, "unknown name `w`");
}

#[test]
fn use_before_let_is_explained() {
    expect_error(
        "let a = b; let b = 1; a",
        ErrorKind::UnknownName,
        1,
        9,
        "used before its `let`",
    );
}

#[test]
fn wrong_arity() {
    expect_error(
        "atan2(y)",
        ErrorKind::WrongArity,
        1,
        1,
        "`atan2` takes 2 arguments, but 1 was given",
    );
    expect_error(
        "x + sin(x, y)",
        ErrorKind::WrongArity,
        1,
        5,
        "`sin` takes 1 argument, but 2 were given",
    );
    expect_error("max(x)", ErrorKind::WrongArity, 1, 1, "2 or more arguments");
    expect_error("cos()", ErrorKind::WrongArity, 1, 1, "but 0 were given");
}

#[test]
fn malformed_numbers() {
    expect_error(
        "x + 1.2.3",
        ErrorKind::MalformedNumber,
        1,
        5,
        "malformed number `1.2.3`",
    );
    expect_error(
        "2x + 1",
        ErrorKind::MalformedNumber,
        1,
        1,
        "malformed number `2x`",
    );
    expect_error(
        "1e+ y",
        ErrorKind::MalformedNumber,
        1,
        1,
        "malformed number `1e+`",
    );
}

#[test]
fn unbalanced_parentheses() {
    let r = expect_error(
        "(x + (y - 1)",
        ErrorKind::UnclosedParenthesis,
        1,
        13,
        "unclosed parenthesis",
    );
    assert!(r.contains("never closed"), "{r}");
    expect_error(
        "x + y)",
        ErrorKind::UnmatchedParenthesis,
        1,
        6,
        "unmatched `)`",
    );
}

#[test]
fn trailing_input() {
    expect_error(
        "x^2 y",
        ErrorKind::TrailingInput,
        1,
        5,
        "after a complete expression",
    );
    expect_error(
        "x + 1 2",
        ErrorKind::TrailingInput,
        1,
        7,
        "after a complete expression",
    );
}

#[test]
fn empty_input() {
    expect_error("", ErrorKind::EmptyInput, 1, 1, "empty formula");
    expect_error(
        "  # just a comment\n",
        ErrorKind::EmptyInput,
        1,
        19,
        "empty formula",
    );
}

#[test]
fn unexpected_end_and_tokens() {
    expect_error("x^2 +", ErrorKind::UnexpectedEnd, 1, 6, "unexpected end");
    expect_error(
        "let a = 1;",
        ErrorKind::UnexpectedEnd,
        1,
        11,
        "ends after its `let` bindings",
    );
    expect_error(
        "let a = 1 x",
        ErrorKind::UnexpectedToken,
        1,
        11,
        "unexpected name `x`",
    );
    expect_error(
        "x * / y",
        ErrorKind::UnexpectedToken,
        1,
        5,
        "unexpected `/`",
    );
}

#[test]
fn invalid_characters() {
    expect_error(
        "x $ y",
        ErrorKind::InvalidCharacter,
        1,
        3,
        "unexpected character `$`",
    );
    expect_error(
        "x + é",
        ErrorKind::InvalidCharacter,
        1,
        5,
        "unexpected character `é`",
    );
}

#[test]
fn names_used_as_the_wrong_thing() {
    expect_error(
        "sin + 1",
        ErrorKind::MissingArguments,
        1,
        1,
        "`sin` is a function",
    );
    expect_error(
        "x(y + 1)",
        ErrorKind::NotAFunction,
        1,
        1,
        "`x` is not a function",
    );
    expect_error(
        "let pi = 3; pi",
        ErrorKind::ReservedName,
        1,
        5,
        "`pi` is built in",
    );
    expect_error(
        "x + dx",
        ErrorKind::DirectionInSurface,
        1,
        5,
        "x, y and z only",
    );
}

#[test]
fn errors_on_later_lines_report_their_line() {
    let src = "# a sphere\nlet r = 1;\nx^2 + y^2 + z^2 - r^2 +\n  cos(x) + foo(y)\n";
    expect_error(
        src,
        ErrorKind::UnknownFunction,
        4,
        12,
        "unknown function `foo`",
    );
}

#[test]
fn no_input_panics() {
    // A sweep of fragments and their concatenations: any error is fine, a
    // panic is not.
    let pieces = [
        "x", "(", ")", "+", "-", "*", "/", "^", ",", "1", "1e", ".", "let", "=", ";", "sin", "min",
        "#", "\n", "é", "$", " ",
    ];
    for a in pieces {
        for b in pieces {
            for c in pieces {
                let src = format!("{a}{b}{c}");
                let result = std::panic::catch_unwind(|| Formula::parse(&src).map(|_| ()));
                assert!(result.is_ok(), "`{src}` panicked");
                if let Ok(Err(e)) = result {
                    assert!(!e.render(&src, "<formula>").is_empty());
                }
            }
        }
    }
}

#[test]
fn numbers_beyond_f64_are_refused_not_read_as_zero_or_infinity() {
    // `1e-400` was read as 0, so `x*1e-400*1e300` was the constant 0.
    expect_error(
        "x*1e-400*1e300 - 1",
        ErrorKind::NumberOutOfRange,
        1,
        3,
        "beyond f64's range",
    );
    expect_error("y + 1e400", ErrorKind::NumberOutOfRange, 1, 5, "`1e400`");
    // The least subnormal and an exact 0 with a large exponent are numbers.
    assert!(Formula::parse("5e-324*x + 0e-999").is_ok());
}
