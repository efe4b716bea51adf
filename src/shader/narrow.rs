//! The f32 flavour of the GPU path's WGSL, for the shader export: every `f64` narrowed to
//! `f32` by a pass over the tokens (types, conversions, `lf` literals), the few functions whose
//! f64 form is not a correct f32 form replaced by written ones ([`OVERRIDES`]), and every
//! module-scope name given the `tg_` prefix so that nothing collides with the user's shader.
//!
//! Why not a text search-and-replace: a literal such as `1lf` must stay a float (`1.0`, not the
//! integer `1`), comments must stay untouched, and a field access `.cell` must not be renamed
//! where a function `cell` is. Why not naga's IR: naga has no pass that changes a module's
//! scalar widths, and the library is ours, written to these conventions (`wgsl/common.wgsl`).

use std::collections::HashSet;

/// The prefix of every module-scope name of the library and the tape function.
pub const PREFIX: &str = "tg_";

/// Functions whose narrowed f64 form would be wrong or poor in f32, replaced after narrowing:
/// the cell words of the hash (`c − floor(c / 2³²) · 2³²` rounds every negative cell's low
/// word in f32: white and cellular noise would hash the wrong cells), and the f64
/// transcendentals (written for f64 with Cody–Waite splits and f64 polynomials; in f32 the
/// library's own f32 forms, the CPU f32 path's, are the right ones).
const OVERRIDES: &[(&str, &str)] = &[
    (
        "cell_words",
        "fn cell_words(c: f32) -> vec2<u32> {\n    \
         // An f32 cell is an integer below 2^31 in magnitude wherever positions are exact;\n    \
         // its two's-complement words as Rust's `floor as i64` gives them, saturating.\n    \
         let i = i32(clamp(c, -2147483648.0, 2147483520.0));\n    \
         return vec2<u32>(bitcast<u32>(i), select(0u, 0xffffffffu, i < 0));\n}\n",
    ),
    // `x != x` may be folded to false by a fast-math shader compiler; the bit test cannot.
    (
        "is_nan_d",
        "fn is_nan_d(x: f32) -> bool { return is_nan(x); }\n",
    ),
    (
        "d_is_inf",
        "fn d_is_inf(x: f32) -> bool { return is_inf(x); }\n",
    ),
    (
        "simplex_finite3",
        "fn simplex_finite3(p: vec3<f32>) -> bool {\n    \
         let a = abs(p);\n    \
         return a.x <= 3.4028235e38 && a.y <= 3.4028235e38 && a.z <= 3.4028235e38;\n}\n",
    ),
    // ln x for x > 0 finite (the level-of-detail octave count): f32's own.
    (
        "d_ln_finite",
        "fn d_ln_finite(x: f32) -> f32 { return log(x); }\n",
    ),
    (
        "d_div",
        "fn d_div(a: f32, b: f32) -> f32 { return s_div(a, b); }\n",
    ),
    // The driver's own sin and cos may be as coarse as 2^-11 (the precision Vulkan and WebGL
    // allow; SwiftShader's, under Chromium's WebGL, are off by 1e-4): [`SIN_COS`] instead.
    (
        "s_sin",
        "fn s_sin(x: f32) -> f32 {\n    \
         if (is_inf(x)) { return nan_f32(); }\n    \
         return sin_cos_f32(x).x;\n}\n",
    ),
    (
        "s_cos",
        "fn s_cos(x: f32) -> f32 {\n    \
         if (is_inf(x)) { return nan_f32(); }\n    \
         return sin_cos_f32(x).y;\n}\n",
    ),
    (
        "s_tan",
        "fn s_tan(x: f32) -> f32 {\n    \
         if (is_inf(x)) { return nan_f32(); }\n    \
         let r = sin_cos_f32(x);\n    \
         return r.x / r.y;\n}\n",
    ),
    ("d_sin", "fn d_sin(x: f32) -> f32 { return s_sin(x); }\n"),
    ("d_cos", "fn d_cos(x: f32) -> f32 { return s_cos(x); }\n"),
    ("d_tan", "fn d_tan(x: f32) -> f32 { return s_tan(x); }\n"),
    ("d_sqrt", "fn d_sqrt(x: f32) -> f32 { return s_sqrt(x); }\n"),
    (
        "d_fract",
        "fn d_fract(x: f32) -> f32 { return s_fract(x); }\n",
    ),
    ("d_exp", "fn d_exp(x: f32) -> f32 { return s_exp(x); }\n"),
    ("d_log", "fn d_log(x: f32) -> f32 { return s_log(x); }\n"),
    ("d_log2", "fn d_log2(x: f32) -> f32 { return s_log2(x); }\n"),
    ("d_asin", "fn d_asin(x: f32) -> f32 { return s_asin(x); }\n"),
    ("d_acos", "fn d_acos(x: f32) -> f32 { return s_acos(x); }\n"),
    ("d_sign", "fn d_sign(x: f32) -> f32 { return s_sign(x); }\n"),
    (
        "d_round",
        "fn d_round(x: f32) -> f32 { return s_round(x); }\n",
    ),
    (
        "d_min",
        "fn d_min(a: f32, b: f32) -> f32 { return s_min(a, b); }\n",
    ),
    (
        "d_max",
        "fn d_max(a: f32, b: f32) -> f32 { return s_max(a, b); }\n",
    ),
    (
        "d_pow",
        "fn d_pow(x: f32, y: f32) -> f32 { return s_pow(x, y); }\n",
    ),
    (
        "d_atan2",
        "fn d_atan2(y: f32, x: f32) -> f32 { return s_atan2(y, x); }\n",
    ),
    (
        "d_mod",
        "fn d_mod(a: f32, b: f32) -> f32 { return s_mod(a, b); }\n",
    ),
];

