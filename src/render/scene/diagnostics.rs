//! Pointing scene problems at the scene file: paths into its spanned tree, the collector of
//! problems, and `ron`'s errors as diagnostics.

use crate::diagnostic::{Diagnostic, DiagnosticClass, Diagnostics, SourceFile, Span};
use crate::render::error::RenderError;
use crate::syntax;
use std::sync::Arc;

/// The scene file's text and generic tree, to point diagnostics at what they are about.
pub(super) struct Located<'a> {
    pub(super) source: &'a Arc<SourceFile>,
    pub(super) tree: Option<&'a syntax::Value>,
}

/// One step of a path into the scene file's tree.
#[derive(Clone, Copy, Debug)]
pub(super) enum Key<'a> {
    Field(&'a str),
    Index(usize),
    /// A map entry's value, by its string key.
    Entry(&'a str),
    /// A map entry's key itself.
    EntryName(&'a str),
}

/// The value `key` leads to from `here`, if the file has it (map keys and newtype variants are
/// `locate`'s concern).
fn step<'t>(here: &'t syntax::Value, key: &Key) -> Option<&'t syntax::Value> {
    use syntax::ValueKind as V;
    match (&here.kind, key) {
        (V::Struct { fields, .. }, Key::Field(name)) => fields
            .iter()
            .find(|(n, _)| n.value == *name)
            .map(|(_, v)| v),
        (V::List(items), Key::Index(i)) | (V::Tuple { items, .. }, Key::Index(i)) => items.get(*i),
        (V::Map(entries), Key::Entry(name)) => entries
            .iter()
            .find(|(k, _)| matches!(&k.kind, V::Str(s) if s == name))
            .map(|(_, v)| v),
        _ => None,
    }
}

/// The value at exactly `path`, if the file has it.
fn value_at<'t>(tree: &'t syntax::Value, path: &[Key]) -> Option<&'t syntax::Value> {
    path.iter().try_fold(tree, |here, key| step(here, key))
}

/// The span of the deepest value along `path` that the file has.
fn locate(tree: &syntax::Value, path: &[Key]) -> Span {
    use syntax::ValueKind as V;
    let mut here = tree;
    for key in path {
        let next = step(here, key).or_else(|| match (&here.kind, key) {
            (V::Map(entries), Key::EntryName(name)) => entries
                .iter()
                .find(|(k, _)| matches!(&k.kind, V::Str(s) if s == name))
                .map(|(k, _)| k),
            _ => None,
        });
        let next = match (next, &here.kind) {
            // A newtype variant such as `Scale(2)`: look inside.
            (None, V::Tuple { items, .. }) if items.len() == 1 && !matches!(key, Key::Index(_)) => {
                return locate(&items[0], std::slice::from_ref(key)).to(here.span)
            }
            (next, _) => next,
        };
        match next {
            Some(v) => here = v,
            None => break,
        }
    }
    here.span
}

/// Collects scene problems; each becomes a diagnostic against the scene file (or, for a scene
/// built in code, against a placeholder named after its graph).
pub(super) struct Problems<'a> {
    pub(super) located: Option<&'a Located<'a>>,
    scene: Vec<Diagnostic>,
    /// Diagnostics about other files (graphs, meshes).
    pub(super) other: Vec<Diagnostics>,
}

impl<'a> Problems<'a> {
    /// No problems yet, located in `located` when it is given.
    pub(super) fn new(located: Option<&'a Located<'a>>) -> Problems<'a> {
        Problems {
            located,
            scene: Vec::new(),
            other: Vec::new(),
        }
    }

    /// Adds a problem about the value at `path` in the scene file.
    pub(super) fn add(
        &mut self,
        class: DiagnosticClass,
        path: &[Key],
        message: String,
        help: Option<String>,
    ) {
        let mut d = Diagnostic::new(class, message);
        if let Some(Located {
            tree: Some(tree), ..
        }) = self.located
        {
            d = d.at(locate(tree, path));
        }
        if let Some(help) = help {
            d = d.help(help);
        }
        self.scene.push(d);
    }

    /// The value at exactly `path` in the scene file's tree, if the file is located and has it.
    pub(super) fn value_at(&self, path: &[Key]) -> Option<&'a syntax::Value> {
        value_at(self.located?.tree?, path)
    }

    /// Every problem collected, as one error (the scene's in file order, then the other
    /// files'), or `Ok` when there is none.
    pub(super) fn finish(&mut self) -> Result<(), RenderError> {
        if self.scene.is_empty() && self.other.is_empty() {
            return Ok(());
        }
        let mut all = Vec::new();
        if !self.scene.is_empty() {
            // In file order, as the graph checker reports.
            let mut list = std::mem::take(&mut self.scene);
            list.sort_by_key(|d| d.span.map_or(usize::MAX, |s| s.start));
            let file = match self.located {
                Some(l) => l.source.clone(),
                None => SourceFile::new("(preview scene)", ""),
            };
            all.push(Diagnostics { file, list });
        }
        all.extend(std::mem::take(&mut self.other));
        Err(RenderError::Invalid(all))
    }
}

