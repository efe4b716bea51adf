//! Stage 1, parse: graph file text → a generic RON value tree in which every value keeps its span.
//!
//! Why not `ron::from_str`: the `ron` crate's generic `ron::Value` drops struct and enum names
//! (`Sin("x")` and `Cos("x")` both become a bare sequence) and carries no positions, and typed
//! deserialisation stops at the first problem. Diagnostics must name the node, its line and column,
//! and list every problem at once, so this small reader keeps names and spans. It accepts the RON
//! grammar that graph files use (structs, tuples, lists, maps, strings, numbers, identifiers,
//! comments, trailing commas, `#![enable(...)]` headers); a test parses every file in `graphs/`
//! with the `ron` crate too, so the files stay valid RON for other tools.

// A syntax error ends parsing and is built once per file; boxing it would buy nothing.
#![allow(clippy::result_large_err)]

use crate::diagnostic::{Diagnostic, DiagnosticClass, Span, Spanned};
use crate::limits;

/// Names and strings of a graph file: short ones (node ids, kinds, field names) are stored
/// inline, without a heap allocation, which is most of what parsing a large graph costs.
pub type Text = compact_str::CompactString;

/// A RON value with the span it was written at.
#[derive(Clone, Debug, PartialEq)]
pub struct Value {
    pub kind: ValueKind,
    pub span: Span,
}

#[derive(Clone, Debug, PartialEq)]
pub enum ValueKind {
    Number(f64),
    Bool(bool),
    Str(Text),
    /// A bare identifier: a unit struct or enum variant such as `Position` or `Perlin`.
    Ident(Text),
    /// `(a, b)` or `Name(a, b)`; `Name()` has no items.
    Tuple {
        name: Option<Spanned<Text>>,
        items: Vec<Value>,
    },
    /// `(a: 1)` or `Name(a: 1, b: 2)`.
    Struct {
        name: Option<Spanned<Text>>,
        fields: Vec<(Spanned<Text>, Value)>,
    },
    List(Vec<Value>),
    Map(Vec<(Value, Value)>),
}

impl ValueKind {
    /// How the value is described in "expected X, found Y" messages.
    pub fn describe(&self) -> String {
        match self {
            ValueKind::Number(_) => "a number".into(),
            ValueKind::Bool(_) => "a boolean".into(),
            ValueKind::Str(s) => format!("the string \"{s}\""),
            ValueKind::Ident(name) => format!("`{name}`"),
            ValueKind::Tuple { name: Some(n), .. } | ValueKind::Struct { name: Some(n), .. } => {
                format!("`{}(...)`", n.value)
            }
            ValueKind::Tuple { .. } => "a tuple".into(),
            ValueKind::Struct { .. } => "a struct".into(),
            ValueKind::List(_) => "a list".into(),
            ValueKind::Map(_) => "a map".into(),
        }
    }
}

/// Parses a whole file: exactly one value, then only whitespace and comments.
pub fn parse(text: &str) -> Result<Value, Diagnostic> {
    parse_boxed(text).map_err(|e| *e)
}

/// The parser's error, boxed: the parser recurses once per nesting level (up to
/// `limits::MAX_NESTING`), and a small error type keeps each level's frame small (test threads
/// have 2 MiB stacks, and debug builds keep every temporary).
type Failure = Box<Diagnostic>;

fn parse_boxed(text: &str) -> Result<Value, Failure> {
    if text.len() > limits::MAX_FILE_BYTES {
        return Err(Box::new(Diagnostic::new(
            DiagnosticClass::Limit,
            format!(
                "the file is {} bytes; graph files are limited to {} bytes",
                text.len(),
                limits::MAX_FILE_BYTES
            ),
        )));
    }
    let mut parser = Parser {
        text,
        bytes: text.as_bytes(),
        // A UTF-8 byte-order mark, as some editors write, is not part of the graph.
        pos: if text.starts_with('\u{feff}') { 3 } else { 0 },
        depth: 0,
    };
    parser.skip_trivia()?;
    parser.skip_attributes()?;
    if parser.pos >= parser.bytes.len() {
        return Err(Box::new(
            Diagnostic::new(
                DiagnosticClass::Syntax,
                "the file holds no graph (only whitespace and comments)",
            )
            .at(Span::new(0, 0))
            .label("a graph was expected")
            .help("a graph file is `Graph(nodes: { ... }, outputs: { ... })`"),
        ));
    }
    let value = parser.value()?;
    parser.skip_trivia()?;
    if parser.pos < parser.bytes.len() {
        return Err(Box::new(parser.error_here(
            "unexpected text after the graph",
            "expected end of file",
        )));
    }
    Ok(value)
}

