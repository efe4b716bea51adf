//! Source files, spans and diagnostics.
//!
//! Every problem with a graph file becomes a [`Diagnostic`] that names the node (when there is
//! one) and carries a byte span into the file; rendering turns the span into `file:line:column`
//! and shows the offending line with a caret (miette's graphical handler).

use std::fmt;
use std::sync::Arc;

/// Formats a number for a message: plain when short, scientific when huge or tiny, so that
/// `1e300` does not print three hundred digits.
pub fn number(v: f64) -> String {
    let a = v.abs();
    if v.is_finite() && a != 0.0 && !(1e-4..1e15).contains(&a) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

/// A half-open byte range `start..end` into a [`SourceFile`]'s text.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub struct Span {
    pub start: usize,
    pub end: usize,
}

impl Span {
    pub fn new(start: usize, end: usize) -> Span {
        Span { start, end }
    }

    /// The smallest span that covers both.
    pub fn to(self, other: Span) -> Span {
        Span::new(self.start.min(other.start), self.end.max(other.end))
    }
}

/// A value together with where it was written.
#[derive(Clone, Debug, PartialEq)]
pub struct Spanned<T> {
    pub value: T,
    pub span: Span,
}

/// A graph file's name (as the user typed it) and text.
#[derive(Debug, PartialEq)]
pub struct SourceFile {
    pub name: String,
    pub text: String,
}

impl SourceFile {
    pub fn new(name: impl Into<String>, text: impl Into<String>) -> Arc<SourceFile> {
        Arc::new(SourceFile {
            name: name.into(),
            text: text.into(),
        })
    }

    /// 1-based line and column (in characters) of a byte offset.
    pub fn line_col(&self, offset: usize) -> (usize, usize) {
        let offset = offset.min(self.text.len());
        let before = &self.text[..floor_char_boundary(&self.text, offset)];
        let line = before.matches('\n').count() + 1;
        let line_start = before.rfind('\n').map_or(0, |i| i + 1);
        let column = before[line_start..].chars().count() + 1;
        (line, column)
    }
}

fn floor_char_boundary(text: &str, mut offset: usize) -> usize {
    while offset > 0 && !text.is_char_boundary(offset) {
        offset -= 1;
    }
    offset
}

/// What went wrong, by class. The class is part of the rendered message (`error[class]`), so
/// tests and scripts can tell the classes apart without parsing prose.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DiagnosticClass {
    Syntax,
    UnknownKind,
    UnknownReference,
    WrongComponent,
    Type,
    Cycle,
    BadParameter,
    MissingArgument,
    UnknownArgument,
    DuplicateName,
    Limit,
    NotConstant,
    UnknownOutput,
    UnknownParam,
    BadName,
    NotDifferentiable,
    MissingFile,
}

impl DiagnosticClass {
    pub fn code(self) -> &'static str {
        match self {
            DiagnosticClass::Syntax => "syntax",
            DiagnosticClass::UnknownKind => "unknown-kind",
            DiagnosticClass::UnknownReference => "unknown-reference",
            DiagnosticClass::WrongComponent => "wrong-component",
            DiagnosticClass::Type => "type",
            DiagnosticClass::Cycle => "cycle",
            DiagnosticClass::BadParameter => "bad-parameter",
            DiagnosticClass::MissingArgument => "missing-argument",
            DiagnosticClass::UnknownArgument => "unknown-argument",
            DiagnosticClass::DuplicateName => "duplicate-name",
            DiagnosticClass::Limit => "limit",
            DiagnosticClass::NotConstant => "not-constant",
            DiagnosticClass::UnknownOutput => "unknown-output",
            DiagnosticClass::UnknownParam => "unknown-param",
            DiagnosticClass::BadName => "bad-name",
            DiagnosticClass::NotDifferentiable => "not-differentiable",
            DiagnosticClass::MissingFile => "missing-file",
        }
    }
}

/// One problem with a graph file.
#[derive(Clone, Debug, PartialEq)]
pub struct Diagnostic {
    pub class: DiagnosticClass,
    /// The node id (or `outputs.NAME`, `params.NAME`) the problem belongs to.
    pub node: Option<String>,
    pub message: String,
    pub span: Option<Span>,
    /// Short text under the caret.
    pub label: Option<String>,
    pub help: Option<String>,
    /// The file the span is in when it is not the reported file: a problem inside an imported
    /// graph, located in that graph's own file.
    pub file: Option<Arc<SourceFile>>,
    /// Where that file was imported, innermost first: `floor.ron:12:9` (rendered as
    /// `imported from floor.ron:12:9`).
    pub chain: Vec<String>,
}

/// Text for a message, with characters that would not show as themselves escaped (`\u{1e}`,
/// `\t`, a right-to-left override): messages quote names from the file, and a name with an
/// invisible character in it must not read like the name it only resembles.
fn printable(text: String) -> String {
    let hidden = |c: char| c.is_control() || (c.escape_debug().len() > 1 && !"\"'\\".contains(c));
    if !text.chars().any(hidden) {
        return text;
    }
    text.chars()
        .map(|c| {
            if hidden(c) {
                c.escape_debug().to_string()
            } else {
                c.to_string()
            }
        })
        .collect()
}

