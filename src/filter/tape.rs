//! The filtered form of a tape: every instruction of a compiled tape run on distributions
//! ([`Dist`]) instead of numbers, so each output is an estimate of its mean over a footprint.
//!
//! The instruction set is the interpreter's (`eval.rs`), one rule per instruction kind (the
//! match below is exhaustive: a new kind does not compile without its rule). Promoted
//! (`Prec::Wide`) instructions take the same rules on the wide slots: every filtered value is
//! f64. Side tables are prepared once
//! per tape ([`Filtered::new`]): each noise table's statistics, each tiled fractal's per-octave
//! tables, each spline as piecewise cubics.

use super::abs_sine::{AbsSinPlan, SeriesLanes};
use super::fusions::{Fusion, Fusions, Part};
use super::noise::{self as fnoise, FractalSamplers, LaneScratch, Lanes, Sampler, Stats};
use super::operands::Source;
use super::ranges::Restricted;
use super::rules::{hermite_shape, spline_shape, Dist, Footprint, Rules, Shapes};
use crate::graph::Type;
use crate::noise::{Basis, NoiseTable, Style};
use crate::ops;
use crate::real::Real;
use crate::tape::{Instr, Prec, Tape};
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
    /// Per instruction, a piecewise instruction's shapes over its input's interval
    /// (`ranges.rs`), where that leaves a knot out.
    in_range: Vec<Option<Restricted>>,
    shapes: Shapes,
    /// Per instruction: whether its operand `a` is integer-valued (`integers.rs`).
    integer: Vec<[bool; 3]>,
    /// Which instructions are computed with their operand's producer (`fusions.rs`).
    fusions: Fusions,
}

/// The slots of one chunk of lanes: slot `k` of lane `i` at `k * width + i` in its file.
struct Slots {
    width: usize,
    scalars: Vec<Dist>,
    wides: Vec<Dist>,
    vec3s: Vec<[Dist; 3]>,
    /// Arguments saved for fused instructions (`Fusions::save`).
    saved: Vec<Dist>,
    scratch: LaneScratch,
    /// A fused `|sin|`'s series at the chunk's lanes (`Filtered::abs_sin_chunk`).
    series: SeriesLanes,
}

impl Slots {
    /// The scalar file of precision `prec` (both hold f64 distributions).
    fn file(&mut self, prec: Prec) -> &mut Vec<Dist> {
        match prec {
            Prec::Lane => &mut self.scalars,
            Prec::Wide => &mut self.wides,
        }
    }
}

/// Lanes per chunk of a batch: the instruction loop runs over this many lanes at a time, so
/// each noise instruction samples them in one SIMD batch.
const WIDTH: usize = 64;

/// What [`Filtered::eval_batch_with`] keeps between calls on one thread: the slots of a chunk
/// and the chunk's outputs before they are spread into the planar result. Not tied to one
/// [`Filtered`] or chunk width: the slots are resized in place and their constants written
/// again for each chunk (every other slot is written before it is read).
pub struct FilterWorkspace<S> {
    slots: Option<Slots>,
    staging: Vec<S>,
}