/// A character as a message shows it: in backticks, escaped when invisible or a control code.
fn shown(text: &str) -> String {
    let escaped: String = text.chars().flat_map(|c| c.escape_debug()).collect();
    if escaped != text || text.chars().any(|c| c.is_whitespace() || c == '\u{feff}') {
        format!(
            "`{}` ({})",
            escaped,
            text.chars()
                .map(|c| format!("U+{:04X}", c as u32))
                .collect::<Vec<_>>()
                .join(" ")
        )
    } else {
        format!("`{text}`")
    }
}

struct Parser<'a> {
    text: &'a str,
    bytes: &'a [u8],
    pos: usize,
    depth: usize,
}

impl<'a> Parser<'a> {
    fn error_at(
        &self,
        span: Span,
        message: impl Into<String>,
        label: impl Into<String>,
    ) -> Diagnostic {
        Diagnostic::new(DiagnosticClass::Syntax, message)
            .at(span)
            .label(label)
    }

    fn error_here(&self, message: impl Into<String>, label: impl Into<String>) -> Diagnostic {
        let end = self.next_char_end();
        self.error_at(Span::new(self.pos, end), message, label)
    }

    fn next_char_end(&self) -> usize {
        self.text[self.pos..]
            .chars()
            .next()
            .map_or(self.pos, |c| self.pos + c.len_utf8())
    }

    fn peek(&self) -> Option<u8> {
        self.bytes.get(self.pos).copied()
    }

    fn peek_at(&self, offset: usize) -> Option<u8> {
        self.bytes.get(self.pos + offset).copied()
    }

    /// Skips whitespace, `// line` and `/* block */` comments (block comments nest, as in RON).
    fn skip_trivia(&mut self) -> Result<(), Failure> {
        loop {
            match self.peek() {
                Some(b' ' | b'\t' | b'\n' | b'\r') => self.pos += 1,
                Some(b'/') if self.peek_at(1) == Some(b'/') => {
                    while let Some(c) = self.peek() {
                        if c == b'\n' {
                            break;
                        }
                        self.pos += 1;
                    }
                }
                Some(b'/') if self.peek_at(1) == Some(b'*') => {
                    let start = self.pos;
                    self.pos += 2;
                    let mut level = 1usize;
                    while level > 0 {
                        match (self.peek(), self.peek_at(1)) {
                            (Some(b'*'), Some(b'/')) => {
                                level -= 1;
                                self.pos += 2;
                            }
                            (Some(b'/'), Some(b'*')) => {
                                level += 1;
                                self.pos += 2;
                            }
                            (Some(_), _) => self.pos += 1,
                            (None, _) => {
                                return Err(Box::new(self.error_at(
                                    Span::new(start, start + 2),
                                    "unterminated block comment",
                                    "this comment is never closed",
                                )))
                            }
                        }
                    }
                }
                _ => return Ok(()),
            }
        }
    }

    /// `#![enable(...)]` extension headers are accepted and ignored: graph files need none.
    fn skip_attributes(&mut self) -> Result<(), Failure> {
        while self.peek() == Some(b'#') {
            let start = self.pos;
            while let Some(c) = self.peek() {
                self.pos += 1;
                if c == b']' {
                    break;
                }
            }
            if self.bytes.get(self.pos - 1) != Some(&b']') {
                return Err(Box::new(self.error_at(
                    Span::new(start, self.pos),
                    "unterminated attribute",
                    "expected `]`",
                )));
            }
            self.skip_trivia()?;
        }
        Ok(())
    }

    /// The error for a file that ends, or a wrong closing bracket that comes, before the bracket
    /// opened at `open` is closed.
    fn unclosed(&self, open: usize, close: u8) -> Diagnostic {
        let opener = self.bytes.get(open).map_or('(', |&b| b as char);
        let (line, column) = line_col(self.text, open);
        match self.peek() {
            None => self
                .error_at(
                    Span::new(open, open + 1),
                    format!("unexpected end of file: this `{opener}` is never closed"),
                    format!("expected a matching `{}`", close as char),
                )
                .help(format!(
                    "add `{}` at the end of what `{opener}` opens",
                    close as char
                )),
            Some(c) => self
                .error_here(
                    format!(
                        "`{}` does not close the `{opener}` opened at line {line}, column {column}",
                        c as char
                    ),
                    format!("expected `,` or `{}`", close as char),
                )
                .help(format!(
                    "close the `{opener}` with `{}` first",
                    close as char
                )),
        }
    }

