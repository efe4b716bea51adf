//! Fixes to the text naga's writers produce, for their quirks (`shader::tidy` and its
//! neighbours, each documented where it is used): identifiers renamed by a scan over the tokens
//! (so that a number such as `1e5` or a comment is never taken for a name), and the range of a
//! function's block. Nothing here rewrites the generated WGSL: the module is made for its
//! target on naga's IR (`narrow.rs`, `functions.rs`).

/// `text` (WGSL or what naga wrote from it) with each identifier `rename` maps replaced, fields
/// included.
pub fn rename_words(text: &str, rename: impl Fn(&str) -> Option<String>) -> String {
    let mut out = String::with_capacity(text.len());
    scan(text, |piece, ident| {
        match ident.then(|| rename(piece)).flatten() {
            Some(renamed) => out.push_str(&renamed),
            None => out.push_str(piece),
        }
    });
    out
}

/// The byte range of the first block whose line starts with `header` (a function, in any of
/// the languages naga writes), from that line to the closing brace and the line end.
#[cfg_attr(not(feature = "shader"), allow(dead_code))]
pub fn block_range(source: &str, header: &str) -> Option<std::ops::Range<usize>> {
    let mut at = 0;
    let start = loop {
        let found = at + source[at..].find(header)?;
        if found == 0 || source.as_bytes()[found - 1] == b'\n' {
            break found;
        }
        at = found + header.len();
    };
    let mut depth = 0usize;
    for (i, c) in source[start..].char_indices() {
        match c {
            '{' => depth += 1,
            '}' => {
                depth -= 1;
                if depth == 0 {
                    let mut end = start + i + 1;
                    if source[end..].starts_with('\n') {
                        end += 1;
                    }
                    return Some(start..end);
                }
            }
            _ => {}
        }
    }
    None
}

/// Calls `each` with every piece of `source` in order and whether it is an identifier (numbers,
/// comments and the rest are pieces of their own).
fn scan<'s>(source: &'s str, mut each: impl FnMut(&'s str, bool)) {
    let bytes = source.as_bytes();
    let mut i = 0;
    while i < bytes.len() {
        let c = bytes[i];
        let start = i;
        if c == b'/' && bytes.get(i + 1) == Some(&b'/') {
            while i < bytes.len() && bytes[i] != b'\n' {
                i += 1;
            }
            each(&source[start..i], false);
        } else if c.is_ascii_alphabetic() || c == b'_' {
            while i < bytes.len() && (bytes[i].is_ascii_alphanumeric() || bytes[i] == b'_') {
                i += 1;
            }
            each(&source[start..i], true);
        } else if c.is_ascii_digit()
            || (c == b'.' && bytes.get(i + 1).is_some_and(u8::is_ascii_digit))
        {
            i = number_end(bytes, i);
            each(&source[start..i], false);
        } else {
            // One character (UTF-8 aware: comments hold non-ASCII text, handled above; any
            // other non-ASCII character is copied whole).
            let len = source[i..].chars().next().map_or(1, char::len_utf8);
            i += len;
            each(&source[start..i], false);
        }
    }
}

/// The end of the numeric literal starting at `i`: digits, a point, an exponent with its sign,
/// hexadecimal digits, then a suffix of letters (`u`, `i`, `f`, `h`, `lf`).
fn number_end(bytes: &[u8], mut i: usize) -> usize {
    let hex = bytes[i] == b'0' && matches!(bytes.get(i + 1), Some(b'x' | b'X'));
    if hex {
        i += 2;
        while i < bytes.len() && (bytes[i].is_ascii_hexdigit() || bytes[i] == b'.') {
            i += 1;
        }
    } else {
        while i < bytes.len() {
            let c = bytes[i];
            if c.is_ascii_digit() || c == b'.' {
                i += 1;
            } else if matches!(c, b'e' | b'E') {
                i += 1;
                if matches!(bytes.get(i), Some(b'+' | b'-')) {
                    i += 1;
                }
            } else {
                break;
            }
        }
    }
    while i < bytes.len() && bytes[i].is_ascii_alphabetic() {
        i += 1;
    }
    i
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn renames_identifiers_not_numbers_or_comments() {
        let text = "// a1 stays\nfloat a1 = 1e5 + b.a1 + a1_2 + 0x1a1u;\n";
        let out = rename_words(text, |w| (w == "a1").then(|| "x".to_string()));
        assert_eq!(out, "// a1 stays\nfloat x = 1e5 + b.x + a1_2 + 0x1a1u;\n");
    }

    #[test]
    fn a_block_ends_at_its_closing_brace() {
        let text = "int f() {\n    if (a) { b(); }\n}\nvoid main() {\n    f();\n}\n";
        let range = block_range(text, "void main(").unwrap();
        assert_eq!(&text[range], "void main() {\n    f();\n}\n");
        assert!(block_range(text, "main(").is_none());
    }
}
