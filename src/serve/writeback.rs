//! Params in the file's text: where each number is written (to write new values back without
//! touching anything else) and the slider range each param gets.

use crate::diagnostic::Span;
use crate::syntax::{self, Value, ValueKind};
use std::path::Path;

/// A param as written in the file: its name, the span of its number and the number.
#[derive(Clone, Debug, PartialEq)]
pub struct WrittenParam {
    pub name: String,
    pub span: Span,
    pub value: f64,
}

/// The graph's top-level field `name`, if the text parses as a graph.
fn field<'v>(root: &'v Value, name: &str) -> Option<&'v Value> {
    let ValueKind::Struct { fields, .. } = &root.kind else {
        return None;
    };
    fields
        .iter()
        .find(|(f, _)| f.value == name)
        .map(|(_, value)| value)
}

/// The entries of the map `value` with string keys (others are skipped: the checker reports
/// them).
fn entries(value: &Value) -> impl Iterator<Item = (&str, &Value)> {
    let list = match &value.kind {
        ValueKind::Map(list) => list.as_slice(),
        _ => &[],
    };
    list.iter().filter_map(|(key, v)| match &key.kind {
        ValueKind::Str(s) => Some((s.as_str(), v)),
        _ => None,
    })
}

/// The params written in `text` (a graph file), each with the span of its number, in file
/// order. `Err` with the parser's message when the text does not parse.
pub fn written_params(text: &str) -> Result<Vec<WrittenParam>, String> {
    let root = syntax::parse(text).map_err(|d| d.message)?;
    let Some(params) = field(&root, "params") else {
        return Ok(Vec::new());
    };
    Ok(entries(params)
        .filter_map(|(name, v)| match v.kind {
            ValueKind::Number(n) => Some(WrittenParam {
                name: name.to_string(),
                span: v.span,
                value: n,
            }),
            _ => None,
        })
        .collect())
}

/// The kind each named node is written as (`Fbm`, `Mul`, a reference, a number), by id, in
/// file order.
pub fn node_kinds(text: &str) -> Vec<(String, String)> {
    let Ok(root) = syntax::parse(text) else {
        return Vec::new();
    };
    let Some(nodes) = field(&root, "nodes") else {
        return Vec::new();
    };
    entries(nodes)
        .map(|(name, v)| {
            let kind = match &v.kind {
                ValueKind::Struct { name: Some(n), .. }
                | ValueKind::Tuple { name: Some(n), .. } => n.value.to_string(),
                ValueKind::Ident(n) => n.to_string(),
                ValueKind::Str(_) => "reference".to_string(),
                ValueKind::Number(_) => "constant".to_string(),
                other => other.describe(),
            };
            (name.to_string(), kind)
        })
        .collect()
}

/// A number as written back: the shortest text that reads back as the same f64, with a decimal
/// point kept for whole numbers (`2.0`, not `2`) so the value still reads as a float.
pub fn number_text(v: f64) -> String {
    format!("{v:?}")
}

/// `text` with each param in `values` that it writes replaced by its new number; only the
/// numbers' characters change. `Err` naming a param `text` does not write as a number, or the
/// parse error.
pub fn rewrite_params(text: &str, values: &[(String, f64)]) -> Result<String, String> {
    let written = written_params(text)?;
    let mut edits: Vec<(Span, String)> = Vec::new();
    for (name, value) in values {
        if !value.is_finite() {
            return Err(format!("param \"{name}\": {value} is not a finite number"));
        }
        let Some(w) = written.iter().find(|w| w.name == *name) else {
            return Err(format!(
                "the file does not write param \"{name}\" as a number in `params`"
            ));
        };
        edits.push((w.span, number_text(*value)));
    }
    edits.sort_by_key(|(span, _)| span.start);
    let mut out = String::with_capacity(text.len() + 16 * edits.len());
    let mut at = 0;
    for (span, new) in edits {
        out.push_str(&text[at..span.start]);
        out.push_str(&new);
        at = span.end;
    }
    out.push_str(&text[at..]);
    Ok(out)
}

/// Writes `values` into the graph file at `path` (atomically: a temporary renamed over it),
/// re-reading the file first so an edit made meanwhile is kept.
pub fn write_params(path: &Path, values: &[(String, f64)]) -> Result<(), String> {
    let source = crate::source::read_source(path).map_err(|e| match e {
        crate::source::LoadError::Io { source, .. } => format!("{}: {source}", path.display()),
        crate::source::LoadError::Invalid(d) => d.render_plain(),
    })?;
    let text = rewrite_params(&source.text, values)
        .map_err(|e| format!("{}: cannot write the params: {e}", path.display()))?;
    crate::output::write_atomic(path, |w| w.write_all(text.as_bytes())).map_err(|e| e.to_string())
}

/// The slider range of a param whose file value is `v`, when the file gives none (docs/serve.md):
/// `[0, 4v]` above zero, `[4v, 0]` below, `[-1, 1]` at zero.
pub fn default_range(v: f64) -> (f64, f64) {
    if v > 0.0 {
        (0.0, 4.0 * v)
    } else if v < 0.0 {
        (4.0 * v, 0.0)
    } else {
        (-1.0, 1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const GRAPH: &str = r#"// a comment that stays
Graph(
    params: { "scale": 2.0, /* keep */ "turns":-3 , "s": 1e-3 },
    nodes: { "n": Fbm(input: Position, octaves: 4), "m": "n" },
    outputs: { "out": "m" },
)"#;

    #[test]
    fn numbers_are_found_where_written() {
        let params = written_params(GRAPH).unwrap();
        let names: Vec<&str> = params.iter().map(|p| p.name.as_str()).collect();
        assert_eq!(names, ["scale", "turns", "s"]);
        for p in &params {
            let text = &GRAPH[p.span.start..p.span.end];
            assert_eq!(text.parse::<f64>().unwrap(), p.value, "{text}");
        }
    }

    #[test]
    fn rewriting_changes_only_the_numbers() {
        let out = rewrite_params(GRAPH, &[("turns".into(), 0.5), ("scale".into(), 7.0)]).unwrap();
        let expected = GRAPH
            .replace("\"scale\": 2.0", "\"scale\": 7.0")
            .replace("\"turns\":-3 ", "\"turns\":0.5 ");
        assert_eq!(out, expected);
        assert!(rewrite_params(GRAPH, &[("nope".into(), 1.0)]).is_err());
        assert!(rewrite_params(GRAPH, &[("s".into(), f64::NAN)]).is_err());
        assert!(rewrite_params("Graph(params: {", &[("s".into(), 1.0)]).is_err());
    }

    #[test]
    fn written_numbers_read_back_exactly() {
        for v in [0.1, 1.0 / 3.0, -2.0, 1e-300, 123456789.0, 5e20] {
            assert_eq!(number_text(v).parse::<f64>().unwrap(), v);
            assert!(number_text(v).contains(['.', 'e']), "{}", number_text(v));
        }
    }

    #[test]
    fn kinds_are_read_from_the_text() {
        let kinds = node_kinds(GRAPH);
        assert_eq!(
            kinds,
            [
                ("n".to_string(), "Fbm".to_string()),
                ("m".to_string(), "reference".to_string())
            ]
        );
    }
}