    fn expect(&mut self, byte: u8, what: &str) -> Result<(), Failure> {
        self.skip_trivia()?;
        if self.peek() == Some(byte) {
            self.pos += 1;
            Ok(())
        } else if self.pos >= self.bytes.len() {
            Err(Box::new(self.error_at(
                Span::new(self.pos, self.pos),
                format!("unexpected end of file, expected {what}"),
                format!("expected {what}"),
            )))
        } else {
            Err(Box::new(self.error_here(
                format!("expected {what}"),
                format!("expected {what}"),
            )))
        }
    }

    fn value(&mut self) -> Result<Value, Failure> {
        self.skip_trivia()?;
        let start = self.pos;
        let Some(c) = self.peek() else {
            return Err(Box::new(self.error_at(
                Span::new(start, start),
                "unexpected end of file, expected a value",
                "expected a value",
            )));
        };
        match c {
            b'"' => {
                let s = self.string()?;
                Ok(Value {
                    kind: ValueKind::Str(s),
                    span: Span::new(start, self.pos),
                })
            }
            b'r' if matches!(self.peek_at(1), Some(b'"' | b'#')) => {
                let s = self.raw_string()?;
                Ok(Value {
                    kind: ValueKind::Str(s),
                    span: Span::new(start, self.pos),
                })
            }
            b'0'..=b'9' | b'-' | b'+' | b'.' => self.number(),
            b'(' => self.parenthesised(None, start),
            b'[' => self.list(),
            b'{' => self.map(),
            c if c.is_ascii_alphabetic() || c == b'_' => {
                let name = self.identifier();
                let name_span = Span::new(start, self.pos);
                match name.as_str() {
                    "true" => {
                        return Ok(Value {
                            kind: ValueKind::Bool(true),
                            span: name_span,
                        })
                    }
                    "false" => {
                        return Ok(Value {
                            kind: ValueKind::Bool(false),
                            span: name_span,
                        })
                    }
                    "inf" => {
                        return Ok(Value {
                            kind: ValueKind::Number(f64::INFINITY),
                            span: name_span,
                        })
                    }
                    "NaN" => {
                        return Ok(Value {
                            kind: ValueKind::Number(f64::NAN),
                            span: name_span,
                        })
                    }
                    _ => {}
                }
                // A name directly followed by `(` (whitespace allowed) is a named struct or tuple.
                let save = self.pos;
                self.skip_trivia()?;
                if self.peek() == Some(b'(') {
                    let name = Spanned {
                        value: name,
                        span: name_span,
                    };
                    self.parenthesised(Some(name), start)
                } else {
                    self.pos = save;
                    Ok(Value {
                        kind: ValueKind::Ident(name),
                        span: name_span,
                    })
                }
            }
            b')' | b']' | b'}' => Err(Box::new(self.error_here(
                format!("unexpected `{}`, expected a value", c as char),
                "expected a value here",
            ))),
            _ => Err(Box::new(self.error_here(
                format!(
                    "unexpected character {}",
                    shown(&self.text[self.pos..self.next_char_end()])
                ),
                "expected a value",
            ))),
        }
    }

    fn enter(&mut self, start: usize) -> Result<(), Failure> {
        self.depth += 1;
        if self.depth > limits::MAX_NESTING {
            return Err(Box::new(
                Diagnostic::new(
                    DiagnosticClass::Limit,
                    format!(
                        "values are nested more than {} levels deep",
                        limits::MAX_NESTING
                    ),
                )
                .at(Span::new(start, start + 1))
                .label("too deep")
                .help("give inner nodes an id in `nodes` and refer to them by name"),
            ));
        }
        Ok(())
    }

    fn identifier(&mut self) -> Text {
        let start = self.pos;
        self.skip_identifier();
        Text::from(&self.text[start..self.pos])
    }

    fn skip_identifier(&mut self) {
        while let Some(c) = self.peek() {
            if c.is_ascii_alphanumeric() || c == b'_' {
                self.pos += 1;
            } else {
                break;
            }
        }
    }

