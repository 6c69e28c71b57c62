//! Errors in formula text, each with the span it points at.

use super::ast::Span;
use codespan_reporting::diagnostic::{Diagnostic, Label};
use codespan_reporting::files::SimpleFile;
use codespan_reporting::term::{self, Chars, Config};

/// What kind of mistake a [`FormulaError`] reports.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ErrorKind {
    /// A character that starts no token.
    InvalidCharacter,
    /// Text that starts like a number but is not one.
    MalformedNumber,
    /// A number beyond f64's range: too large, or too small to be told
    /// from 0.
    NumberOutOfRange,
    /// A token where the grammar expected something else.
    UnexpectedToken,
    /// The text ended in the middle of an expression.
    UnexpectedEnd,
    /// A `(` without its `)`.
    UnclosedParenthesis,
    /// A `)` without its `(`.
    UnmatchedParenthesis,
    /// More text after a complete formula.
    TrailingInput,
    /// Nothing but white space and comments.
    EmptyInput,
    /// A call of a function the language does not have.
    UnknownFunction,
    /// A name that is no variable, constant or `let` binding.
    UnknownName,
    /// A function called with the wrong number of arguments.
    WrongArity,
    /// A variable, constant or binding called like a function.
    NotAFunction,
    /// A function name used without arguments.
    MissingArguments,
    /// A `let` that tries to rebind a built-in name.
    ReservedName,
    /// The ray direction `dx`, `dy`, `dz` used in a surface formula.
    DirectionInSurface,
    /// A value of the wrong kind: a tuple for a number, a formula for a constant…
    WrongType,
    /// A block kind or field name that scene files do not have.
    UnknownKeyword,
    /// A required field left out.
    MissingField,
    /// A field given twice.
    RepeatedField,
    /// An object without a box to bound it.
    MissingBox,
    /// A scene with nothing to render.
    EmptyScene,
    /// User functions nested too deeply.
    TooDeep,
    /// A text longer than lgc reads (see [`crate::lang::MAX_TOKENS`]).
    TooLong,
    /// A formula whose graph, or its derivatives' graph, would pass the node
    /// limit (see [`crate::expr::MAX_NODES`]).
    TooLarge,
    /// A value outside its allowed range (a negative index of refraction…).
    OutOfRange,
    /// A camera that cannot be placed: the eye at the look-at point, up
    /// parallel to the view, a field of view out of range.
    BadCamera,
    /// A function a proof's checker does not read (see `docs/bounds.md`).
    NotInProofLanguage,
}

/// A mistake in formula text: what, where, and what would have been right.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{message}")]
pub struct FormulaError {
    /// The class of mistake.
    pub kind: ErrorKind,
    /// The byte range the caret points at.
    pub span: Span,
    /// One line saying what is wrong.
    pub message: String,
    /// Text under the caret: usually what was expected.
    pub label: String,
    /// Further help, such as a suggestion.
    pub notes: Vec<String>,
    /// A second location worth showing (the `(` that was never closed).
    pub related: Option<Box<(Span, String)>>,
}

impl FormulaError {
    /// An error of `kind` at `span`.
    pub fn new(kind: ErrorKind, span: Span, message: impl Into<String>) -> Self {
        Self {
            kind,
            span,
            message: message.into(),
            label: String::new(),
            notes: Vec::new(),
            related: None,
        }
    }

    /// A graph too large to build, reached at `span`: `what` ("the formula")
    /// would pass `e`'s limit.
    pub fn too_large(span: Span, what: &str, e: crate::expr::GraphTooLarge) -> Self {
        Self::new(
            ErrorKind::TooLarge,
            span,
            format!("too large to build: {what} would pass {} expression nodes", e.limit),
        )
        .with_label("the limit was reached here")
        .with_note("lgc bounds the memory a formula takes: make it smaller, or split it into objects of a scene")
    }

    /// Sets the text shown under the caret.
    pub fn with_label(mut self, label: impl Into<String>) -> Self {
        self.label = label.into();
        self
    }

    /// Adds a note below the source excerpt.
    pub fn with_note(mut self, note: impl Into<String>) -> Self {
        self.notes.push(note.into());
        self
    }

    /// Adds a secondary location.
    pub fn with_related(mut self, span: Span, label: impl Into<String>) -> Self {
        self.related = Some(Box::new((span, label.into())));
        self
    }

    /// The 1-based line and column (in characters) where the error starts.
    pub fn line_column(&self, source: &str) -> (usize, usize) {
        line_column(source, self.span.start)
    }

    /// Renders the error as text: message, `origin:line:column`, the source
    /// line and a caret under the span, then the notes.
    pub fn render(&self, source: &str, origin: &str) -> String {
        // A line too long to show (a generated formula on one line) is
        // located, not printed.
        let start = self.span.start.min(source.len());
        let line_start = source[..start].rfind('\n').map_or(0, |i| i + 1);
        let line_end = source[start..]
            .find('\n')
            .map_or(source.len(), |i| start + i);
        if line_end - line_start > MAX_SHOWN_LINE {
            let (line, column) = self.line_column(source);
            let mut text = format!(
                "error: {}\n  --> {origin}:{line}:{column}\n  = the line is {} bytes long, too long to show\n",
                self.message,
                line_end - line_start
            );
            for note in &self.notes {
                text += &format!("  = {note}\n");
            }
            return text;
        }
        let shown = visible(source);
        let source = shown.as_str();
        let file = SimpleFile::new(origin, source);
        let clamp = |s: &Span| {
            s.start.min(source.len())..s.end.min(source.len()).max(s.start.min(source.len()))
        };
        let mut labels = vec![Label::primary((), clamp(&self.span)).with_message(&self.label)];
        if let Some((span, text)) = self.related.as_deref() {
            labels.push(Label::secondary((), clamp(span)).with_message(text));
        }
        let diagnostic = Diagnostic::error()
            .with_message(&self.message)
            .with_labels(labels)
            .with_notes(self.notes.clone());
        let config = Config {
            chars: Chars::ascii(),
            ..Config::default()
        };
        term::emit_into_string(&config, &file, &diagnostic)
            .unwrap_or_else(|_| format!("error: {}\n", self.message))
    }
}

/// The longest source line an error shows, in bytes.
const MAX_SHOWN_LINE: usize = 4096;

/// Whether `c` shows nothing where it stands: a control or format
/// character, or a space other than the ASCII ones.
pub(crate) fn is_invisible(c: char) -> bool {
    (c.is_control() && !matches!(c, '\n' | '\t' | '\r'))
        || (c.is_whitespace() && !matches!(c, ' ' | '\n' | '\t' | '\r'))
        || matches!(c, '\u{200b}'..='\u{200f}' | '\u{2060}'..='\u{2064}' | '\u{feff}' | '\u{00ad}')
}

/// `source` with each invisible character replaced by a visible one of the
/// same length in bytes, so that spans still hold and a caret under one
/// shows.
fn visible(source: &str) -> String {
    source
        .chars()
        .map(|c| {
            if !is_invisible(c) {
                return c;
            }
            match c.len_utf8() {
                1 => '?',
                2 => '\u{00bf}', // ¿
                3 => '\u{2423}', // ␣
                _ => '\u{1f6ab}',
            }
        })
        .collect()
}
/// The line and column of byte `at` of `source`, each counted from 1,
/// columns in characters.
pub fn line_column(source: &str, at: usize) -> (usize, usize) {
    let start = at.min(source.len());
    let before = &source[..start];
    let line = before.matches('\n').count() + 1;
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    (line, source[line_start..start].chars().count() + 1)
}