/// Identifiers renamed while narrowing: f64 constants whose f32 rounding is wrong.
const RENAMES: &[(&str, &str)] = &[
    ("f64", "f32"),
    ("ONE_BELOW_F64", "ONE_BELOW_F32"),
    // GLSL ES 3.00 has no `ldexp`: every call goes through [`LDEXP`].
    ("ldexp", "ldexp_f32"),
];

/// `ldexp` for every language: `x · 2^e` as up to three products with powers of two built from
/// their bits (each within the normal range, so each product is exact while the result is
/// normal).
const LDEXP: &str = "fn ldexp_f32(x: f32, e: i32) -> f32 {
    var y = x;
    var k = clamp(e, -450, 450);
    for (var i = 0; i < 3; i = i + 1) {
        let s = clamp(k, -126, 127);
        y = y * bitcast<f32>(u32(s + 127) << 23u);
        k = k - s;
    }
    return y;
}
";

/// sin and cos of an f32, (sin x, cos x), written out so that every driver gives the same
/// numbers: x reduced by π/2 in three f32 parts (Cody–Waite; each `k · part` exact while
/// |k| < 2^15), then Cephes' f32 minimax polynomials on [−π/4, π/4] (about 1 ulp) and the
/// quadrant's signs. Beyond |x| = 5e4, where one f32 ulp of x is already 0.004 rad, the
/// reduction by a 2π rounded to f32 and the driver's own functions.
const SIN_COS: &str = "fn sin_cos_f32(x: f32) -> vec2<f32> {
    if (!(abs(x) < 51000.0)) {
        let w = x - floor(x / 6.2831855 + 0.5) * 6.2831855;
        return vec2<f32>(sin(w), cos(w));
    }
    let k = round(x * 0.63661975);
    let r = ((x - k * 1.5703125) - k * 4.837512969970703e-4) - k * 7.549789954891882e-8;
    let z = r * r;
    let s = r + r * z * (-0.16666654611 + z * (0.0083321608736 + z * -0.00019515295891));
    let c = 1.0 - 0.5 * z + z * z * (0.04166664568298827 + z * (-0.001388731625493765 + z * 0.00002443315711809948));
    let q = i32(k) & 3;
    if (q == 0) { return vec2<f32>(s, c); }
    if (q == 1) { return vec2<f32>(c, -s); }
    if (q == 2) { return vec2<f32>(-s, -c); }
    return vec2<f32>(-c, s);
}
";

/// f64 constants with no f32 use once [`OVERRIDES`] are in: their definitions are dropped
/// (their values are beyond f32's range).
const DROPPED: &[&str] = &["SIMPLEX_MAX_F64"];