    fn number(&mut self) -> Result<Value, Failure> {
        let start = self.pos;
        if matches!(self.peek(), Some(b'-' | b'+')) {
            self.pos += 1;
        }
        // `-inf`, `+inf`, `-NaN`
        if self.peek().is_some_and(|c| c.is_ascii_alphabetic()) {
            let word = self.identifier();
            let negative = self.bytes[start] == b'-';
            let value = match word.as_str() {
                "inf" if negative => f64::NEG_INFINITY,
                "inf" => f64::INFINITY,
                "NaN" => f64::NAN,
                _ => {
                    return Err(Box::new(self.error_at(
                        Span::new(start, self.pos),
                        format!("`{}` is not a number", &self.text[start..self.pos]),
                        "expected a number",
                    )))
                }
            };
            return Ok(Value {
                kind: ValueKind::Number(value),
                span: Span::new(start, self.pos),
            });
        }
        while let Some(c) = self.peek() {
            let exponent_sign = matches!(c, b'-' | b'+')
                && matches!(self.bytes.get(self.pos.wrapping_sub(1)), Some(b'e' | b'E'));
            if c.is_ascii_digit()
                || c == b'.'
                || c == b'e'
                || c == b'E'
                || c == b'_'
                || exponent_sign
            {
                self.pos += 1;
            } else {
                break;
            }
        }
        let span = Span::new(start, self.pos);
        let written = &self.text[start..self.pos];
        // Digit separators (`1_000`) need a copy without them; most numbers have none.
        let without_separators: String;
        let lexeme = if written.contains('_') {
            without_separators = written.chars().filter(|&c| c != '_').collect();
            &without_separators
        } else {
            written
        };
        let lexeme = lexeme.strip_prefix('+').unwrap_or(lexeme);
        match lexeme.parse::<f64>() {
            Ok(v) if !lexeme.is_empty() && lexeme != "-" => Ok(Value {
                kind: ValueKind::Number(v),
                span,
            }),
            _ => Err(Box::new(self.error_at(
                span,
                format!("`{}` is not a number", &self.text[start..self.pos]),
                "expected a number",
            ))),
        }
    }

    fn string(&mut self) -> Result<Text, Failure> {
        let start = self.pos;
        self.pos += 1; // opening quote
                       // Fast path: no escapes (every name and reference in practice), one copy of the slice.
        let body = &self.bytes[self.pos..];
        if let Some(end) = body.iter().position(|&b| b == b'"' || b == b'\\') {
            if body[end] == b'"' {
                let text = Text::from(&self.text[self.pos..self.pos + end]);
                self.pos += end + 1;
                return Ok(text);
            }
        }
        let mut out = Text::default();
        loop {
            let Some(c) = self.text[self.pos..].chars().next() else {
                return Err(Box::new(self.error_at(
                    Span::new(start, start + 1),
                    "unterminated string",
                    "this string is never closed",
                )));
            };
            self.pos += c.len_utf8();
            match c {
                '"' => return Ok(out),
                '\\' => {
                    let escape_start = self.pos - 1;
                    let Some(e) = self.text[self.pos..].chars().next() else {
                        return Err(Box::new(self.error_at(
                            Span::new(start, start + 1),
                            "unterminated string",
                            "this string is never closed",
                        )));
                    };
                    self.pos += e.len_utf8();
                    match e {
                        '"' => out.push('"'),
                        '\\' => out.push('\\'),
                        '/' => out.push('/'),
                        'n' => out.push('\n'),
                        't' => out.push('\t'),
                        'r' => out.push('\r'),
                        '0' => out.push('\0'),
                        _ => {
                            return Err(Box::new(self.error_at(
                                Span::new(escape_start, self.pos),
                                format!("unknown escape `\\{e}` in string"),
                                "unknown escape",
                            )))
                        }
                    }
                }
                c => out.push(c),
            }
        }
    }

    fn raw_string(&mut self) -> Result<Text, Failure> {
        let start = self.pos;
        self.pos += 1; // r
        let mut hashes = 0;
        while self.peek() == Some(b'#') {
            hashes += 1;
            self.pos += 1;
        }
        if self.peek() != Some(b'"') {
            return Err(Box::new(
                self.error_here("expected `\"` in raw string", "expected `\"`"),
            ));
        }
        self.pos += 1;
        let terminator = format!("\"{}", "#".repeat(hashes));
        match self.text[self.pos..].find(&terminator) {
            Some(end) => {
                let s = Text::from(&self.text[self.pos..self.pos + end]);
                self.pos += end + terminator.len();
                Ok(s)
            }
            None => Err(Box::new(self.error_at(
                Span::new(start, start + 1),
                "unterminated raw string",
                "never closed",
            ))),
        }
    }