impl Diagnostic {
    pub fn new(class: DiagnosticClass, message: impl Into<String>) -> Diagnostic {
        Diagnostic {
            class,
            node: None,
            message: printable(message.into()),
            span: None,
            label: None,
            help: None,
            file: None,
            chain: Vec::new(),
        }
    }

    /// The same problem seen from a file that imports `inner` at `at` (`file:line:col`): its
    /// location stays in the innermost file, and the import chain grows by one link.
    pub fn imported(mut self, inner: &Arc<SourceFile>, at: String) -> Diagnostic {
        if self.file.is_none() {
            self.file = Some(inner.clone());
        }
        self.chain.push(at);
        self
    }

    pub fn at(mut self, span: Span) -> Diagnostic {
        self.span = Some(span);
        self
    }

    pub fn in_node(mut self, node: impl Into<String>) -> Diagnostic {
        self.node = Some(printable(node.into()));
        self
    }

    pub fn label(mut self, label: impl Into<String>) -> Diagnostic {
        self.label = Some(printable(label.into()));
        self
    }

    pub fn help(mut self, help: impl Into<String>) -> Diagnostic {
        self.help = Some(printable(help.into()));
        self
    }

    pub fn headline(&self) -> String {
        match &self.node {
            Some(node) => format!("node \"{node}\": {}", self.message),
            None => self.message.clone(),
        }
    }
}

/// All the problems found in one file. This is the error type of checking and compiling.
#[derive(Clone, Debug)]
pub struct Diagnostics {
    pub file: Arc<SourceFile>,
    pub list: Vec<Diagnostic>,
}

impl Diagnostics {
    /// Renders every diagnostic without colour: `error[class]: file:line:col: node "id": message`,
    /// then the source line with a caret. Stable text, compared by the error goldens.
    pub fn render_plain(&self) -> String {
        self.render(false)
    }

    /// Where `diagnostic` (one of this list) is: the file it is in (an imported graph's own
    /// file, else the reported one) and its 1-based line and column, when it has a span.
    pub fn location<'a>(
        &'a self,
        diagnostic: &'a Diagnostic,
    ) -> (&'a SourceFile, Option<(usize, usize)>) {
        let file = diagnostic.file.as_deref().unwrap_or(&self.file);
        (file, diagnostic.span.map(|span| file.line_col(span.start)))
    }

    /// Renders with colour when `colour` is set (for terminals).
    pub fn render(&self, colour: bool) -> String {
        use miette::{GraphicalReportHandler, GraphicalTheme};
        let theme = if colour {
            GraphicalTheme::unicode()
        } else {
            GraphicalTheme::unicode_nocolor()
        };
        let handler = GraphicalReportHandler::new_themed(theme)
            .with_width(100)
            .with_links(false);
        let mut out = String::new();
        for diagnostic in &self.list {
            let (file, at) = self.location(diagnostic);
            let location = match at {
                Some((line, column)) => format!("{}:{line}:{column}", file.name),
                None => file.name.clone(),
            };
            out.push_str(&format!(
                "error[{}]: {location}: {}\n",
                diagnostic.class.code(),
                diagnostic.headline()
            ));
            let report = MietteReport {
                diagnostic,
                file,
                source: WindowedSource(&file.text),
            };
            let mut body = String::new();
            // Rendering into a String cannot fail; if miette ever did, the headline above
            // already carries the location and message.
            let _ = handler.render_report(&mut body, &report);
            // miette's headline is empty (ours, above, carries the message); drop its line and
            // keep the snippet.
            let snippet: Vec<&str> = body.lines().skip(1).collect();
            let snippet = snippet.join("\n");
            let snippet = snippet.trim_matches('\n');
            if !snippet.trim().is_empty() {
                out.push_str(snippet);
                out.push('\n');
            }
            for link in &diagnostic.chain {
                out.push_str(&format!("  imported from {link}\n"));
            }
        }
        out
    }
}

impl fmt::Display for Diagnostics {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.render_plain())
    }
}

impl std::error::Error for Diagnostics {}

/// Adapter from our diagnostic to miette's trait, used only for rendering.
struct MietteReport<'a> {
    diagnostic: &'a Diagnostic,
    file: &'a SourceFile,
    source: WindowedSource<'a>,
}

impl fmt::Debug for MietteReport<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.diagnostic.message)
    }
}

impl fmt::Display for MietteReport<'_> {
    fn fmt(&self, _: &mut fmt::Formatter<'_>) -> fmt::Result {
        // Empty: our own headline line is printed before the snippet, and a long headline here
        // would be wrapped by miette into several lines.
        Ok(())
    }
}

impl std::error::Error for MietteReport<'_> {}

