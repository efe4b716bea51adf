//! The periodic chains (`filter/periodic.rs`: `g(fract X)` for a piecewise-cubic `g`) in the
//! filtered WGSL: per chain shape, the functions `wgsl/filter_periodic.wgsl` integrates.
//!
//! The GPU's exact method differs from the CPU's (shifted Bernoulli functions) and agrees with
//! it to rounding. For `X = t + Σ w_k U_k` (widths descending), one width `w` at a time:
//! `E[F(fract(t + w U + S'))] = F̄ + (E[H(fract(t + w/2 + S'))] − E[H(fract(t − w/2 + S'))]) / w`
//! with `H(u) = ∫₀ᵘ (F − F̄)`, periodic and continuous (the fundamental theorem of calculus on
//! `F̄ y + H(fract y)`, an antiderivative of `F(fract y)`). The widest widths are taken off so
//! until the rest spans at most two periods, where the rest is integrated exactly over the
//! periods it covers (Gauss–Legendre between the pieces' and the density's breakpoints: the
//! integrands are polynomials of degree at most 9 there). `H`'s constant term cancels in the
//! differences, so only level 0's means are needed; the slope is the same sum one level down.
//! The same for `g²` gives the second moment.

use super::codegen::f64_literal;
use crate::filter::periodic::Periodic;
use std::fmt::Write;

/// A periodic piecewise polynomial: pieces from `starts` (the first 0) to the next start (the
/// last to 1), ascending coefficients in the period's `u`.
#[derive(Clone, Debug)]
struct Pieces {
    starts: Vec<f64>,
    polys: Vec<Vec<f64>>,
}

impl Pieces {
    fn end(&self, j: usize) -> f64 {
        self.starts.get(j + 1).copied().unwrap_or(1.0)
    }

    /// `∫₀¹`.
    fn mean(&self) -> f64 {
        (0..self.polys.len())
            .map(|j| integral(&self.polys[j], self.starts[j], self.end(j)))
            .sum()
    }

    /// `H(u) = ∫₀ᵘ (F − F̄)`: piece `j` is `H(s_j) + ∫_{s_j}^u (F_j − F̄)`.
    fn antiderivative(&self) -> Pieces {
        let mean = self.mean();
        let mut at_start = 0.0;
        let mut polys = Vec::with_capacity(self.polys.len());
        for (j, p) in self.polys.iter().enumerate() {
            let mut q: Vec<f64> = Vec::with_capacity(p.len() + 1);
            q.push(0.0);
            for (i, &a) in p.iter().enumerate() {
                let a = if i == 0 { a - mean } else { a };
                q.push(a / (i + 1) as f64);
            }
            let start = eval(&q, self.starts[j]);
            q[0] = at_start - start;
            at_start += eval(&q, self.end(j)) - eval(&q, self.starts[j]);
            polys.push(q);
        }
        Pieces {
            starts: self.starts.clone(),
            polys,
        }
    }

    /// The same starts, each piece's polynomial mapped by `f`.
    fn map(&self, f: impl Fn(&[f64]) -> Vec<f64>) -> Pieces {
        Pieces {
            starts: self.starts.clone(),
            polys: self.polys.iter().map(|p| f(p)).collect(),
        }
    }

    fn squared(&self) -> Pieces {
        self.map(|p| {
            let mut out = vec![0.0; 2 * p.len() - 1];
            for (i, a) in p.iter().enumerate() {
                for (j, b) in p.iter().enumerate() {
                    out[i + j] += a * b;
                }
            }
            out
        })
    }

    fn derivative(&self) -> Pieces {
        self.map(|p| {
            let d: Vec<f64> = (1..p.len()).map(|i| i as f64 * p[i]).collect();
            if d.is_empty() {
                vec![0.0]
            } else {
                d
            }
        })
    }
}

fn eval(c: &[f64], u: f64) -> f64 {
    c.iter().rev().fold(0.0, |acc, &a| acc * u + a)
}

