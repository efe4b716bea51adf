//! The noise bases in f64, for noise the precision plan promoted (`Noise`, `Fractal`,
//! `NoiseGradient` and `FractalGradient` with `Prec::Wide`): derived from the f32 modules (`cell.wgsl` and the bases) so that each
//! basis keeps one definition. Every item whose text names `f32`, or uses such an item, gets an
//! `_d` twin with `f32` read as `f64` and `f`-suffixed literals made abstract; the few whose
//! f32 forms work on bit patterns are written by hand in `wide.wgsl` and the derived twin is
//! left out. Items without a real type (hashes, integer splits) are shared as they are.
//!
//! Hand-written rather than a WGSL preprocessor crate: the transformation is a token rename
//! over a handful of files, and naga validates its output in the tests.

use std::collections::{HashMap, HashSet};

/// The f32 modules with f64 twins, in library order.
const SOURCES: [&str; 5] = [
    include_str!("wgsl/cell.wgsl"),
    include_str!("wgsl/lattice.wgsl"),
    include_str!("wgsl/lattice_grad.wgsl"),
    include_str!("wgsl/simplex.wgsl"),
    include_str!("wgsl/cellular.wgsl"),
];

/// The hand-written f64 forms (`wgsl/wide.wgsl`).
const OVERRIDES: &str = include_str!("wgsl/wide.wgsl");

/// f32 helpers outside [`SOURCES`] (common.wgsl) whose f64 forms already exist under another
/// name (math.wgsl, wide.wgsl).
const EXTERNAL: [(&str, &str); 3] = [
    ("is_nan", "is_nan_d"),
    ("nan_f32", "nan_d"),
    ("is_nan3", "is_nan3_d"),
];

/// The f64 forms: wide.wgsl, then the derived twins in source order.
pub(crate) fn library() -> &'static str {
    static LIBRARY: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    LIBRARY.get_or_init(|| {
        let overridden: HashSet<&str> = items(OVERRIDES).iter().map(|i| i.name).collect();
        let sources: Vec<Item> = SOURCES.iter().flat_map(|s| items(s)).collect();
        let renames = renames(&sources);
        let mut out = String::from(OVERRIDES);
        for item in &sources {
            let Some(twin) = renames.get(item.name) else {
                continue;
            };
            if !overridden.contains(twin.as_str()) {
                out.push('\n');
                out.push_str(&widen(item.text, &renames));
            }
        }
        out
    })
}

/// A top-level `fn`, `struct` or `const` of a WGSL module: its name and its whole text.
struct Item<'s> {
    name: &'s str,
    text: &'s str,
}

/// The module's top-level items (comments and bindings between them are dropped). The
/// library's style makes this a line scan: an item starts at a line beginning with its keyword,
/// a `const` ends at its `;`, a `fn` or `struct` at the next line that is exactly `}`.
fn items(source: &str) -> Vec<Item<'_>> {
    let mut out = Vec::new();
    let mut offset = 0;
    let mut start: Option<(usize, &str, bool)> = None;
    for line in source.split_inclusive('\n') {
        let here = offset;
        offset += line.len();
        let trimmed = line.trim_end();
        if start.is_none() {
            for (keyword, braced) in [("fn ", true), ("struct ", true), ("const ", false)] {
                if let Some(rest) = trimmed.strip_prefix(keyword) {
                    let end = rest
                        .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
                        .unwrap_or(rest.len());
                    start = Some((here, &rest[..end], braced));
                }
            }
        }
        if let Some((from, name, braced)) = start {
            let ends = if braced {
                trimmed == "}"
            } else {
                trimmed.ends_with(';')
            };
            if ends {
                out.push(Item {
                    name,
                    text: &source[from..offset],
                });
                start = None;
            }
        }
    }
    out
}

/// Which names get a twin, and its name: the items whose text names `f32` or a name that gets
/// one (to a fixed point), plus [`EXTERNAL`].
fn renames(items: &[Item]) -> HashMap<String, String> {
    let mut renames: HashMap<String, String> = EXTERNAL
        .iter()
        .map(|&(a, b)| (a.to_string(), b.to_string()))
        .collect();
    let words: Vec<HashSet<&str>> = items
        .iter()
        .map(|i| identifiers(i.text).into_iter().collect())
        .collect();
    loop {
        let before = renames.len();
        for (item, words) in items.iter().zip(&words) {
            if !renames.contains_key(item.name)
                && words
                    .iter()
                    .any(|&w| w == "f32" || (w != item.name && renames.contains_key(w)))
            {
                renames.insert(item.name.to_string(), format!("{}_d", item.name));
            }
        }
        if renames.len() == before {
            return renames;
        }
    }
}