/// `source` with every f64 made f32 (see the module comment), then the overridden functions
/// replaced.
pub fn narrow(source: &str) -> String {
    // The f64 constants renamed to their f32 twins lose their own definitions.
    let source: String = source
        .lines()
        .filter(|line| {
            let defines = |name: &str| line.starts_with(&format!("const {name}:"));
            !(RENAMES.iter().any(|(from, _)| defines(from)) || DROPPED.iter().any(|n| defines(n)))
        })
        .flat_map(|line| [line, "\n"])
        .collect();
    let mut out = map_tokens(&source, |token| match token {
        Token::Ident(name) => RENAMES
            .iter()
            .find(|(from, _)| *from == name)
            .map(|(_, to)| to.to_string()),
        Token::Number(text) => text.strip_suffix("lf").map(|digits| {
            if digits.contains(['.', 'e', 'E']) || digits.starts_with("0x") {
                digits.to_string()
            } else {
                format!("{digits}.0")
            }
        }),
    });
    // A library without one of them (a basis' module left out) has nothing to replace.
    replace_functions(&mut out, OVERRIDES);
    out.push_str(LDEXP);
    out.push_str(SIN_COS);
    out
}

/// The names `source` defines at module scope (`fn`, `const`, `struct`, `var`, `alias`).
pub fn module_names(source: &str) -> HashSet<String> {
    let mut names = HashSet::new();
    for line in source.lines() {
        let mut words = line.split(|c: char| !(c.is_alphanumeric() || c == '_'));
        let first = words.next().unwrap_or("");
        if matches!(first, "fn" | "const" | "struct" | "alias") {
            if let Some(name) = words.find(|w| !w.is_empty()) {
                names.insert(name.to_string());
            }
        } else if line.starts_with("var") {
            // `var<private> name: T`: the name after the address space.
            if let Some(rest) = line.split_once('>').map(|(_, r)| r) {
                if let Some(name) = rest
                    .split(|c: char| !(c.is_alphanumeric() || c == '_'))
                    .find(|w| !w.is_empty())
                {
                    names.insert(name.to_string());
                }
            }
        }
    }
    names
}

/// `source` with every name of `names` prefixed by [`PREFIX`], except a field: after a `.`, or
/// a member's name in a `struct` body (the name before its `:`).
pub fn prefix(source: &str, names: &HashSet<String>) -> String {
    let mut pieces: Vec<(&str, bool)> = Vec::new();
    scan(source, |piece, token| {
        pieces.push((piece, matches!(token, Some(Token::Ident(_)))))
    });
    let next_visible = |from: usize| {
        pieces[from..]
            .iter()
            .map(|(p, _)| p.trim())
            .find(|p| !p.is_empty() && !p.starts_with("//"))
    };
    let mut out = String::with_capacity(source.len() + source.len() / 8);
    let (mut previous, mut after_struct, mut in_struct) = ("", false, false);
    for (k, &(piece, ident)) in pieces.iter().enumerate() {
        let field = previous == "." || (in_struct && next_visible(k + 1) == Some(":"));
        if ident && !field && names.contains(piece) {
            out.push_str(PREFIX);
        }
        out.push_str(piece);
        match piece {
            "struct" if ident => after_struct = true,
            "{" if after_struct => (after_struct, in_struct) = (false, true),
            "}" => in_struct = false,
            _ => {}
        }
        if !piece.trim().is_empty() && !piece.starts_with("//") {
            previous = piece.trim();
        }
    }
    out
}

/// `text` (WGSL or what naga wrote from it) with each identifier `rename` maps replaced, fields
/// included.
pub fn rename_words(text: &str, rename: impl Fn(&str) -> Option<String>) -> String {
    map_tokens(text, |token| match token {
        Token::Ident(name) => rename(name),
        Token::Number(_) => None,
    })
}

/// The byte range of the module-scope function `name` in `source` (from its `fn` to its closing
/// brace and the line end), if it has one.
pub fn function_range(source: &str, name: &str) -> Option<std::ops::Range<usize>> {
    block_range(source, &format!("fn {name}("))
}

/// The byte range of the first block whose line starts with `header` (a function, in any of
/// the languages naga writes), from that line to the closing brace and the line end.
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