impl<S> Default for FilterWorkspace<S> {
    fn default() -> Self {
        FilterWorkspace {
            slots: None,
            staging: Vec::new(),
        }
    }
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
                | Instr::FractalGradient { table, octaves, .. } => (table, octaves),
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
        let integer = super::integers::integer_operands(tape);
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
            in_range: super::ranges::restricted_shapes(tape),
            shapes: Shapes::new(),
            fusions: super::fusions::fusions(tape, &integer),
            integer,
        }
    }

    pub fn tape(&self) -> &Tape {
        self.tape
    }

    /// Every output's estimated mean over `footprint` around `point`, channels in output order
    /// (as [`Tape::eval_point`]). `S` is the output's type; the rules run in f64 either way.
    /// The same arithmetic as one lane of [`Filtered::eval_batch`] (bit for bit).
    ///
    /// # Panics
    /// If `out.len() != tape.channels()`.
    pub fn eval_point<S: Real>(&self, point: [f64; 3], footprint: &Footprint, out: &mut [S]) {
        assert_eq!(
            out.len(),
            self.tape.channels(),
            "eval_point: output buffer has the wrong length"
        );
        let mut slots = self.slots(1);
        let p = ([point[0]], [point[1]], [point[2]]);
        self.eval_chunk(
            &mut slots,
            [&p.0, &p.1, &p.2],
            std::slice::from_ref(footprint),
            out,
        );
    }

    /// [`Filtered::eval_batch`] on the calling thread, its slots kept in `ws` between calls
    /// (a bake's or render's worker calls this once per row of voxels or pixels: no allocation
    /// after the first call, and no nested parallel split of a short row). The same values,
    /// bit for bit.
    ///
    /// # Panics
    /// If the slices' lengths disagree.
    pub fn eval_batch_with<S: Real>(
        &self,
        ws: &mut FilterWorkspace<S>,
        points: [&[f64]; 3],
        footprints: &[Footprint],
        out: &mut [S],
    ) {
        let n = self.check_batch(points, footprints, out.len());
        let channels = self.tape.channels();
        for start in (0..n).step_by(WIDTH) {
            let r = start..(start + WIDTH).min(n);
            let fp = if footprints.len() == 1 {
                footprints
            } else {
                &footprints[r.clone()]
            };
            let slots = ws.slots.get_or_insert_with(|| self.slots(r.len()));
            self.prepare(slots, r.len());
            ws.staging.clear();
            ws.staging.resize(channels * r.len(), S::ZERO);
            self.eval_chunk(slots, points.map(|c| &c[r.clone()]), fp, &mut ws.staging);
            for (i, lane) in ws.staging.chunks_exact(channels).enumerate() {
                for (c, v) in lane.iter().enumerate() {
                    out[c * n + start + i] = *v;
                }
            }
        }
    }

    /// The number of points of a batch, after checking the lengths agree.
    fn check_batch(&self, [x, y, z]: [&[f64]; 3], footprints: &[Footprint], out: usize) -> usize {
        let n = x.len();
        assert!(
            y.len() == n && z.len() == n,
            "eval_batch: coordinate lengths differ"
        );
        assert!(
            footprints.len() == n || footprints.len() == 1,
            "eval_batch: one footprint per point, or one for all"
        );
        assert_eq!(
            out,
            self.tape.channels() * n,
            "eval_batch: output buffer has the wrong length"
        );
        n
    }

    /// One chunk of lanes (as many as `slots.width`): lane `i`'s channels at
    /// `out[i * channels..]`.
    fn eval_chunk<S: Real>(
        &self,
        slots: &mut Slots,
        points: [&[f64]; 3],
        footprints: &[Footprint],
        out: &mut [S],
    ) {
        let lanes = Lanes::new(footprints, slots.width);
        // An f32 result may take f32 noise samples where the tape allows (`narrow_samples`).
        self.run(
            slots,
            points,
            lanes,
            S::MANTISSA_BITS < f64::MANTISSA_DIGITS,
        );
        let channels = self.tape.channels();
        let w = slots.width;
        for (lane, out) in out.chunks_exact_mut(channels).enumerate() {
            let mut overflowed = false;
            for o in &self.tape.outputs {
                let at = o.slot as usize * w + lane;
                let means: &mut dyn Iterator<Item = f64> = match o.ty {
                    Type::Scalar => &mut std::iter::once(slots.scalars[at].mean),
                    Type::Vec3 => &mut slots.vec3s[at].iter().map(|d| d.mean),
                };
                for (c, mean) in means.enumerate() {
                    overflowed |= !mean.is_finite();
                    out[o.first_channel + c] = S::from_f64(mean);
                }
            }
            if overflowed {
                self.point_fallback(points.map(|c| c[lane]), out);
            }
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
        let n = self.check_batch([x, y, z], footprints, out.len());
        let channels = self.tape.channels();
        let mut lanes = vec![S::ZERO; channels * n];
        lanes
            .par_chunks_mut(channels * WIDTH)
            .enumerate()
            .for_each_init(
                || self.slots(WIDTH),
                |slots, (k, out)| {
                    let r = k * WIDTH..(k * WIDTH + WIDTH).min(n);
                    let fp = if footprints.len() == 1 {
                        footprints
                    } else {
                        &footprints[r.clone()]
                    };
                    if slots.width != r.len() {
                        self.prepare(slots, r.len());
                    }
                    let points = [&x[r.clone()], &y[r.clone()], &z[r.clone()]];
                    self.eval_chunk(slots, points, fp, out);
                },
            );
        for i in 0..n {
            for c in 0..channels {
                out[c * n + i] = lanes[i * channels + c];
            }
        }
    }

    /// Slots for this tape with its constants written (no instruction writes a constant's slot,
    /// as in the interpreter's `Workspace::bind`), reused from point to point.
    fn slots(&self, width: usize) -> Slots {
        let mut slots = Slots {
            width,
            scalars: Vec::new(),
            wides: Vec::new(),
            vec3s: Vec::new(),
            saved: Vec::new(),
            scratch: LaneScratch::default(),
            series: SeriesLanes::default(),
        };
        self.prepare(&mut slots, width);
        slots
    }

    /// Sizes `slots` for this tape's chunks of `width` lanes (keeping their allocations) and
    /// writes its constants.
    fn prepare(&self, slots: &mut Slots, width: usize) {
        let t = self.tape;
        let zero = Dist::constant(0.0);
        slots.width = width;
        slots.scalars.resize(t.scalar_slots * width, zero);
        slots.wides.resize(t.wide_slots * width, zero);
        slots.vec3s.resize(t.vec3_slots * width, [zero; 3]);
        slots.saved.resize(self.fusions.saved * width, zero);
        let lanes = |slot: u32| slot as usize * width..(slot as usize + 1) * width;
        for &(slot, v) in &t.scalar_constants {
            slots.scalars[lanes(slot)].fill(Dist::constant(v));
        }
        for &(slot, v) in &t.wide_constants {
            slots.wides[lanes(slot)].fill(Dist::constant(v));
        }
        for &(slot, v) in &t.vec3_constants {
            slots.vec3s[lanes(slot)].fill(v.map(Dist::constant));
        }
    }

    /// The tape over a chunk: instruction by instruction, each over every lane (a noise
    /// instruction samples all lanes in one batch, `noise_chunk`).
    fn run(&self, s: &mut Slots, points: [&[f64]; 3], lanes: Lanes, narrow: bool) {
        let f = &self.fusions;
        let w = s.width;
        let per_instruction = self.integer.iter().zip(f.save.iter().zip(&f.fused));
        for (index, (instr, (integer, (save, fusion)))) in
            self.tape.instrs.iter().zip(per_instruction).enumerate()
        {
            if is_noise(instr) {
                let share = if narrow {
                    self.tape.narrow_samples[index]
                } else {
                    0.0
                };
                self.noise_chunk(lanes, instr, *integer, s, share);
                continue;
            }
            for &(source, k) in save {
                let k = k as usize * w;
                match source {
                    Source::Scalar(prec, src) => {
                        let src = src as usize * w;
                        let file = match prec {
                            Prec::Lane => &s.scalars,
                            Prec::Wide => &s.wides,
                        };
                        s.saved[k..k + w].copy_from_slice(&file[src..src + w]);
                    }
                    Source::Vec3(src, c) => {
                        for lane in 0..w {
                            s.saved[k + lane] = s.vec3s[src as usize * w + lane][c as usize];
                        }
                    }
                }
            }
            if f.skip[index] {
                continue;
            }
            if fusion.is_none() && self.in_range[index].is_none() {
                self.step(lanes, instr, *integer, points, s, 0..w);
                continue;
            }
            if let Some(Fusion::AbsSin { saved, cos }) = fusion {
                self.abs_sin_chunk(lanes, instr, *saved, *cos, s);
                continue;
            }
            for lane in 0..w {
                let rules = lanes.rules(lane);
                let fused = fusion.as_ref().and_then(|f| self.fused(&rules, f, s, lane));
                let dst = instr.writes();
                let at = dst.slot as usize * w + lane;
                match (fused, dst.file.prec()) {
                    (Some(Fused::Scalar(v)), Some(prec)) => s.file(prec)[at] = v,
                    (Some(Fused::Vec3(v)), None) => s.vec3s[at] = v,
                    // A point (no spread: a zero footprint, a constant) takes the function
                    // itself: the restricted line is the function only to within 1e-7.
                    _ => match &self.in_range[index] {
                        Some(shapes) if spread(&rules, instr, s, lane) => {
                            in_range(&rules, instr, shapes, s, lane)
                        }
                        _ => self.step(lanes, instr, *integer, points, s, lane..lane + 1),
                    },
                }
            }
        }
    }

    /// Whether a noise table takes a rule of its own per lane: white noise (a mixture of
    /// cells) and cellular noise (sub-footprint evaluation), `noise.rs`.
    fn per_lane(&self, table: u32) -> bool {
        matches!(
            self.tape.tables[table as usize].1.basis(),
            Basis::White | Basis::Cellular(_)
        )
    }

    /// Table `table`'s sampler; `narrow`: its value-only samples in f32.
    fn sampler(&self, table: u32, narrow: bool) -> Sampler<'_> {
        Sampler {
            table: &self.tape.tables[table as usize].1,
            stats: self.stats[table as usize],
            narrow,
        }
    }

    /// A fractal's octave samplers; `share`: of its summed amplitude, how much may take f32
    /// value-only samples.
    fn fractal_samplers(&self, table: u32, octaves: u32, share: f64) -> FractalSamplers<'_> {
        FractalSamplers {
            octaves: &self.tape.octaves[octaves as usize],
            narrow: share,
            base: self.sampler(table, false),
            periodic: self.octave_tables.get(&(table, octaves)).map(Vec::as_slice),
        }
    }

    /// A fused `|sin|` (`|cos|`) at every lane of the chunk: [`Rules::abs_sin_plan`], its
    /// series summed for all the lanes that take one in one loop (`lanes::SeriesLanes`).
    fn abs_sin_chunk(&self, lanes: Lanes, instr: &Instr, saved: u32, cos: bool, s: &mut Slots) {
        let w = s.width;
        let Some(prec) = instr.writes().file.prec() else {
            return;
        };
        let at = |lane: usize| instr.writes().slot as usize * w + lane;
        let arg = |s: &Slots, lane: usize| s.saved[saved as usize * w + lane];
        s.series.clear();
        for lane in 0..w {
            let rules = lanes.rules(lane);
            let x = arg(s, lane);
            match rules.abs_sin_plan(&x, cos) {
                AbsSinPlan::Done(d) => {
                    let v = d.unwrap_or_else(|| self.abs_sin_plain(&rules, &x, cos));
                    s.file(prec)[at(lane)] = v;
                }
                AbsSinPlan::Series(l) => s.series.push(lane, &l),
            }
        }
        if s.series.len() == 0 {
            return;
        }
        s.series.run(cos);
        for i in 0..s.series.len() {
            let lane = s.series.lane[i] as usize;
            let rules = lanes.rules(lane);
            let x = arg(s, lane);
            let v = rules
                .abs_sin_finish(&x, cos, s.series.sums(i))
                .unwrap_or_else(|| self.abs_sin_plain(&rules, &x, cos));
            s.file(prec)[at(lane)] = v;
        }
    }

    /// Where the `|sin|` series declines: the plain rules on the argument itself (the `Sin`
    /// may have been skipped, `Fusions::skip`).
    fn abs_sin_plain(&self, rules: &Rules, x: &Dist, cos: bool) -> Dist {
        let op = if cos {
            ops::UnaryOp::Cos
        } else {
            ops::UnaryOp::Sin
        };
        let sh = &self.shapes;
        rules.unary(sh, ops::UnaryOp::Abs, &rules.unary(sh, op, x))
    }

    /// A fused instruction's value (`fusions.rs`): its rule on its operand's producer's
    /// argument; `None` for a fused `|sin|`, which `run` gives [`Filtered::abs_sin_chunk`]
    /// instead, and for a chain of another length.
    fn fused(&self, rules: &Rules, fusion: &Fusion, s: &Slots, lane: usize) -> Option<Fused> {
        let at = |k: u32| k as usize * s.width + lane;
        match fusion {
            // The chunk's lanes at once (`abs_sin_chunk`).
            Fusion::AbsSin { .. } => None,
            Fusion::Folded { saved, shape } => {
                Some(Fused::Scalar(rules.piecewise(shape, &s.saved[at(*saved)])))
            }
            Fusion::Periodic { parts } => {
                let part =
                    |p: &Part| rules.periodic(&p.shape, &s.saved[at(p.saved)].scale(p.scale));
                match parts.as_slice() {
                    [one] => Some(Fused::Scalar(part(one))),
                    [x, y, z] => Some(Fused::Vec3([part(x), part(y), part(z)])),
                    _ => None,
                }
            }
        }
    }

    /// One instruction on lanes `range` of the slots: one match per chunk, the lanes looped in
    /// each arm (the same arithmetic per lane as one lane at a time). `integer`: whether the
    /// operand `a` is integer-valued (per component). The vector instructions are
    /// [`Filtered::step_vec3`]'s (a match per lane there: they are few in a tape, each three
    /// rules' work).
    #[allow(clippy::too_many_arguments)]
    fn step(
        &self,
        lanes: Lanes,
        instr: &Instr,
        integer: [bool; 3],
        points: [&[f64]; 3],
        s: &mut Slots,
        range: std::ops::Range<usize>,
    ) {
        let sh = &self.shapes;
        let w = s.width;
        let at = move |x: u32, lane: usize| x as usize * w + lane;
        match *instr {
            Instr::Component {
                prec,
                dst,
                src,
                axis,
            } => {
                for lane in range {
                    let v = s.vec3s[at(src, lane)][axis as usize % 3];
                    s.file(prec)[at(dst, lane)] = v;
                }
            }
            Instr::UnaryScalar { prec, op, dst, src } => {
                let file = s.file(prec);
                for lane in range {
                    file[at(dst, lane)] = lanes.rules(lane).unary(sh, op, &file[at(src, lane)]);
                }
            }
            Instr::BinaryScalar {
                prec,
                op,
                dst,
                a,
                b,
            } => {
                let file = s.file(prec);
                for lane in range {
                    let (a, b) = (&file[at(a, lane)], &file[at(b, lane)]);
                    let v = binary(&lanes.rules(lane), sh, op, a, b, integer[0]);
                    file[at(dst, lane)] = v;
                }
            }
            Instr::TernaryScalar {
                prec,
                op,
                dst,
                a,
                b,
                c,
            } => {
                let file = s.file(prec);
                for lane in range {
                    let [a, b, c] = [a, b, c].map(|x| file[at(x, lane)]);
                    file[at(dst, lane)] = lanes.rules(lane).ternary(sh, op, &a, &b, &c);
                }
            }
            Instr::Dot { prec, dst, a, b } => {
                for lane in range {
                    let v = dot(
                        &lanes.rules(lane),
                        &s.vec3s[at(a, lane)],
                        &s.vec3s[at(b, lane)],
                    );
                    s.file(prec)[at(dst, lane)] = v;
                }
            }
            Instr::Length { prec, dst, src } => {
                for lane in range {
                    let v = length(&lanes.rules(lane), sh, &s.vec3s[at(src, lane)]);
                    s.file(prec)[at(dst, lane)] = v;
                }
            }
            Instr::Hermite { dst, src, spline } => {
                let f = &self.hermites[spline as usize];
                for lane in range {
                    let v = lanes.rules(lane).piecewise(f, &s.scalars[at(src, lane)]);
                    s.scalars[at(dst, lane)] = v;
                }
            }
            Instr::Curve { dst, src, curve } => {
                let f = &self.curves[curve as usize];
                for lane in range {
                    let v = lanes.rules(lane).piecewise(f, &s.scalars[at(src, lane)]);
                    s.scalars[at(dst, lane)] = v;
                }
            }
            Instr::Widen { dst, src } => {
                for lane in range {
                    s.wides[at(dst, lane)] = s.scalars[at(src, lane)];
                }
            }
            Instr::Narrow { dst, src } => {
                for lane in range {
                    s.scalars[at(dst, lane)] = s.wides[at(src, lane)];
                }
            }
            _ => self.step_vec3(lanes, instr, integer, points, s, range),
        }
    }

    /// [`Filtered::step`] for the instructions whose result is a vector.
    #[allow(clippy::too_many_arguments)]
    fn step_vec3(
        &self,
        lanes: Lanes,
        instr: &Instr,
        integer: [bool; 3],
        points: [&[f64]; 3],
        s: &mut Slots,
        range: std::ops::Range<usize>,
    ) {
        let sh = &self.shapes;
        let w = s.width;
        let at = move |x: u32, lane: usize| x as usize * w + lane;
        for lane in range {
            let rules = lanes.rules(lane);
            let at = |x: u32| at(x, lane);
            let v = &mut s.vec3s;
            match *instr {
                Instr::Position { dst } => {
                    let point = points.map(|c| c[lane]);
                    v[at(dst)] = std::array::from_fn(|i| Dist::position(point, i));
                }
                Instr::Splat { prec, dst, src } => {
                    let c = match prec {
                        Prec::Lane => s.scalars[at(src)],
                        Prec::Wide => s.wides[at(src)],
                    };
                    v[at(dst)] = [c; 3];
                }
                Instr::Combine { prec, dst, x, y, z } => {
                    let file = match prec {
                        Prec::Lane => &s.scalars,
                        Prec::Wide => &s.wides,
                    };
                    v[at(dst)] = [x, y, z].map(|c| file[at(c)]);
                }
                Instr::UnaryVec3 { op, dst, src } => {
                    v[at(dst)] = v[at(src)].map(|c| rules.unary(sh, op, &c));
                }
                Instr::BinaryVec3 { op, dst, a, b } => {
                    let (a, b) = (v[at(a)], v[at(b)]);
                    v[at(dst)] =
                        std::array::from_fn(|i| binary(&rules, sh, op, &a[i], &b[i], integer[i]));
                }
                Instr::TernaryVec3 { op, dst, a, b, c } => {
                    let [a, b, c] = [a, b, c].map(|x| v[at(x)]);
                    v[at(dst)] =
                        std::array::from_fn(|i| rules.ternary(sh, op, &a[i], &b[i], &c[i]));
                }
                Instr::Cross { dst, a, b } => {
                    let (a, b) = (v[at(a)], v[at(b)]);
                    let term = |i: usize, j: usize| {
                        rules.sub(&rules.mul(&a[i], &b[j]), &rules.mul(&a[j], &b[i]))
                    };
                    v[at(dst)] = [term(1, 2), term(2, 0), term(0, 1)];
                }
                Instr::Normalize { dst, src } => v[at(dst)] = normalize(&rules, sh, &v[at(src)]),
                Instr::RotateConst { dst, src, matrix } => {
                    let m = &self.tape.matrices[matrix as usize];
                    v[at(dst)] = rotate(&rules, m, &v[at(src)]);
                }
                Instr::RotateVarying {
                    prec,
                    dst,
                    src,
                    degrees,
                    axis,
                } => {
                    let axis = self.tape.axes[axis as usize];
                    let degrees = match prec {
                        Prec::Lane => s.scalars[at(degrees)],
                        Prec::Wide => s.wides[at(degrees)],
                    };
                    v[at(dst)] = rotate_varying(&rules, axis, &v[at(src)], &degrees);
                }
                Instr::Ramp { dst, src, ramp } => {
                    let t = s.scalars[at(src)];
                    v[at(dst)] = rules.piecewise3(&self.ramps[ramp as usize], &t);
                }
                // Run per chunk by `run` (`noise_chunk`), never per lane; the scalar
                // instructions are `step`'s.
                _ => {}
            }
        }
    }

    /// A noise instruction over every lane of the chunk; a scalar result goes to the wide
    /// slots for a promoted instruction (the same rule, every filtered value being f64).
    /// `share`: of its summed amplitude, how much may take f32 value-only samples
    /// (`Tape::narrow_samples`; 0 for an f64 result).
    fn noise_chunk(
        &self,
        lanes: Lanes,
        instr: &Instr,
        integer: [bool; 3],
        s: &mut Slots,
        share: f64,
    ) {
        let w = s.width;
        let range = |slot: u32| slot as usize * w..(slot as usize + 1) * w;
        let file = match instr.prec() {
            Prec::Lane => &mut s.scalars,
            Prec::Wide => &mut s.wides,
        };
        match *instr {
            Instr::Noise {
                dst, src, table, ..
            } if self.per_lane(table) => {
                let sampler = self.sampler(table, false);
                let white = sampler.table.basis() == Basis::White;
                let (p, out) = (&s.vec3s[range(src)], &mut file[range(dst)]);
                for (lane, (o, p)) in out.iter_mut().zip(p).enumerate() {
                    let rules = lanes.rules(lane);
                    let special = if white {
                        fnoise::white(&rules, &sampler, p, integer)
                    } else {
                        fnoise::cellular(&rules, &sampler, p)
                    };
                    *o = special
                        .unwrap_or_else(|| fnoise::noise(&rules, &sampler, p, &mut s.scratch));
                }
            }
            Instr::Noise {
                dst, src, table, ..
            } => fnoise::noise_lanes(
                lanes,
                &self.sampler(table, share >= 1.0),
                &s.vec3s[range(src)],
                &mut file[range(dst)],
                &mut s.scratch,
            ),
            Instr::Fractal {
                dst,
                src,
                table,
                octaves,
                style,
                bias,
                ..
            } => {
                let f = self.fractal_samplers(table, octaves, share);
                let out = &mut file[range(dst)];
                let p = &s.vec3s[range(src)];
                fnoise::fractal_lanes(lanes, &self.shapes, &f, style, p, out, &mut s.scratch);
                if bias != 0.0 {
                    for (lane, o) in out.iter_mut().enumerate() {
                        *o = lanes.rules(lane).add(o, &Dist::constant(bias));
                    }
                }
            }
            Instr::NoiseGradient {
                dst, src, table, ..
            } => {
                for lane in 0..w {
                    let p = &s.vec3s[src as usize * w + lane];
                    let rules = lanes.rules(lane);
                    s.vec3s[dst as usize * w + lane] =
                        fnoise::noise_gradient(&rules, &self.sampler(table, false), p, 1.0);
                }
            }
            Instr::FractalGradient {
                dst,
                src,
                table,
                octaves,
                style,
                ..
            } => {
                for lane in 0..w {
                    let p = s.vec3s[src as usize * w + lane];
                    let rules = lanes.rules(lane);
                    s.vec3s[dst as usize * w + lane] =
                        self.fractal_gradient(&rules, table, octaves, style, &p);
                }
            }
            _ => {}
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
        let f = self.fractal_samplers(table, octaves, 0.0);
        let base = &self.tape.tables[table as usize].1;
        let point = if style == Style::Fbm {
            [0.0; 3]
        } else {
            crate::noise::fractal_styled_grad::<f64>(base, f.octaves, style, p.map(|c| c.mean))
        };
        fnoise::fractal_gradient(rules, &f, style, p, point)
    }
}