fn integral(c: &[f64], u0: f64, u1: f64) -> f64 {
    let anti = |u: f64| {
        let mut acc = 0.0;
        for (i, &a) in c.iter().enumerate().rev() {
            acc = acc * u + a / (i + 1) as f64;
        }
        acc * u
    };
    anti(u1) - anti(u0)
}

/// `u` in Horner form over literal coefficients.
fn horner(c: &[f64]) -> String {
    let mut text = f64_literal(*c.last().unwrap_or(&0.0));
    for a in c.iter().rev().skip(1) {
        text = format!("({text} * u + {})", f64_literal(*a));
    }
    text
}

/// The WGSL of chain shape `g` as `{name}`: `fn {name}(level, u)` (levels 0–3: `g` and its
/// successive antiderivatives `H`; 4–7: the same for `g²`; 8: `g'`), its piece count, starts,
/// ends and jumps, level 0's means, and the template's `per_moments_{name}` and
/// `r_periodic_{name}`.
pub(super) fn shape_functions(w: &mut String, name: &str, g: &Periodic, template: &str) {
    let base = Pieces {
        starts: g.starts().to_vec(),
        polys: g.pieces().iter().map(|p| p.to_vec()).collect(),
    };
    let mut levels = vec![base.clone()];
    for _ in 1..4 {
        let next = levels[levels.len() - 1].antiderivative();
        levels.push(next);
    }
    let mut square = vec![base.squared()];
    for _ in 1..4 {
        let next = square[square.len() - 1].antiderivative();
        square.push(next);
    }
    levels.extend(square);
    levels.push(base.derivative());
    let m = base.polys.len();
    let _ = writeln!(
        w,
        "fn {name}(level: u32, u: f64) -> f64 {{\n    var j = 0u;"
    );
    for (j, s) in base.starts.iter().enumerate().skip(1) {
        let _ = writeln!(w, "    if (u >= {}) {{ j = {j}u; }}", f64_literal(*s));
    }
    let _ = writeln!(w, "    switch (level * {m}u + j) {{");
    for (l, f) in levels.iter().enumerate() {
        for (j, p) in f.polys.iter().enumerate() {
            let _ = writeln!(
                w,
                "        case {}u: {{ return {}; }}",
                l * m + j,
                horner(p)
            );
        }
    }
    let _ = writeln!(w, "        default: {{ return 0.0lf; }}\n    }}\n}}");
    let _ = writeln!(w, "fn {name}_count() -> u32 {{ return {m}u; }}");
    let list = |v: &[f64]| {
        v.iter()
            .map(|&x| f64_literal(x))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let ends: Vec<f64> = (0..m).map(|j| base.end(j)).collect();
    let jumps: Vec<f64> = (0..m)
        .map(|j| {
            let prev = (j + m - 1) % m;
            let at = if j == 0 { 1.0 } else { base.starts[j] };
            eval(&base.polys[j], base.starts[j]) - eval(&base.polys[prev], at)
        })
        .collect();
    for (what, v) in [("start", &base.starts), ("end", &ends), ("jump", &jumps)] {
        let _ = writeln!(
            w,
            "fn {name}_{what}(j: u32) -> f64 {{\n    var a = array<f64, {m}>({});\n    return a[j];\n}}",
            list(v)
        );
    }
    // Per piece, its slope where it is a line (else NaN): a support inside one line piece
    // takes the exact line rule, as the CPU's (`moments::piecewise_early`).
    let lines: Vec<f64> = base
        .polys
        .iter()
        .map(|p| {
            if p.iter().skip(2).all(|&c| c == 0.0) {
                p.get(1).copied().unwrap_or(0.0)
            } else {
                f64::NAN
            }
        })
        .collect();
    let _ = writeln!(
        w,
        "fn {name}_line(j: u32) -> f64 {{\n    var a = array<f64, {m}>({});\n    return a[j];\n}}",
        list(&lines)
    );
    let _ = writeln!(
        w,
        "fn {name}_mean() -> vec2<f64> {{ return vec2<f64>({}, {}); }}",
        f64_literal(levels[0].mean()),
        f64_literal(levels[4].mean())
    );
    w.push_str(&template.replace("PC", name));
    w.push('\n');
}
