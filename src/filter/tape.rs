//! The filtered form of a tape: every instruction of a compiled tape run on distributions
//! ([`Dist`]) instead of numbers, so each output is an estimate of its mean over a footprint.
//!
//! The instruction set is the interpreter's (`eval.rs`), one rule per instruction kind (the
//! match below is exhaustive: a new kind does not compile without its rule). Promoted (`Wide`)
//! instructions take the same rules: every filtered value is f64. Side tables are prepared once
//! per tape ([`Filtered::new`]): each noise table's statistics, each tiled fractal's per-octave
//! tables, each spline as piecewise cubics.

use super::fusions::{scalar_dst, Fusion, Fusions};
use super::noise::{self as fnoise, FractalSamplers, Sampler, Stats};
use super::rules::{hermite_shape, spline_shape, Dist, Footprint, Rules, Shapes};
use crate::graph::Type;
use crate::noise::{NoiseTable, Style};
use crate::ops;
use crate::real::Real;
use crate::tape::{Instr, Tape, Wide};
use std::collections::HashMap;

use super::moments::Piecewise;

/// A tape ready for filtered evaluation (its side tables prepared). Immutable and shareable
/// across threads; [`Filtered::eval_point`] and [`Filtered::eval_batch`] allocate their own
/// slots per call.
pub struct Filtered<'t> {
    tape: &'t Tape,
    stats: Vec<Stats>,
    /// Per (table, octave schedule) of a tiled fractal: one table per octave at its period.
    octave_tables: HashMap<(u32, u32), Vec<NoiseTable>>,
    hermites: Vec<Piecewise>,
    ramps: Vec<[Piecewise; 3]>,
    curves: Vec<Piecewise>,
    shapes: Shapes,
    /// Per instruction: whether its operand `a` is integer-valued (`integers.rs`).
    integer: Vec<[bool; 3]>,
    /// Which instructions are computed with their operand's producer (`fusions.rs`).
    fusions: Fusions,
}

/// The slots of one filtered evaluation.
struct Slots {
    scalars: Vec<Dist>,
    wides: Vec<Dist>,
    vec3s: Vec<[Dist; 3]>,
    /// Arguments saved for fused instructions (`Fusions::save`).
    saved: Vec<Dist>,
}

