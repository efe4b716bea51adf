//! The periodic chains (`filter/periodic.rs`: `g(fract X)` for a piecewise-cubic `g`) in the
//! filtered WGSL: every chain shape as a block of data (`pc_data`) that the one copy of
//! `wgsl/filter_periodic.wgsl` reads by its offset.
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
use crate::filter::moments::taylor_at;
use crate::filter::periodic::Periodic;
use std::fmt::Write;

/// A periodic piecewise polynomial: pieces from `starts` (the first 0) to the next start (the
/// last to 1), each piece's ascending coefficients in its own variable `v = u − start`. (In the
/// period's `u` a steep piece far from 0 has huge coefficients that cancel: `Smoothstep(0.9, 1,
/// fract x)`'s square is `2893401 − 18370800 u + …` on `[0.9, 1]`, and the shader export's f32
/// evaluated it to 1.8 where it is 0.18, a variance of 1.8 at a zero footprint: issue 49's
/// `library/sandstone`. In `v` the same piece is `300 v² − 2000 v³`.)
#[derive(Clone, Debug)]
struct Pieces {
    starts: Vec<f64>,
    polys: Vec<Vec<f64>>,
}

impl Pieces {
    /// `g`'s pieces, shifted from the period's `u` to each piece's own variable.
    fn of(g: &Periodic) -> Pieces {
        let starts = g.starts().to_vec();
        let polys = g
            .pieces()
            .iter()
            .zip(&starts)
            .map(|(p, &s)| taylor_at(*p, s).to_vec())
            .collect();
        Pieces { starts, polys }
    }

    fn end(&self, j: usize) -> f64 {
        self.starts.get(j + 1).copied().unwrap_or(1.0)
    }

    /// Piece `j`'s length: its polynomial's domain is `[0, len]`.
    fn len(&self, j: usize) -> f64 {
        self.end(j) - self.starts[j]
    }

    /// `∫₀¹`.
    fn mean(&self) -> f64 {
        (0..self.polys.len())
            .map(|j| integral(&self.polys[j], 0.0, self.len(j)))
            .sum()
    }

    /// `H(u) = ∫₀ᵘ (F − F̄)`: piece `j` is `H(s_j) + ∫₀^v (F_j − F̄)`.
    fn antiderivative(&self) -> Pieces {
        let mean = self.mean();
        let mut at_start = 0.0;
        let mut polys = Vec::with_capacity(self.polys.len());
        for (j, p) in self.polys.iter().enumerate() {
            let mut q: Vec<f64> = Vec::with_capacity(p.len() + 1);
            q.push(at_start);
            for (i, &a) in p.iter().enumerate() {
                let a = if i == 0 { a - mean } else { a };
                q.push(a / (i + 1) as f64);
            }
            at_start = eval(&q, self.len(j));
            polys.push(q);
        }
        Pieces {
            starts: self.starts.clone(),
            polys,
        }
    }