impl miette::Diagnostic for MietteReport<'_> {
    fn help<'b>(&'b self) -> Option<Box<dyn fmt::Display + 'b>> {
        self.diagnostic
            .help
            .as_ref()
            .map(|h| Box::new(h) as Box<dyn fmt::Display>)
    }

    fn source_code(&self) -> Option<&dyn miette::SourceCode> {
        self.diagnostic
            .span
            .map(|_| &self.source as &dyn miette::SourceCode)
    }

    fn labels(&self) -> Option<Box<dyn Iterator<Item = miette::LabeledSpan> + '_>> {
        let span = self.diagnostic.span?;
        let text = &self.file.text;
        let start = floor_char_boundary(text, span.start.min(text.len()));
        // A label never runs past the end of its first line, nor past the window shown.
        let line_end = text[start..].find('\n').map_or(text.len(), |i| start + i);
        let end = span.end.max(start + 1).min(line_end).min(start + WINDOW);
        let end = floor_char_boundary(text, end.max(start));
        let label = miette::LabeledSpan::new(self.diagnostic.label.clone(), start, end - start);
        Some(Box::new(std::iter::once(label)))
    }
}

/// Lines longer than this are shown as a window around the problem, not whole (a file of one
/// megabyte-long line must not print a megabyte).
const WINDOW: usize = 120;

/// The file's text as miette reads it: whole lines, except that a long line is cut to a window
/// around the span, with miette told the window's true line and column.
struct WindowedSource<'a>(&'a str);

impl miette::SourceCode for WindowedSource<'_> {
    fn read_span<'a>(
        &'a self,
        span: &miette::SourceSpan,
        before: usize,
        after: usize,
    ) -> Result<Box<dyn miette::SpanContents<'a> + 'a>, miette::MietteError> {
        let text = self.0;
        let start = floor_char_boundary(text, span.offset().min(text.len()));
        let line_start = text[..start].rfind('\n').map_or(0, |i| i + 1);
        let line_end = text[start..].find('\n').map_or(text.len(), |i| start + i);
        // Context lines could be long too: only short neighbourhoods are shown whole.
        let context_start = text[..line_start.saturating_sub(1)]
            .rfind('\n')
            .map_or(0, |i| i + 1);
        let context_end = text[line_end..]
            .get(1..)
            .and_then(|rest| rest.find('\n'))
            .map_or(text.len(), |i| line_end + 1 + i);
        if context_end - context_start <= 4 * WINDOW {
            let contents = text.read_span(span, before, after)?;
            if before != 0 {
                return Ok(contents);
            }
            // miette counts the primary span's column in bytes; the diagnostic's own
            // `file:line:column` counts characters, and the two must agree.
            let column = text[line_start..start].chars().count();
            return Ok(Box::new(miette::MietteSpanContents::new(
                contents.data(),
                *contents.span(),
                contents.line(),
                column,
                contents.line_count(),
            )));
        }
        let from = floor_char_boundary(text, start.saturating_sub(WINDOW / 2).max(line_start));
        let to = floor_char_boundary(text, (start + WINDOW).min(line_end)).max(from);
        let line = text[..line_start].matches('\n').count();
        let column = text[line_start..from].chars().count();
        Ok(Box::new(miette::MietteSpanContents::new(
            &text.as_bytes()[from..to],
            miette::SourceSpan::new(from.into(), to - from),
            line,
            column,
            1,
        )))
    }
}

/// What a command or option says in a build without the cargo feature it needs (`zarr`,
/// `serve`): `what` (the command or option) and how to get it.
#[cfg(not(all(feature = "zarr", feature = "serve")))]
pub(crate) fn without_feature(what: &str, feature: &str) -> String {
    format!("{what}: this texgraph was built without its `{feature}` feature (build with the default features, or `--features {feature}`)")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_col_counts_from_one() {
        let file = SourceFile::new("a.ron", "ab\ncd\n");
        assert_eq!(file.line_col(0), (1, 1));
        assert_eq!(file.line_col(3), (2, 1));
        assert_eq!(file.line_col(4), (2, 2));
        assert_eq!(file.line_col(999), (3, 1));
    }

    #[test]
    fn render_names_file_line_column_and_node() {
        let file = SourceFile::new("g.ron", "Graph(\n  nodes: { \"a\": Sinn(1) },\n)\n");
        let diagnostics = Diagnostics {
            file,
            list: vec![
                Diagnostic::new(DiagnosticClass::UnknownKind, "unknown node kind `Sinn`")
                    .in_node("a")
                    .at(Span::new(21, 25))
                    .label("not a node kind")
                    .help("did you mean `Sin`?"),
            ],
        };
        let text = diagnostics.render_plain();
        assert!(
            text.starts_with(
                "error[unknown-kind]: g.ron:2:15: node \"a\": unknown node kind `Sinn`"
            ),
            "{text}"
        );
        assert!(text.contains("Sinn(1)"), "{text}");
        assert!(text.contains("did you mean `Sin`?"), "{text}");
    }
}