impl<'t> Filtered<'t> {
    pub fn new(tape: &'t Tape) -> Filtered<'t> {
        let stats = tape
            .tables
            .iter()
            .map(|(key, t)| fnoise::cached_stats(*key, t))
            .collect();
        let mut octave_tables = HashMap::new();
        for instr in &tape.instrs {
            let (table, octaves) = match *instr {
                Instr::Fractal { table, octaves, .. }
                | Instr::FractalGradient { table, octaves, .. }
                | Instr::Wide(Wide::Fractal { table, octaves, .. })
                | Instr::Wide(Wide::FractalGradient { table, octaves, .. }) => (table, octaves),
                _ => continue,
            };
            let schedule = &tape.octaves[octaves as usize];
            let base = &tape.tables[table as usize].1;
            let periods = match (&schedule.periods, base.period()) {
                (Some(periods), _) => periods.clone(),
                (None, Some(p)) => vec![p; schedule.len()],
                (None, None) => continue,
            };
            let tables = periods
                .iter()
                .map(|&p| NoiseTable::periodic(base.basis(), base.seed(), Some(p)))
                .collect();
            octave_tables.insert((table, octaves), tables);
        }
        Filtered {
            tape,
            stats,
            octave_tables,
            hermites: tape.hermites.iter().map(hermite_shape).collect(),
            ramps: tape
                .ramps
                .iter()
                .map(|r| std::array::from_fn(|c| spline_shape(r.as_ref(), c)))
                .collect(),
            curves: tape
                .curves
                .iter()
                .map(|c| spline_shape(c.as_ref(), 0))
                .collect(),
            shapes: Shapes::new(),
            integer: super::integers::integer_operands(tape),
            fusions: super::fusions::fusions(tape),
        }
    }

    pub fn tape(&self) -> &Tape {
        self.tape
    }

    /// Every output's estimated mean over `footprint` around `point`, channels in output order
    /// (as [`Tape::eval_point`]). `S` is the output's type; the rules run in f64 either way.
    ///
    /// # Panics
    /// If `out.len() != tape.channels()`.
    pub fn eval_point<S: Real>(&self, point: [f64; 3], footprint: &Footprint, out: &mut [S]) {
        assert_eq!(
            out.len(),
            self.tape.channels(),
            "eval_point: output buffer has the wrong length"
        );
        let mut slots = self.slots();
        self.eval_into(&mut slots, point, footprint, out);
    }

    /// [`Filtered::eval_point`] on slots made by [`Filtered::slots`] (reused across points).
    fn eval_into<S: Real>(
        &self,
        slots: &mut Slots,
        point: [f64; 3],
        footprint: &Footprint,
        out: &mut [S],
    ) {
        self.run(slots, point, footprint);
        let mut overflowed = false;
        for o in &self.tape.outputs {
            let means: &mut dyn Iterator<Item = f64> = match o.ty {
                Type::Scalar => &mut std::iter::once(slots.scalars[o.slot as usize].mean),
                Type::Vec3 => &mut slots.vec3s[o.slot as usize].iter().map(|d| d.mean),
            };
            for (c, mean) in means.enumerate() {
                overflowed |= !mean.is_finite();
                out[o.first_channel + c] = S::from_f64(mean);
            }
        }
        if overflowed {
            self.point_fallback(point, out);
        }
    }

    /// Where a rule's mean is not finite (the mean of `exp` over an enormous box, a reciprocal
    /// whose spread reaches 0), the channel takes the point value instead when that is finite
    /// (docs/filtering.md, "What is approximate"): a filtered output is finite wherever the
    /// point value is.
    #[cold]
    fn point_fallback<S: Real>(&self, point: [f64; 3], out: &mut [S]) {
        let mut exact = vec![0f64; out.len()];
        self.tape
            .eval_point(&mut crate::eval::Workspace::new(), point, &mut exact);
        for (o, e) in out.iter_mut().zip(exact) {
            if !o.to_f64().is_finite() && e.is_finite() {
                *o = S::from_f64(e);
            }
        }
    }

    /// [`Filtered::eval_point`] over many points, one footprint each (`footprints` as long as
    /// `x`, or one for all), planar output as [`Tape::eval_batch`]: channel `c` of point `i` is
    /// `out[c * n + i]`. Runs on the rayon pool for large batches.
    ///
    /// # Panics
    /// If the slices' lengths disagree.
    pub fn eval_batch<S: Real>(
        &self,
        [x, y, z]: [&[f64]; 3],
        footprints: &[Footprint],
        out: &mut [S],
    ) {
        use rayon::prelude::*;
        let n = x.len();
        let channels = self.tape.channels();
        assert!(
            y.len() == n && z.len() == n,
            "eval_batch: coordinate lengths differ"
        );
        assert!(
            footprints.len() == n || footprints.len() == 1,
            "eval_batch: one footprint per point, or one for all"
        );
        assert_eq!(
            out.len(),
            channels * n,
            "eval_batch: output buffer has the wrong length"
        );
        let footprint = |i: usize| &footprints[if footprints.len() == 1 { 0 } else { i }];
        let mut lanes = vec![S::ZERO; channels * n];
        lanes
            .par_chunks_mut(channels)
            .enumerate()
            .with_min_len(64)
            .for_each_init(
                || self.slots(),
                |slots, (i, lane)| self.eval_into(slots, [x[i], y[i], z[i]], footprint(i), lane),
            );
        for i in 0..n {
            for c in 0..channels {
                out[c * n + i] = lanes[i * channels + c];
            }
        }
    }

    /// Slots for this tape with its constants written (no instruction writes a constant's slot,
    /// as in the interpreter's `Workspace::bind`), reused from point to point.
    fn slots(&self) -> Slots {
        let t = self.tape;
        let mut slots = Slots {
            scalars: vec![Dist::constant(0.0); t.scalar_slots],
            wides: vec![Dist::constant(0.0); t.wide_slots],
            vec3s: vec![[Dist::constant(0.0); 3]; t.vec3_slots],
            saved: vec![Dist::constant(0.0); self.fusions.saved],
        };
        for &(slot, v) in &t.scalar_constants {
            slots.scalars[slot as usize] = Dist::constant(v);
        }
        for &(slot, v) in &t.wide_constants {
            slots.wides[slot as usize] = Dist::constant(v);
        }
        for &(slot, v) in &t.vec3_constants {
            slots.vec3s[slot as usize] = v.map(Dist::constant);
        }
        slots
    }

    fn run(&self, slots: &mut Slots, point: [f64; 3], footprint: &Footprint) {
        let rules = Rules { footprint };
        let f = &self.fusions;
        let per_instruction = self.integer.iter().zip(f.save.iter().zip(&f.fused));
        for (instr, (integer, (save, fusion))) in self.tape.instrs.iter().zip(per_instruction) {
            if let (Some(k), Instr::UnaryScalar { src, .. }) = (save, instr) {
                slots.saved[*k as usize] = slots.scalars[*src as usize];
            }
            let fused = fusion.as_ref().and_then(|f| self.fused(&rules, f, slots));
            match (fused, scalar_dst(instr)) {
                (Some(value), Some(dst)) => slots.scalars[dst as usize] = value,
                _ => self.step(&rules, instr, *integer, point, slots),
            }
        }
    }

    fn sampler(&self, table: u32) -> Sampler<'_> {
        Sampler {
            table: &self.tape.tables[table as usize].1,
            stats: self.stats[table as usize],
        }
    }