    /// Each term that stays below 1e-15 of the largest term of any piece over its own domain
    /// set to 0: the rounding the shifts and sums leave (1e-17 and less, e.g. an
    /// antiderivative's value at a start that is 0), which the shader's f32 literals would
    /// spell out in 30 digits (naga writes them without an exponent) and no value can show.
    fn without_noise(&self) -> Pieces {
        let term = |j: usize, k: usize, c: f64| c.abs() * self.len(j).powi(k as i32);
        let mut largest = 0.0f64;
        for (j, p) in self.polys.iter().enumerate() {
            for (k, &c) in p.iter().enumerate() {
                largest = largest.max(term(j, k, c));
            }
        }
        let polys = self.polys.iter().enumerate().map(|(j, p)| {
            let small = |(k, &c): (usize, &f64)| term(j, k, c) < 1e-15 * largest;
            p.iter()
                .enumerate()
                .map(|kc| if small(kc) { 0.0 } else { *kc.1 })
                .collect()
        });
        Pieces {
            starts: self.starts.clone(),
            polys: polys.collect(),
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

/// The coefficients stored per polynomial of each level (`pc_len` in filter_periodic.wgsl):
/// `g` (a cubic) and its three antiderivatives, `g²` and its three, `g'`.
const LEVEL_COEFFS: [usize; 9] = [4, 5, 6, 7, 7, 8, 9, 10, 3];

/// The chain shapes of one filtered form as data: one block per distinct shape in the filtered
/// form's data array `fdata` (the layout in filter_periodic.wgsl), the sawtooth's first
/// (`PC_SAW`, offset 0: [`Shapes::new`] is called on an empty array).
pub(super) struct Shapes {
    shapes: Vec<(Periodic, u32)>,
}

impl Shapes {
    pub(super) fn new(data: &mut Vec<f64>) -> Shapes {
        debug_assert!(data.is_empty(), "the sawtooth's block is at offset 0");
        let mut shapes = Shapes { shapes: Vec::new() };
        shapes.offset(&Periodic::sawtooth(), data);
        shapes
    }

    /// The offset of `g`'s block in `data` (appended once per distinct shape).
    pub(super) fn offset(&mut self, g: &Periodic, data: &mut Vec<f64>) -> u32 {
        if let Some((_, at)) = self.shapes.iter().find(|(s, _)| s == g) {
            return *at;
        }
        let at = data.len() as u32;
        data.extend(block(g));
        self.shapes.push((g.clone(), at));
        at
    }
}

/// `{decl} fdata: array<f64, N> = array<f64, N>(...);`, the filtered form's data as a
/// module-scope array (the shader export's; the GPU path binds it as a storage buffer).
pub(super) fn write_array(w: &mut String, decl: &str, data: &[f64]) {
    let n = data.len().max(1);
    let _ = write!(w, "{decl} fdata: array<f64, {n}> = array<f64, {n}>(");
    for (i, &v) in data.iter().enumerate() {
        if i % 8 == 0 {
            w.push_str("\n    ");
        }
        let _ = write!(w, "{},", data_literal(v));
    }
    if data.is_empty() {
        w.push_str("0.0lf");
    }
    w.push_str("\n);\n");
}

/// `v` as an f64 literal of a constant initialiser (no function calls): subnormals flushed to
/// zero (below 2.3e-308, nothing a chain's moments can show), values past f64's range (a
/// square or antiderivative of coefficients near 1e154, which the CPU's form cannot use either)
/// as its largest finite value of that sign.
fn data_literal(v: f64) -> String {
    let v = if v.is_nan() {
        0.0
    } else if v.is_infinite() {
        f64::MAX.copysign(v)
    } else if v.abs() < f64::MIN_POSITIVE {
        0.0
    } else {
        v
    };
    f64_literal(v)
}

/// Shape `g`'s block of `pc_data`: its piece count, the means of `g` and `g²`, per piece its
/// start, end, jump, line slope and whether it is a line, then per level (0-3: `g` and its
/// successive antiderivatives `H`; 4-7: the same for `g²`; 8: `g'`) per piece its
/// [`LEVEL_COEFFS`] ascending coefficients in `u − start`.
fn block(g: &Periodic) -> Vec<f64> {
    let base = Pieces::of(g);
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
    let mut out = vec![m as f64, levels[0].mean(), levels[4].mean()];
    out.extend(&base.starts);
    out.extend((0..m).map(|j| base.end(j)));
    // (A continuous join's rounding, 1e-17, is no jump: 0 below 1e-15 of the shape's values.)
    let scale = (0..m)
        .map(|j| base.polys[j][0].abs())
        .fold(0.0f64, f64::max);
    out.extend((0..m).map(|j| {
        let prev = (j + m - 1) % m;
        let jump = base.polys[j][0] - eval(&base.polys[prev], base.len(prev));
        if jump.abs() < 1e-15 * scale {
            0.0
        } else {
            jump
        }
    }));
    // Per piece, its slope where it is a line: a support inside one line piece takes the
    // exact line rule, as the CPU's (`moments::piecewise_early`).
    let line = |p: &Vec<f64>| p.iter().skip(2).all(|&c| c == 0.0);
    out.extend(base.polys.iter().map(|p| match line(p) {
        true => p.get(1).copied().unwrap_or(0.0),
        false => 0.0,
    }));
    out.extend(base.polys.iter().map(|p| if line(p) { 1.0 } else { 0.0 }));
    for (level, len) in levels.iter().zip(LEVEL_COEFFS) {
        let level = level.without_noise();
        for p in &level.polys {
            debug_assert!(p.len() <= len, "degree {} in a chain shape", p.len());
            out.extend((0..len).map(|i| p.get(i).copied().unwrap_or(0.0)));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::filter::moments::Piecewise;

    /// The block's polynomials by the layout filter_periodic.wgsl reads, at level `level`.
    fn eval_block(b: &[f64], level: usize, u: f64) -> f64 {
        let m = b[0] as usize;
        let j = (1..m).filter(|&i| u >= b[3 + i]).max().unwrap_or(0);
        let (len, pre) = (pc_len(level), pc_pre(level));
        let base = 3 + 5 * m + pre * m + j * len;
        let v = u - b[3 + j];
        b[base..base + len]
            .iter()
            .rev()
            .fold(0.0, |acc, &c| acc * v + c)
    }

    /// [`eval_block`] in f32, as the shader export runs it.
    fn eval_block_f32(b: &[f64], level: usize, u: f32) -> f32 {
        let m = b[0] as usize;
        let j = (1..m).filter(|&i| u >= b[3 + i] as f32).max().unwrap_or(0);
        let (len, pre) = (pc_len(level), pc_pre(level));
        let base = 3 + 5 * m + pre * m + j * len;
        let v = u - b[3 + j] as f32;
        b[base..base + len]
            .iter()
            .rev()
            .fold(0.0, |acc, &c| acc * v + c as f32)
    }

    /// A steep piece near the period's end (`Smoothstep(0.9, 1, fract x)`, a bed's blend into
    /// the next in library/sandstone): its square and its antiderivatives in f32 as in f64.
    /// In the period's `u` the square's coefficients reach 7e7 and cancel to 0.18: f32 read
    /// 1.8 (a variance of 1.6 at a zero footprint in the exported filtered shader).
    #[test]
    fn a_steep_piece_keeps_f32s_precision() {
        let s = Piecewise::new(
            vec![0.9, 1.0],
            vec![[0.0; 4], [0.0, 0.0, 300.0, -2000.0], [1.0, 0.0, 0.0, 0.0]],
        );
        let g = Periodic::sawtooth()
            .then(&s)
            .expect("a smoothstep of fract");
        let b = block(&g);
        assert!((eval_block(&b, 0, 0.95) - 0.5).abs() < 1e-12);
        for &u in &[0.05, 0.5, 0.9, 0.91, 0.945, 0.97, 0.999] {
            // (f32's own rounding of u and of the piece's start: 5e-6 of a slope at 0.91.)
            for level in 0..9 {
                let want = eval_block(&b, level, u as f32 as f64);
                let got = eval_block_f32(&b, level, u as f32) as f64;
                assert!(
                    (got - want).abs() < 2e-5 * want.abs().max(1.0),
                    "level {level} at {u}: f32 {got}, f64 {want}"
                );
            }
            let g1 = eval_block(&b, 0, u);
            assert!((eval_block(&b, 4, u) - g1 * g1).abs() < 1e-12, "g² at {u}");
        }
    }

    /// filter_periodic.wgsl's `pc_len` and `pc_pre`, as written there.
    fn pc_len(level: usize) -> usize {
        match level {
            0..4 => 4 + level,
            4..8 => 3 + level,
            _ => 3,
        }
    }

    fn pc_pre(level: usize) -> usize {
        if level <= 4 {
            return 4 * level + level * (level - level.min(1)) / 2;
        }
        let l = level - 4;
        22 + 3 * l + l * (level + 3) / 2
    }

    #[test]
    fn the_shaders_lengths_and_prefixes_are_the_levels() {
        let mut pre = 0;
        for (level, &len) in LEVEL_COEFFS.iter().enumerate() {
            assert_eq!(pc_len(level), len, "level {level}");
            assert_eq!(pc_pre(level), pre, "level {level}");
            pre += len;
        }
    }

    #[test]
    fn a_block_holds_the_shape_and_its_antiderivatives() {
        // A triangle wave: 2u up to 1/2, 2 - 2u after.
        let h = Piecewise::new(vec![0.5], vec![[1.0, 2.0, 0.0, 0.0], [1.0, -2.0, 0.0, 0.0]]);
        let tri = Periodic::sawtooth()
            .then(&h)
            .expect("a piecewise-linear shape");
        let b = block(&tri);
        let m = b[0] as usize;
        assert_eq!(m, tri.pieces().len());
        for &u in &[0.0, 0.1, 0.25, 0.5, 0.7, 0.99] {
            let j = (0..m).filter(|&j| u >= tri.starts()[j]).max().unwrap_or(0);
            let g = eval(&tri.pieces()[j], u);
            assert!((g - h.eval(u)).abs() < 1e-12, "the shape at {u}");
            assert!((eval_block(&b, 0, u) - g).abs() < 1e-12, "g({u})");
            assert!((eval_block(&b, 4, u) - g * g).abs() < 1e-12, "g²({u})");
        }
        // H = ∫₀ᵘ (g − ḡ): zero at both ends of the period, its derivative g − ḡ.
        let mean = b[1];
        assert!(eval_block(&b, 1, 0.0).abs() < 1e-12 && eval_block(&b, 1, 1.0).abs() < 1e-12);
        let (u, e) = (0.3, 1e-6);
        let slope = (eval_block(&b, 1, u + e) - eval_block(&b, 1, u - e)) / (2.0 * e);
        assert!((slope - (eval_block(&b, 0, u) - mean)).abs() < 1e-6);
    }

    #[test]
    fn shapes_are_written_once_and_the_sawtooth_first() {
        let mut data = Vec::new();
        let mut shapes = Shapes::new(&mut data);
        let saw = Periodic::sawtooth();
        assert_eq!(shapes.offset(&saw, &mut data), 0);
        let other = saw.affine(1.0, -2.0).expect("an affine shape");
        let at = shapes.offset(&other, &mut data);
        assert_eq!(at as usize, block(&saw).len());
        let len = data.len();
        assert_eq!(shapes.offset(&other, &mut data), at);
        assert_eq!(data.len(), len);
        let mut text = String::new();
        write_array(&mut text, "var<private>", &data);
        assert_eq!(text.matches("fdata").count(), 1);
        // A literal and its comma per value, and the two in the array types.
        assert_eq!(text.matches(',').count(), data.len() + 2);
    }
}