    /// After `(` (or `Name(`): a struct if the first item is `ident:`, else a tuple.
    fn parenthesised(
        &mut self,
        name: Option<Spanned<Text>>,
        start: usize,
    ) -> Result<Value, Failure> {
        self.enter(start)?;
        self.expect(b'(', "`(`")?;
        let open = self.pos - 1;
        self.skip_trivia()?;
        let is_struct = {
            let save = self.pos;
            let mut struct_like = false;
            if self
                .peek()
                .is_some_and(|c| c.is_ascii_alphabetic() || c == b'_')
            {
                self.skip_identifier();
                self.skip_trivia()?;
                struct_like = self.peek() == Some(b':');
            }
            self.pos = save;
            struct_like
        };
        let kind = if is_struct {
            let mut fields: Vec<(Spanned<Text>, Value)> = Vec::new();
            loop {
                self.skip_trivia()?;
                if self.peek() == Some(b')') {
                    self.pos += 1;
                    break;
                }
                if matches!(self.peek(), None | Some(b']' | b'}')) {
                    return Err(Box::new(self.unclosed(open, b')')));
                }
                let field_start = self.pos;
                if !self
                    .peek()
                    .is_some_and(|c| c.is_ascii_alphabetic() || c == b'_')
                {
                    return Err(Box::new(
                        self.error_here("expected a field name", "expected `name: value`"),
                    ));
                }
                let field = self.identifier();
                let field = Spanned {
                    value: field,
                    span: Span::new(field_start, self.pos),
                };
                self.expect(b':', "`:` after the field name")?;
                let value = self.value()?;
                fields.push((field, value));
                self.skip_trivia()?;
                match self.peek() {
                    Some(b',') => self.pos += 1,
                    Some(b')') => {}
                    None | Some(b']' | b'}') => return Err(Box::new(self.unclosed(open, b')'))),
                    _ => {
                        return Err(Box::new(self.error_here(
                            "expected `,` or `)` after the field",
                            "expected `,` or `)`",
                        )))
                    }
                }
            }
            ValueKind::Struct { name, fields }
        } else {
            let items = self.sequence(open, b')')?;
            ValueKind::Tuple { name, items }
        };
        self.depth -= 1;
        Ok(Value {
            kind,
            span: Span::new(start, self.pos),
        })
    }

    /// Comma-separated values up to `close` (trailing comma allowed); consumes `close`. `open`
    /// is where the bracket being closed was opened.
    fn sequence(&mut self, open: usize, close: u8) -> Result<Vec<Value>, Failure> {
        let mut items = Vec::new();
        loop {
            self.skip_trivia()?;
            if self.peek() == Some(close) {
                self.pos += 1;
                return Ok(items);
            }
            if matches!(self.peek(), None | Some(b')' | b']' | b'}')) {
                return Err(Box::new(self.unclosed(open, close)));
            }
            items.push(self.value()?);
            self.skip_trivia()?;
            match self.peek() {
                Some(b',') => self.pos += 1,
                Some(c) if c == close => {}
                None | Some(b')' | b']' | b'}') => {
                    return Err(Box::new(self.unclosed(open, close)))
                }
                // `Kind(a, b, name: c)`: a named argument after positional ones.
                Some(b':') if close == b')' => return Err(Box::new(self.mixed_arguments())),
                _ => {
                    return Err(Box::new(self.error_here(
                        format!("expected `,` or `{}`", close as char),
                        format!("expected `,` or `{}`", close as char),
                    )))
                }
            }
        }
    }

    /// Out of line: `sequence` recurses once per nesting level, so its frame stays small.
    #[cold]
    #[inline(never)]
    fn mixed_arguments(&self) -> Diagnostic {
        self.error_here(
            "positional and named arguments cannot be mixed",
            "a named argument after positional ones",
        )
        .help("name every argument, `Kind(input: a, clamp: true)`, or none")
    }