    fn fractal_samplers(&self, table: u32, octaves: u32) -> FractalSamplers<'_> {
        FractalSamplers {
            octaves: &self.tape.octaves[octaves as usize],
            base: self.sampler(table),
            periodic: self.octave_tables.get(&(table, octaves)).map(Vec::as_slice),
        }
    }

    /// A fused instruction's value (`fusions.rs`): its rule on its operand's producer's
    /// argument; `None` where that rule declines (a `|sin|` series that cannot converge: the
    /// plain rules are then accurate).
    fn fused(&self, rules: &Rules, fusion: &Fusion, s: &Slots) -> Option<Dist> {
        match fusion {
            Fusion::AbsSin { saved, cos } => rules.abs_sin_cos(&s.saved[*saved as usize], *cos),
            Fusion::Folded { saved, shape } => {
                Some(rules.piecewise(shape, &s.saved[*saved as usize]))
            }
        }
    }

    /// One instruction on the slots.
    /// `integer`: whether the operand `a` is integer-valued (per component).
    fn step(
        &self,
        rules: &Rules,
        instr: &Instr,
        integer: [bool; 3],
        point: [f64; 3],
        s: &mut Slots,
    ) {
        let sh = &self.shapes;
        match *instr {
            Instr::Position { dst } => {
                s.vec3s[dst as usize] = std::array::from_fn(|i| Dist::position(point, i));
            }
            Instr::Splat { dst, src } => s.vec3s[dst as usize] = [s.scalars[src as usize]; 3],
            Instr::Combine { dst, x, y, z } => {
                s.vec3s[dst as usize] = [x, y, z].map(|c| s.scalars[c as usize]);
            }
            Instr::Component { dst, src, axis } => {
                s.scalars[dst as usize] = s.vec3s[src as usize][axis as usize % 3];
            }
            Instr::UnaryScalar { op, dst, src } => {
                s.scalars[dst as usize] = rules.unary(sh, op, &s.scalars[src as usize]);
            }
            Instr::UnaryVec3 { op, dst, src } => {
                s.vec3s[dst as usize] = s.vec3s[src as usize].map(|c| rules.unary(sh, op, &c));
            }
            Instr::BinaryScalar { op, dst, a, b } => {
                let (a, b) = (s.scalars[a as usize], s.scalars[b as usize]);
                s.scalars[dst as usize] = binary(rules, sh, op, &a, &b, integer[0]);
            }
            Instr::BinaryVec3 { op, dst, a, b } => {
                let (a, b) = (s.vec3s[a as usize], s.vec3s[b as usize]);
                s.vec3s[dst as usize] =
                    std::array::from_fn(|i| binary(rules, sh, op, &a[i], &b[i], integer[i]));
            }
            Instr::TernaryScalar { op, dst, a, b, c } => {
                let [a, b, c] = [a, b, c].map(|x| s.scalars[x as usize]);
                s.scalars[dst as usize] = rules.ternary(sh, op, &a, &b, &c);
            }
            Instr::TernaryVec3 { op, dst, a, b, c } => {
                let [a, b, c] = [a, b, c].map(|x| s.vec3s[x as usize]);
                s.vec3s[dst as usize] =
                    std::array::from_fn(|i| rules.ternary(sh, op, &a[i], &b[i], &c[i]));
            }
            Instr::Dot { dst, a, b } => {
                s.scalars[dst as usize] = dot(rules, &s.vec3s[a as usize], &s.vec3s[b as usize]);
            }
            Instr::Length { dst, src } => {
                s.scalars[dst as usize] = length(rules, sh, &s.vec3s[src as usize]);
            }
            Instr::Cross { dst, a, b } => {
                let (a, b) = (s.vec3s[a as usize], s.vec3s[b as usize]);
                let term = |i: usize, j: usize| {
                    rules.sub(&rules.mul(&a[i], &b[j]), &rules.mul(&a[j], &b[i]))
                };
                s.vec3s[dst as usize] = [term(1, 2), term(2, 0), term(0, 1)];
            }
            Instr::Normalize { dst, src } => {
                let v = s.vec3s[src as usize];
                let l = length(rules, sh, &v);
                let mut n = v.map(|c| rules.binary(sh, ops::BinaryOp::Div, &c, &l));
                // A length whose spread reaches 0 (a vector through the origin within the
                // footprint) has no finite reciprocal mean: the direction of the mean vector
                // instead, as the point evaluation takes it (0 for the zero vector).
                if n.iter().any(|c| !c.mean.is_finite()) && v.iter().all(|c| c.mean.is_finite()) {
                    n = ops::normalize(v.map(|c| c.mean)).map(Dist::constant);
                }
                s.vec3s[dst as usize] = n;
            }
            Instr::RotateConst { dst, src, matrix } => {
                let m = &self.tape.matrices[matrix as usize];
                s.vec3s[dst as usize] = rotate(rules, m, &s.vec3s[src as usize]);
            }
            Instr::RotateVarying {
                dst,
                src,
                degrees,
                axis,
            } => {
                let axis = self.tape.axes[axis as usize];
                let v = s.vec3s[src as usize];
                s.vec3s[dst as usize] =
                    rotate_varying(rules, axis, &v, &s.scalars[degrees as usize]);
            }
            Instr::Noise { .. }
            | Instr::Fractal { .. }
            | Instr::NoiseGradient { .. }
            | Instr::FractalGradient { .. } => self.noise_step(rules, instr, s, false),
            Instr::Hermite { dst, src, spline } => {
                let f = &self.hermites[spline as usize];
                s.scalars[dst as usize] = rules.piecewise(f, &s.scalars[src as usize]);
            }
            Instr::Ramp { dst, src, ramp } => {
                let t = s.scalars[src as usize];
                s.vec3s[dst as usize] = self.ramps[ramp as usize]
                    .each_ref()
                    .map(|f| rules.piecewise(f, &t));
            }
            Instr::Curve { dst, src, curve } => {
                let f = &self.curves[curve as usize];
                s.scalars[dst as usize] = rules.piecewise(f, &s.scalars[src as usize]);
            }
            Instr::Wide(w) => self.wide(rules, w, integer[0], s),
        }
    }

    /// A promoted instruction: the plain one's rule on the wide slots.
    fn wide(&self, rules: &Rules, w: Wide, integer: bool, s: &mut Slots) {
        let sh = &self.shapes;
        match w {
            Wide::Component { dst, src, axis } => {
                s.wides[dst as usize] = s.vec3s[src as usize][axis as usize % 3];
            }
            Wide::Unary { op, dst, src } => {
                s.wides[dst as usize] = rules.unary(sh, op, &s.wides[src as usize]);
            }
            Wide::Binary { op, dst, a, b } => {
                let (a, b) = (s.wides[a as usize], s.wides[b as usize]);
                s.wides[dst as usize] = binary(rules, sh, op, &a, &b, integer);
            }
            Wide::Ternary { op, dst, a, b, c } => {
                let [a, b, c] = [a, b, c].map(|x| s.wides[x as usize]);
                s.wides[dst as usize] = rules.ternary(sh, op, &a, &b, &c);
            }
            Wide::Dot { dst, a, b } => {
                s.wides[dst as usize] = dot(rules, &s.vec3s[a as usize], &s.vec3s[b as usize]);
            }
            Wide::Length { dst, src } => {
                s.wides[dst as usize] = length(rules, sh, &s.vec3s[src as usize]);
            }
            Wide::Splat { dst, src } => s.vec3s[dst as usize] = [s.wides[src as usize]; 3],
            Wide::Combine { dst, x, y, z } => {
                s.vec3s[dst as usize] = [x, y, z].map(|c| s.wides[c as usize]);
            }
            Wide::Rotate {
                dst,
                src,
                degrees,
                axis,
            } => {
                let axis = self.tape.axes[axis as usize];
                let v = s.vec3s[src as usize];
                s.vec3s[dst as usize] = rotate_varying(rules, axis, &v, &s.wides[degrees as usize]);
            }
            // Gradients write vec3 slots, f64 on both paths: the plain rule for all four.
            Wide::Noise { .. }
            | Wide::Fractal { .. }
            | Wide::NoiseGradient { .. }
            | Wide::FractalGradient { .. } => {
                if let Some(plain) = w.plain_noise() {
                    self.noise_step(rules, &plain, s, true);
                }
            }
            Wide::Widen { dst, src } => s.wides[dst as usize] = s.scalars[src as usize],
            Wide::Narrow { dst, src } => s.scalars[dst as usize] = s.wides[src as usize],
        }
    }

    /// The noise instructions' rules; a scalar result goes to the wide slots when `wide` (a
    /// promoted instruction: the same rule, every filtered value being f64).
    fn noise_step(&self, rules: &Rules, instr: &Instr, s: &mut Slots, wide: bool) {
        let (dst, value) = match *instr {
            Instr::Noise { dst, src, table } => (
                dst,
                fnoise::noise(rules, &self.sampler(table), &s.vec3s[src as usize]),
            ),
            Instr::Fractal {
                dst,
                src,
                table,
                octaves,
                style,
                bias,
            } => (
                dst,
                self.fractal(rules, table, octaves, style, bias, &s.vec3s[src as usize]),
            ),
            Instr::NoiseGradient { dst, src, table } => {
                let p = &s.vec3s[src as usize];
                s.vec3s[dst as usize] = fnoise::noise_gradient(rules, &self.sampler(table), p, 1.0);
                return;
            }
            Instr::FractalGradient {
                dst,
                src,
                table,
                octaves,
                style,
            } => {
                let p = &s.vec3s[src as usize];
                s.vec3s[dst as usize] = self.fractal_gradient(rules, table, octaves, style, p);
                return;
            }
            _ => unreachable!("noise_step takes only noise instructions"),
        };
        let file = if wide { &mut s.wides } else { &mut s.scalars };
        file[dst as usize] = value;
    }

    fn fractal(
        &self,
        rules: &Rules,
        table: u32,
        octaves: u32,
        style: Style,
        bias: f64,
        p: &[Dist; 3],
    ) -> Dist {
        let f = self.fractal_samplers(table, octaves);
        let sum = fnoise::fractal(rules, &self.shapes, &f, style, p);
        if bias != 0.0 {
            rules.add(&sum, &Dist::constant(bias))
        } else {
            sum
        }
    }

    fn fractal_gradient(
        &self,
        rules: &Rules,
        table: u32,
        octaves: u32,
        style: Style,
        p: &[Dist; 3],
    ) -> [Dist; 3] {
        let f = self.fractal_samplers(table, octaves);
        let base = &self.tape.tables[table as usize].1;
        let point = if style == Style::Fbm {
            [0.0; 3]
        } else {
            crate::noise::fractal_styled_grad::<f64>(base, f.octaves, style, p.map(|c| c.mean))
        };
        fnoise::fractal_gradient(rules, &f, style, p, point)
    }
}