/// Whether a piecewise instruction's input is spread at a lane (not a point footprint, a
/// positive variance).
fn spread(rules: &Rules, instr: &Instr, s: &Slots, lane: usize) -> bool {
    let input = match *instr {
        Instr::Ramp { src, .. } | Instr::Hermite { src, .. } | Instr::Curve { src, .. } => {
            s.scalars[src as usize * s.width + lane]
        }
        _ => return false,
    };
    !rules.footprint.is_point() && rules.total_var(&input) > 0.0
}

/// A piecewise instruction by its shapes over its input's interval (`ranges.rs`).
fn in_range(rules: &Rules, instr: &Instr, shapes: &Restricted, s: &mut Slots, lane: usize) {
    let at = |x: &u32| *x as usize * s.width + lane;
    match (instr, shapes) {
        (Instr::Ramp { dst, src, .. }, Restricted::Three(fs)) => {
            s.vec3s[at(dst)] = rules.piecewise3(fs, &s.scalars[at(src)]);
        }
        (Instr::Hermite { dst, src, .. } | Instr::Curve { dst, src, .. }, Restricted::One(f)) => {
            s.scalars[at(dst)] = rules.piecewise(f, &s.scalars[at(src)]);
        }
        // `ranges.rs` makes these for the three piecewise instructions only.
        _ => debug_assert!(false, "restricted shapes for {instr:?}"),
    }
}

/// A fused instruction's result.
enum Fused {
    Scalar(Dist),
    Vec3([Dist; 3]),
}

/// A noise instruction: run per chunk (`Filtered::noise_chunk`), never per lane.
fn is_noise(instr: &Instr) -> bool {
    matches!(
        instr,
        Instr::Noise { .. }
            | Instr::Fractal { .. }
            | Instr::NoiseGradient { .. }
            | Instr::FractalGradient { .. }
    )
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

/// A vector divided by its length; where the length's spread reaches 0 (a vector through the
/// origin within the footprint) and the reciprocal mean is not finite, the direction of the
/// mean vector instead, as the point evaluation takes it (0 for the zero vector).
fn normalize(rules: &Rules, sh: &Shapes, v: &[Dist; 3]) -> [Dist; 3] {
    let l = length(rules, sh, v);
    let n = v.map(|c| rules.binary(sh, ops::BinaryOp::Div, &c, &l));
    if n.iter().any(|c| !c.mean.is_finite()) && v.iter().all(|c| c.mean.is_finite()) {
        return ops::normalize(v.map(|c| c.mean)).map(Dist::constant);
    }
    n
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
