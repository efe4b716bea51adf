//! Which lines of the filtered tape's body one output needs: the shader export's per-output
//! `ftape_oK` functions (`filtered.rs`), so that `texgraph_NAME_filtered` runs only the rules
//! its output reads. Drivers inline every call (lavapipe, SwiftShader and NVIDIA's all do), so
//! each exported `_filtered` function a shader calls is a copy of its body: one that computes
//! every output made an engine shader that calls four outputs compile four whole filtered tapes.
//!
//! The lines are WGSL statements over the body's slot variables (`s3`, `v0`, `d2`, `f1`: scalar,
//! vec3, wide and saved-operand slots), one string per instruction. A backward pass keeps a line
//! when it assigns a live variable, and then makes every slot variable it names live. Nothing is
//! ever made dead again (slots are reused by later instructions), and a line in which no
//! assignment is recognised is kept: the pass may keep more than is needed, never less.
//! Hand-written: a scan of generated text whose shape `filtered.rs` fixes, not a parser's job.

use std::collections::HashSet;

/// Per line, whether the outputs held in `outputs` (slot variable names) need it.
pub(super) fn needed(lines: &[String], outputs: &[String]) -> Vec<bool> {
    let mut live: HashSet<&str> = outputs.iter().map(String::as_str).collect();
    let mut keep = vec![false; lines.len()];
    for (i, line) in lines.iter().enumerate().rev() {
        let (names, assigned) = slot_names(line);
        if assigned.is_empty() || assigned.iter().any(|a| live.contains(a)) {
            keep[i] = true;
            live.extend(names);
        }
    }
    keep
}

/// The slot variables a line names, and those of them it assigns (`x = `, `x[i] = `).
fn slot_names(line: &str) -> (Vec<&str>, Vec<&str>) {
    let b = line.as_bytes();
    let (mut names, mut assigned) = (Vec::new(), Vec::new());
    let mut i = 0;
    while i < b.len() {
        if b[i].is_ascii_alphabetic() || b[i] == b'_' {
            let start = i;
            while i < b.len() && (b[i].is_ascii_alphanumeric() || b[i] == b'_') {
                i += 1;
            }
            let word = &line[start..i];
            // A field (`x.m`) is no variable.
            if is_slot(word) && (start == 0 || b[start - 1] != b'.') {
                names.push(word);
                if assigned_at(b, i) {
                    assigned.push(word);
                }
            }
        } else if b[i].is_ascii_digit() {
            // A literal with its suffix or exponent (`0.5lf`, `2u`, `1e30`).
            while i < b.len() && (b[i].is_ascii_alphanumeric() || b[i] == b'.' || b[i] == b'_') {
                i += 1;
            }
        } else {
            i += 1;
        }
    }
    (names, assigned)
}

/// `s12`, `v0`, `d3`, `f1`.
fn is_slot(word: &str) -> bool {
    word.len() > 1
        && matches!(word.as_bytes()[0], b's' | b'v' | b'd' | b'f')
        && word.bytes().skip(1).all(|c| c.is_ascii_digit())
}

/// Whether the variable ending before `i` is assigned: an optional `[…]`, then `=` (not `==`).
fn assigned_at(b: &[u8], mut i: usize) -> bool {
    let skip_spaces = |i: &mut usize| {
        while *i < b.len() && b[*i] == b' ' {
            *i += 1;
        }
    };
    skip_spaces(&mut i);
    if i < b.len() && b[i] == b'[' {
        let mut depth = 0;
        while i < b.len() {
            match b[i] {
                b'[' => depth += 1,
                b']' => {
                    depth -= 1;
                    if depth == 0 {
                        i += 1;
                        break;
                    }
                }
                _ => {}
            }
            i += 1;
        }
        skip_spaces(&mut i);
    }
    i < b.len() && b[i] == b'=' && b.get(i + 1) != Some(&b'=')
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lines(text: &[&str]) -> Vec<String> {
        text.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn keeps_what_an_output_reads_through_reused_slots() {
        let body = lines(&[
            "v0 = array<D, 3>(d_position(p, 0u), d_position(p, 1u), d_position(p, 2u));",
            "s0 = v0[0];",
            "s1 = r_sin(s0);",
            "s2 = v0[1];",
            "f0 = s2;\n    s3 = r_mul(s2, s2);",
            "if (fp_n == 0u) { s0 = r_piecewise(pwh0(), s1); } else { s0 = r_piecewise(f0, s1); }",
            "s4 = f32(s3.m) == 0.5lf;",
        ]);
        // `s0` (reassigned by line 5) needs lines 5, 4 (`f0`, saved from `s2`), 3, 2 (`s1`), 1
        // and 0, not line 6; `s1` only lines 2, 1 and 0.
        let keep = needed(&body, &["s0".to_string()]);
        assert_eq!(keep, [true, true, true, true, true, true, false]);
        let keep = needed(&body, &["s1".to_string()]);
        assert_eq!(keep, [true, true, true, false, false, false, false]);
    }

    #[test]
    fn a_line_with_no_recognised_assignment_is_kept() {
        let body = lines(&["s0 = dc(1.0lf);", "s9.m = 2.0lf;", "s1 = s0;"]);
        assert_eq!(needed(&body, &["s7".into()]), [false, true, false]);
        let (names, assigned) = slot_names("v2[1] = r_add(v1[0], s10); s3 == s4; f32(x) = 1e30");
        // `f32` reads as a slot name: harmless, no line assigns it.
        assert_eq!(names, ["v2", "v1", "s10", "s3", "s4", "f32"]);
        assert_eq!(assigned, ["v2"]);
    }
}