/// A binary rule; `Mod` of an integer-valued value by a whole constant takes the lattice into
/// account (`Rules::lattice_mod`).
fn binary(
    rules: &Rules,
    sh: &Shapes,
    op: ops::BinaryOp,
    a: &Dist,
    b: &Dist,
    integer: bool,
) -> Dist {
    let whole = b.grad == [0.0; 3] && b.var == 0.0 && b.mean.fract() == 0.0 && b.mean >= 1.0;
    if op == ops::BinaryOp::Mod && integer && whole && b.mean <= 1e6 {
        return rules.lattice_mod(a, b.mean);
    }
    rules.binary(sh, op, a, b)
}

fn dot(rules: &Rules, a: &[Dist; 3], b: &[Dist; 3]) -> Dist {
    let mut sum = rules.mul(&a[0], &b[0]);
    for i in 1..3 {
        sum = rules.add(&sum, &rules.mul(&a[i], &b[i]));
    }
    sum
}

fn length(rules: &Rules, shapes: &Shapes, a: &[Dist; 3]) -> Dist {
    rules.unary(shapes, ops::UnaryOp::Sqrt, &dot(rules, a, a))
}

/// A constant matrix: exact (means, linear parts; residuals as independent per component).
fn rotate(_: &Rules, m: &[[f64; 3]; 3], v: &[Dist; 3]) -> [Dist; 3] {
    std::array::from_fn(|i| Dist {
        mean: (0..3).map(|j| m[i][j] * v[j].mean).sum(),
        grad: std::array::from_fn(|k| (0..3).map(|j| m[i][j] * v[j].grad[k]).sum()),
        var: (0..3).map(|j| m[i][j] * m[i][j] * v[j].var).sum(),
    })
}