/// A RON error as a diagnostic at its position.
pub(super) fn ron_diagnostic(
    source: &Arc<SourceFile>,
    e: &ron::error::SpannedError,
) -> Diagnostics {
    use ron::Error as E;
    let class = match &e.code {
        E::NoSuchStructField { .. } => DiagnosticClass::UnknownArgument,
        E::MissingStructField { .. } => DiagnosticClass::MissingArgument,
        E::NoSuchEnumVariant { .. } => DiagnosticClass::UnknownKind,
        E::DuplicateStructField { .. } => DiagnosticClass::DuplicateName,
        E::InvalidValueForType { .. } | E::ExpectedDifferentLength { .. } => DiagnosticClass::Type,
        _ => DiagnosticClass::Syntax,
    };
    let offset = offset_of(&source.text, e.position.line, e.position.col);
    // ron reports the position after a bad name: underline the name itself.
    let name = match &e.code {
        E::NoSuchEnumVariant { found, .. } | E::NoSuchStructField { found, .. } => {
            Some(found.as_str())
        }
        E::DuplicateStructField { field, .. } => Some(*field),
        _ => None,
    };
    let before = &source.text[..offset];
    let span = name
        .and_then(|n| {
            let start = before.rfind(n)?;
            (offset - start <= n.len() + 16).then(|| Span::new(start, start + n.len()))
        })
        .unwrap_or(Span::new(offset, offset));
    let message = without_rust_names(&e.code.to_string());
    let mut diagnostic = Diagnostic::new(class, format!("scene: {message}")).at(span);
    if class == DiagnosticClass::Syntax {
        diagnostic = diagnostic.help(
            "a scene file is `Scene(camera: Camera(...), lights: [...], materials: {...}, objects: [...])`",
        );
    }
    Diagnostics {
        file: source.clone(),
        list: vec![diagnostic],
    }
}

/// ron's messages name the Rust types the scene is read into (`tuple variant
/// TransformDesc::Translate`, `struct CameraDesc`): an author knows them as `Translate` and
/// `Camera`. Drops every `Path::` qualifier and the `Desc` suffix of the format's type names.
pub(super) fn without_rust_names(message: &str) -> String {
    let mut out = String::with_capacity(message.len());
    let mut word = String::new();
    let flush = |word: &mut String, out: &mut String| {
        let shown = word
            .strip_suffix("Desc")
            .filter(|w| !w.is_empty())
            .unwrap_or(word);
        out.push_str(shown);
        word.clear();
    };
    let mut chars = message.chars().peekable();
    while let Some(c) = chars.next() {
        if c.is_alphanumeric() || c == '_' {
            word.push(c);
        } else if c == ':' && chars.peek() == Some(&':') && !word.is_empty() {
            chars.next();
            word.clear(); // the qualifier goes
        } else {
            flush(&mut word, &mut out);
            out.push(c);
        }
    }
    flush(&mut word, &mut out);
    out
}

/// Byte offset of a 1-based line and column (in characters), clamped to the text.
pub(super) fn offset_of(text: &str, line: usize, col: usize) -> usize {
    let mut offset = 0;
    for _ in 1..line.max(1) {
        match text[offset..].find('\n') {
            Some(i) => offset += i + 1,
            None => return text.len(),
        }
    }
    let rest = &text[offset..];
    let line_end = rest.find('\n').unwrap_or(rest.len());
    let within: usize = rest[..line_end]
        .char_indices()
        .nth(col.saturating_sub(1))
        .map_or(line_end, |(i, _)| i);
    offset + within
}

/// A diagnostic for every material name the scene's `materials` map defines a second time (ron
/// reads the map keeping the last definition, silently).
pub(super) fn duplicate_materials(tree: &syntax::Value) -> Vec<crate::diagnostic::Diagnostic> {
    use crate::diagnostic::{Diagnostic, DiagnosticClass};
    let syntax::ValueKind::Struct { fields, .. } = &tree.kind else {
        return Vec::new();
    };
    let Some((_, materials)) = fields.iter().find(|(k, _)| k.value.as_str() == "materials") else {
        return Vec::new();
    };
    let syntax::ValueKind::Map(entries) = &materials.kind else {
        return Vec::new();
    };
    let mut seen: Vec<&str> = Vec::new();
    let mut found = Vec::new();
    for (key, _) in entries {
        let syntax::ValueKind::Str(name) = &key.kind else {
            continue;
        };
        if seen.contains(&name.as_str()) {
            found.push(
                Diagnostic::new(
                    DiagnosticClass::DuplicateName,
                    format!("scene: material \"{name}\" is defined twice"),
                )
                .at(key.span)
                .label("second definition")
                .help("rename one of them; objects name the material they use"),
            );
        } else {
            seen.push(name.as_str());
        }
    }
    found
}