/// Replaces each module-scope function `(name, text)` names in `source` by `text`; the names it
/// does not find.
pub fn replace_functions<'a>(
    source: &mut String,
    replacements: &[(&'a str, &str)],
) -> Vec<&'a str> {
    let mut missing = Vec::new();
    for &(name, text) in replacements {
        match function_range(source, name) {
            Some(range) => source.replace_range(range, text),
            None => missing.push(name),
        }
    }
    missing
}

/// A token the passes look at; everything else (punctuation, space, comments) is copied.
enum Token<'a> {
    Ident(&'a str),
    Number(&'a str),
}

/// `source` with each token replaced where `f` says so.
fn map_tokens<'s>(source: &'s str, mut f: impl FnMut(Token<'s>) -> Option<String>) -> String {
    let mut out = String::with_capacity(source.len());
    scan(source, |piece, token| match token.and_then(&mut f) {
        Some(replaced) => out.push_str(&replaced),
        None => out.push_str(piece),
    });
    out
}

/// Calls `each` with every piece of `source` in order: identifiers and numbers as tokens,
/// comments and the rest as plain pieces.
fn scan<'s>(source: &'s str, mut each: impl FnMut(&'s str, Option<Token<'s>>)) {
    let bytes = source.as_bytes();
    let mut i = 0;
    while i < bytes.len() {
        let c = bytes[i];
        let start = i;
        if c == b'/' && bytes.get(i + 1) == Some(&b'/') {
            while i < bytes.len() && bytes[i] != b'\n' {
                i += 1;
            }
            each(&source[start..i], None);
        } else if c.is_ascii_alphabetic() || c == b'_' {
            while i < bytes.len() && (bytes[i].is_ascii_alphanumeric() || bytes[i] == b'_') {
                i += 1;
            }
            each(&source[start..i], Some(Token::Ident(&source[start..i])));
        } else if c.is_ascii_digit()
            || (c == b'.' && bytes.get(i + 1).is_some_and(u8::is_ascii_digit))
        {
            i = number_end(bytes, i);
            each(&source[start..i], Some(Token::Number(&source[start..i])));
        } else {
            // One character (UTF-8 aware: comments hold non-ASCII text, handled above; any
            // other non-ASCII character is copied whole).
            let len = source[i..].chars().next().map_or(1, char::len_utf8);
            i += len;
            each(&source[start..i], None);
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
    fn literals_types_and_comments() {
        let src = "// f64 stays in comments: 1lf\nfn f(x: f64) -> vec3<f64> { let a = 1lf; let b = 2.5e-3lf; let c = 7u; let d = 0x7fu; return vec3<f64>(f64(x) * a * b * ONE_BELOW_F64); }\n";
        let out = narrow(src);
        assert!(out.starts_with("// f64 stays in comments: 1lf\n"), "{out}");
        assert!(out.contains("fn f(x: f32) -> vec3<f32> { let a = 1.0; let b = 2.5e-3; let c = 7u; let d = 0x7fu;"), "{out}");
        assert!(
            out.contains("vec3<f32>(f32(x) * a * b * ONE_BELOW_F32)"),
            "{out}"
        );
    }

    #[test]
    fn prefixing_skips_fields_and_overrides_replace_whole_functions() {
        let src = "struct S {\n    cell: u32,\n}\nfn cell(s: S) -> u32 {\n    return s.cell;\n}\nfn cell_words(c: f64) -> vec2<u32> {\n    if (c > 0.0lf) { return vec2<u32>(1u); }\n    return vec2<u32>(0u);\n}\n";
        let names = module_names(src);
        assert_eq!(
            names,
            ["S", "cell", "cell_words"]
                .map(String::from)
                .into_iter()
                .collect()
        );
        let out = prefix(&narrow(src), &names);
        assert!(
            out.contains("fn tg_cell(s: tg_S) -> u32 {\n    return s.cell;"),
            "{out}"
        );
        assert!(
            out.contains("fn tg_cell_words(c: f32)") && out.contains("bitcast<u32>(i)"),
            "{out}"
        );
        assert!(!out.contains("c > 0.0"), "{out}");
    }
}