/// A rotation by a varying angle (degrees): the rotation at the mean angle, plus the angle's
/// linear part and residual through `dR/dθ v = axis × (R v)` (first order).
fn rotate_varying(rules: &Rules, axis: [f64; 3], v: &[Dist; 3], degrees: &Dist) -> [Dist; 3] {
    let m = ops::rotation_matrix(axis, degrees.mean);
    let mut out = rotate(rules, &m, v);
    let rv = out.map(|c| c.mean);
    let d = [
        axis[1] * rv[2] - axis[2] * rv[1],
        axis[2] * rv[0] - axis[0] * rv[2],
        axis[0] * rv[1] - axis[1] * rv[0],
    ];
    let k = std::f64::consts::PI / 180.0;
    for (o, d) in out.iter_mut().zip(d) {
        for (g, dg) in o.grad.iter_mut().zip(degrees.grad) {
            *g += d * k * dg;
        }
        o.var += d * d * k * k * degrees.var;
    }
    out
}

/// The filtered form as methods of the tape (issue 33's library contract). Each call prepares a
/// [`Filtered`] (per-table statistics are cached per process, but a tiled fractal's periodic
/// octave tables are made again): for many calls, make one [`Filtered::new`] and reuse it.
impl Tape {
    /// [`Filtered::eval_point`]: every output's estimated mean over `footprint` around `point`.
    pub fn eval_point_filtered<S: Real>(
        &self,
        point: [f64; 3],
        footprint: &Footprint,
        out: &mut [S],
    ) {
        Filtered::new(self).eval_point(point, footprint, out)
    }

    /// [`Filtered::eval_batch`]: the same over many points (one footprint per point, or one for
    /// all), planar output as [`Tape::eval_batch`].
    pub fn eval_batch_filtered<S: Real>(
        &self,
        points: [&[f64]; 3],
        footprints: &[Footprint],
        out: &mut [S],
    ) {
        Filtered::new(self).eval_batch(points, footprints, out)
    }
}
