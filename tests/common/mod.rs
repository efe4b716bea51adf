//! Helpers shared by the test crates (`mod common;` in each that needs them).

// Each test crate uses some of these.
#![allow(dead_code)]

use std::collections::BTreeSet;
use texgraph::nodes::CATALOGUE;

/// Whether this run re-blesses goldens: `TEXGRAPH_BLESS=1` (the one documented variable for every
/// golden of the project: values, pictures, tapes, diagnostics).
pub fn blessing() -> bool {
    std::env::var_os("TEXGRAPH_BLESS").is_some_and(|v| v == "1")
}

/// The node kinds a graph text uses: every identifier outside string literals that names a
/// catalogue kind (`Position` bare, the others before their parentheses).
pub fn kinds_used(text: &str) -> BTreeSet<&'static str> {
    let mut found = BTreeSet::new();
    let mut word = String::new();
    let mut in_string = false;
    let mut escaped = false;
    for c in text.chars().chain(std::iter::once(' ')) {
        if in_string {
            match (escaped, c) {
                (false, '\\') => escaped = true,
                (false, '"') => in_string = false,
                _ => escaped = false,
            }
            continue;
        }
        if c.is_alphanumeric() || c == '_' {
            word.push(c);
            continue;
        }
        if let Some(def) = CATALOGUE.iter().find(|d| d.name == word) {
            found.insert(def.name);
        }
        word.clear();
        in_string = c == '"';
    }
    found
}

/// The catalogue kinds missing from `found`, for a coverage test's message.
pub fn kinds_missing(found: &BTreeSet<&'static str>) -> Vec<&'static str> {
    CATALOGUE
        .iter()
        .map(|d| d.name)
        .filter(|name| !found.contains(name))
        .collect()
}