    fn list(&mut self) -> Result<Value, Failure> {
        let start = self.pos;
        self.enter(start)?;
        self.pos += 1;
        let items = self.sequence(start, b']')?;
        self.depth -= 1;
        Ok(Value {
            kind: ValueKind::List(items),
            span: Span::new(start, self.pos),
        })
    }

    fn map(&mut self) -> Result<Value, Failure> {
        let start = self.pos;
        self.enter(start)?;
        self.pos += 1;
        let mut entries = Vec::new();
        loop {
            self.skip_trivia()?;
            if self.peek() == Some(b'}') {
                self.pos += 1;
                break;
            }
            if matches!(self.peek(), None | Some(b')' | b']')) {
                return Err(Box::new(self.unclosed(start, b'}')));
            }
            let key = self.value()?;
            self.expect(b':', "`:` after the map key")?;
            let value = self.value()?;
            entries.push((key, value));
            self.skip_trivia()?;
            match self.peek() {
                Some(b',') => self.pos += 1,
                Some(b'}') => {}
                None | Some(b')' | b']') => return Err(Box::new(self.unclosed(start, b'}'))),
                _ => {
                    return Err(Box::new(
                        self.error_here("expected `,` or `}`", "expected `,` or `}`"),
                    ))
                }
            }
        }
        self.depth -= 1;
        Ok(Value {
            kind: ValueKind::Map(entries),
            span: Span::new(start, self.pos),
        })
    }
}

fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let before = &text[..offset.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let column = before[before.rfind('\n').map_or(0, |i| i + 1)..]
        .chars()
        .count()
        + 1;
    (line, column)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn kind(text: &str) -> ValueKind {
        parse(text).unwrap().kind
    }

    #[test]
    #[allow(clippy::approx_constant)] // a literal as authors write it, not π
    fn numbers_round_trip() {
        assert_eq!(kind("1"), ValueKind::Number(1.0));
        assert_eq!(kind("-2.5e-3"), ValueKind::Number(-2.5e-3));
        assert_eq!(kind("+4"), ValueKind::Number(4.0));
        assert_eq!(kind("1_000.5"), ValueKind::Number(1000.5));
        assert_eq!(kind("-inf"), ValueKind::Number(f64::NEG_INFINITY));
        assert_eq!(kind("3.14159265"), ValueKind::Number(3.14159265));
        assert!(parse("1.2.3").is_err());
        assert!(parse("-").is_err());
    }

    #[test]
    fn named_struct_and_tuple() {
        let ValueKind::Struct { name, fields } = kind("Scale(input: Position, by: 1.0)") else {
            panic!()
        };
        assert_eq!(name.unwrap().value, "Scale");
        assert_eq!(fields[0].0.value, "input");
        assert_eq!(fields[0].1.kind, ValueKind::Ident("Position".into()));
        let ValueKind::Tuple { name, items } = kind("Add(\"a\", (1, 2, 3),)") else {
            panic!()
        };
        assert_eq!(name.unwrap().value, "Add");
        assert_eq!(items.len(), 2);
        assert!(
            matches!(&items[1].kind, ValueKind::Tuple { name: None, items } if items.len() == 3)
        );
    }

    #[test]
    fn comments_and_spans() {
        let text = "/* a /* nested */ comment */ { \"k\" : [1, 2], } // end";
        let value = parse(text).unwrap();
        let ValueKind::Map(entries) = value.kind else {
            panic!()
        };
        assert_eq!(
            &text[entries[0].0.span.start..entries[0].0.span.end],
            "\"k\""
        );
        assert_eq!(
            &text[entries[0].1.span.start..entries[0].1.span.end],
            "[1, 2]"
        );
    }

    #[test]
    fn syntax_errors_have_positions() {
        let e = parse("Graph(nodes: { \"a\": Sin(1) ").unwrap_err();
        assert_eq!(e.class, DiagnosticClass::Syntax);
        assert!(e.span.is_some());
        let e = parse("(a: 1 b: 2)").unwrap_err();
        assert_eq!(e.span.unwrap().start, 6);
        assert!(parse("\"open").is_err());
        assert!(parse("/* open").is_err());
        assert!(parse("(1) (2)").is_err());
    }

    #[test]
    fn deep_nesting_is_a_limit_error_not_a_stack_overflow() {
        let text = format!("{}1{}", "Sin(".repeat(100_000), ")".repeat(100_000));
        let e = parse(&text).unwrap_err();
        assert_eq!(e.class, DiagnosticClass::Limit);
    }
}