/// The identifiers of `text` outside comments.
fn identifiers(text: &str) -> Vec<&str> {
    tokens(text)
        .filter_map(|t| match t {
            Token::Word(w) => Some(w),
            _ => None,
        })
        .collect()
}

/// `text` with `f32` read as `f64`, renamed names renamed and `f` literal suffixes dropped.
fn widen(text: &str, renames: &HashMap<String, String>) -> String {
    let mut out = String::with_capacity(text.len() + 64);
    for token in tokens(text) {
        match token {
            Token::Word("f32") => out.push_str("f64"),
            Token::Word(w) => out.push_str(renames.get(w).map_or(w, String::as_str)),
            Token::Number(n) => {
                let hex = n.starts_with("0x") || n.starts_with("0X");
                let f32_suffix = !hex && n.ends_with('f') && !n.ends_with("lf");
                out.push_str(if f32_suffix { &n[..n.len() - 1] } else { n });
            }
            Token::Other(o) => out.push_str(o),
        }
    }
    out
}

#[derive(Debug, PartialEq)]
enum Token<'s> {
    /// An identifier or keyword.
    Word(&'s str),
    /// A numeric literal with its suffix (`1.5e-8f`, `0x7fc00000u`, `2.0lf`).
    Number(&'s str),
    /// Anything else: punctuation, spaces, comments (kept verbatim).
    Other(&'s str),
}

/// WGSL's tokens as far as [`widen`] needs them.
fn tokens(text: &str) -> impl Iterator<Item = Token<'_>> {
    let bytes = text.as_bytes();
    let mut i = 0;
    std::iter::from_fn(move || {
        if i >= bytes.len() {
            return None;
        }
        let start = i;
        let c = bytes[i];
        let word = |b: u8| b.is_ascii_alphanumeric() || b == b'_';
        if text[i..].starts_with("//") {
            while i < bytes.len() && bytes[i] != b'\n' {
                i += 1;
            }
            return Some(Token::Other(&text[start..i]));
        }
        if c.is_ascii_digit() || (c == b'.' && bytes.get(i + 1).is_some_and(u8::is_ascii_digit)) {
            let hex = text[i..].starts_with("0x") || text[i..].starts_with("0X");
            while i < bytes.len() {
                let b = bytes[i];
                let exponent_sign =
                    !hex && (b == b'-' || b == b'+') && matches!(bytes[i - 1], b'e' | b'E');
                if word(b) || b == b'.' || exponent_sign {
                    i += 1;
                } else {
                    break;
                }
            }
            return Some(Token::Number(&text[start..i]));
        }
        if word(c) {
            while i < bytes.len() && word(bytes[i]) {
                i += 1;
            }
            return Some(Token::Word(&text[start..i]));
        }
        // One character (UTF-8 aware: comments may hold any).
        let len = text[i..].chars().next().map_or(1, char::len_utf8);
        i += len;
        Some(Token::Other(&text[start..i]))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn literals_keep_their_exponent_and_lose_only_an_f_suffix() {
        let renames = HashMap::new();
        assert_eq!(
            widen("x * 5.9604644775390625e-8f + 1.5e+3f", &renames),
            "x * 5.9604644775390625e-8 + 1.5e+3"
        );
        assert_eq!(
            widen("0x7fc00000u & 0xffu", &renames),
            "0x7fc00000u & 0xffu"
        );
        assert_eq!(widen("0.5lf + 2u + 3i", &renames), "0.5lf + 2u + 3i");
        assert_eq!(
            widen("a - 1.0 // 1.0f in f32", &renames),
            "a - 1.0 // 1.0f in f32"
        );
    }

    #[test]
    fn twins_follow_the_real_type_through_calls() {
        let source = "const A: u32 = 1u;\n\
                      fn hash(x: u32) -> u32 {\n    return x * A;\n}\n\
                      fn kernel(x: f32) -> f32 {\n    return x;\n}\n\
                      fn sample(t: u32, p: f64) -> u32 {\n    return hash(t) + u32(kernel(0.5));\n}\n";
        let items = items(source);
        assert_eq!(
            items.iter().map(|i| i.name).collect::<Vec<_>>(),
            ["A", "hash", "kernel", "sample"]
        );
        let renames = renames(&items);
        assert!(!renames.contains_key("A") && !renames.contains_key("hash"));
        assert_eq!(renames["kernel"], "kernel_d");
        assert_eq!(renames["sample"], "sample_d");
        assert_eq!(
            widen(items[3].text, &renames),
            "fn sample_d(t: u32, p: f64) -> u32 {\n    return hash(t) + u32(kernel_d(0.5));\n}\n"
        );
    }
}
