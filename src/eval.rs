//! Stage 4, evaluate: the tape interpreter, per point and per batch, in f32 or f64.
//!
//! A batch is cut into chunks of [`LANES`] points (structure of arrays: x, y and z planes). For
//! each chunk the interpreter walks the tape once: one dispatch per instruction per chunk, then a
//! tight loop over the lanes, which the compiler is free to vectorise. A point evaluation is the
//! same walk over a chunk of one lane, so point and batch results agree bit for bit by
//! construction (each lane runs the same per-lane functions from `ops` and `noise`).
//!
//! Scratch memory lives in a [`Workspace`]: allocated when it is first bound to a tape, then
//! reused; evaluation itself never allocates.

use crate::noise;
use crate::ops::{self, BinaryOp, TernaryOp, UnaryOp};
use crate::real::Real;
use crate::tape::{Instr, Prec, Slot, Tape};
use std::mem::take;

/// Points per chunk. 256 lanes keep a typical tape's live slots (a few KiB each) in L1/L2.
pub const LANES: usize = 256;

/// Runs `$body` with `$file` bound to the scalar slot file of precision `$prec`: the lane
/// type's slots or the f64 wide slots. The body is written once and compiled for both files
/// (its lane functions are generic over `Real`); it may borrow the workspace's other fields.
macro_rules! in_file {
    ($ws:ident, $prec:expr, $file:ident => $body:expr) => {
        match $prec {
            Prec::Lane => {
                let $file = &mut $ws.scalars;
                $body
            }
            Prec::Wide => {
                let $file = &mut $ws.wides;
                $body
            }
        }
    };
}

/// Per-thread scratch slots for evaluating tapes in lane type `S`.
#[derive(Debug, Default)]
pub struct Workspace<S: Real> {
    bound_to: u64,
    scalars: Vec<Vec<S>>,
    /// Each vec3 slot holds three planes of LANES f64: x, then y, then z.
    vec3s: Vec<Vec<f64>>,
    /// f64 scalar slots of promoted instructions (`Prec::Wide`), whatever `S` is.
    wides: Vec<Vec<f64>>,
    /// Level of detail per lane: the octaves each lane of a fractal keeps, and its bias.
    kept: Vec<f64>,
    bias: Vec<f64>,
}

impl<S: Real> Workspace<S> {
    pub fn new() -> Workspace<S> {
        Workspace {
            bound_to: 0,
            scalars: Vec::new(),
            vec3s: Vec::new(),
            wides: Vec::new(),
            kept: Vec::new(),
            bias: Vec::new(),
        }
    }

    /// Sizes the slots for `tape` and writes its constants; a no-op when already bound to it.
    fn bind(&mut self, tape: &Tape) {
        if self.bound_to == tape.id {
            return;
        }
        self.scalars = (0..tape.scalar_slots)
            .map(|_| vec![S::ZERO; LANES])
            .collect();
        self.vec3s = (0..tape.vec3_slots).map(|_| vec![0.0; 3 * LANES]).collect();
        for &(slot, v) in &tape.scalar_constants {
            self.scalars[slot as usize].fill(S::from_f64(v));
        }
        self.wides = (0..tape.wide_slots).map(|_| vec![0.0; LANES]).collect();
        self.kept = vec![0.0; LANES];
        self.bias = vec![0.0; LANES];
        for &(slot, v) in &tape.wide_constants {
            self.wides[slot as usize].fill(v);
        }
        for &(slot, v) in &tape.vec3_constants {
            let planes = &mut self.vec3s[slot as usize];
            for (c, plane) in planes.chunks_exact_mut(LANES).enumerate() {
                plane.fill(v[c]);
            }
        }
        self.bound_to = tape.id;
    }
}

impl Tape {
    /// Evaluates every compiled output at one point. `out` receives the channels in output order
    /// (scalar: one value, vec3: three).
    ///
    /// # Panics
    /// If `out.len() != self.channels()`.
    pub fn eval_point<S: Real>(
        &self,
        workspace: &mut Workspace<S>,
        point: [f64; 3],
        out: &mut [S],
    ) {
        assert_eq!(
            out.len(),
            self.channels(),
            "eval_point: output buffer has the wrong length"
        );
        workspace.bind(self);
        let [x, y, z] = [[point[0]], [point[1]], [point[2]]];
        self.run_chunk::<S, true>(workspace, &x, &y, &z, None);
        self.write_outputs::<S, true>(workspace, 1, 0, 1, out);
    }

    /// [`Tape::eval_point`] with level of detail at this point: every fbm, turbulence, billow
    /// and ridged sum (and their gradients) keeps only the octaves whose world frequency a
    /// sampling with spacing `spacing` (world units, e.g. a render hit's footprint in texture
    /// space) resolves, the last one faded, the dropped octaves' mean added back — what a tape
    /// compiled with `CompileOptions::spacing` does, at each point its own spacing. Never more
    /// octaves than the tape keeps; a spacing that is not positive and finite drops nothing.
    /// Bit for bit [`Tape::eval_batch_lod`]'s lane with that point and spacing.
    ///
    /// # Panics
    /// If `out.len() != self.channels()`.
    pub fn eval_point_lod<S: Real>(
        &self,
        workspace: &mut Workspace<S>,
        point: [f64; 3],
        spacing: f64,
        out: &mut [S],
    ) {
        assert_eq!(
            out.len(),
            self.channels(),
            "eval_point_lod: output buffer has the wrong length"
        );
        workspace.bind(self);
        let [x, y, z] = [[point[0]], [point[1]], [point[2]]];
        self.run_chunk::<S, true>(workspace, &x, &y, &z, Some(&[spacing]));
        self.write_outputs::<S, true>(workspace, 1, 0, 1, out);
    }

    /// Evaluates every compiled output at `x.len()` points. `out` is planar: channel `c` of
    /// point `i` is `out[c * n + i]`, channels numbered across outputs in order.
    ///
    /// # Panics
    /// If the coordinate slices differ in length or `out.len() != self.channels() * x.len()`.
    pub fn eval_batch<S: Real>(
        &self,
        workspace: &mut Workspace<S>,
        x: &[f64],
        y: &[f64],
        z: &[f64],
        out: &mut [S],
    ) {
        self.batch(workspace, [x, y, z], None, out);
    }

    /// [`Tape::eval_batch`] with level of detail per point: point `i` keeps the octaves its own
    /// sample spacing `spacing[i]` resolves (see [`Tape::eval_point_lod`]). One batch, one
    /// tape: a chunk of points runs each fractal's octaves up to the most any of its points
    /// keeps. Where every point has the same spacing, the result is bit for bit that of the
    /// tape compiled for that spacing (`CompileOptions::spacing`).
    ///
    /// # Panics
    /// If the coordinate or spacing slices differ in length or
    /// `out.len() != self.channels() * x.len()`.
    pub fn eval_batch_lod<S: Real>(
        &self,
        workspace: &mut Workspace<S>,
        [x, y, z]: [&[f64]; 3],
        spacing: &[f64],
        out: &mut [S],
    ) {
        assert_eq!(
            spacing.len(),
            x.len(),
            "eval_batch_lod: one spacing per point"
        );
        self.batch(workspace, [x, y, z], Some(spacing), out);
    }

    /// [`Tape::eval_batch`] and [`Tape::eval_batch_lod`]: the chunks.
    fn batch<S: Real>(
        &self,
        workspace: &mut Workspace<S>,
        [x, y, z]: [&[f64]; 3],
        spacing: Option<&[f64]>,
        out: &mut [S],
    ) {
        let n = x.len();
        assert!(
            y.len() == n && z.len() == n,
            "eval_batch: coordinate slices differ in length"
        );
        assert_eq!(
            out.len(),
            self.channels() * n,
            "eval_batch: output buffer has the wrong length"
        );
        workspace.bind(self);
        let mut start = 0;
        while start < n {
            let end = (start + LANES).min(n);
            let (cx, cy, cz) = (&x[start..end], &y[start..end], &z[start..end]);
            let lanes = spacing.map(|s| &s[start..end]);
            self.run_chunk::<S, false>(workspace, cx, cy, cz, lanes);
            self.write_outputs::<S, false>(workspace, end - start, start, n, out);
            start = end;
        }
    }

    /// Copies the output slots of the current chunk (`len` lanes) to `out` at lane `offset` of a
    /// planar buffer with `stride` lanes per channel.
    fn write_outputs<S: Real, const ONE_LANE: bool>(
        &self,
        ws: &Workspace<S>,
        len: usize,
        offset: usize,
        stride: usize,
        out: &mut [S],
    ) {
        let (len, offset, stride) = if ONE_LANE {
            (1, 0, 1)
        } else {
            (len, offset, stride)
        };
        for output in &self.outputs {
            let base = output.first_channel;
            match output.ty {
                crate::graph::Type::Scalar => {
                    let src = &ws.scalars[output.slot as usize][..len];
                    out[base * stride + offset..][..len].copy_from_slice(src);
                }
                crate::graph::Type::Vec3 => {
                    let planes = &ws.vec3s[output.slot as usize];
                    for c in 0..3 {
                        let src = &planes[c * LANES..][..len];
                        let dst = &mut out[(base + c) * stride + offset..][..len];
                        for (d, s) in dst.iter_mut().zip(src) {
                            *d = S::from_f64(*s);
                        }
                    }
                }
            }
        }
    }

    /// Runs every instruction over one chunk of `x.len() <= LANES` lanes.
    ///
    /// `ONE_LANE` (eval_point) makes the lane count the constant 1, so the compiler turns every
    /// lane loop and slice copy below into a single scalar operation: the per-point interpreter
    /// is this same code, specialised, not a second copy to keep in step.
    fn run_chunk<S: Real, const ONE_LANE: bool>(
        &self,
        ws: &mut Workspace<S>,
        x: &[f64],
        y: &[f64],
        z: &[f64],
        spacing: Option<&[f64]>,
    ) {
        let n = if ONE_LANE { 1 } else { x.len() };
        for instr in &self.instrs {
            self.step::<S, ONE_LANE>(ws, instr, [x, y, z], spacing, n);
        }
    }

    /// Evaluates like [`Tape::eval_batch`] and adds each instruction's wall time to `times`
    /// (one entry per instruction, in tape order): the per-node cost `texgraph serve` shows is
    /// measured by the interpreter itself, not estimated. The clock is read around every
    /// instruction of every chunk, so the total is a little above an untimed run's.
    ///
    /// # Panics
    /// As [`Tape::eval_batch`], and if `times.len()` differs from the instruction count.
    pub fn eval_batch_timed<S: Real>(
        &self,
        workspace: &mut Workspace<S>,
        points: [&[f64]; 3],
        out: &mut [S],
        times: &mut [std::time::Duration],
    ) {
        let [x, y, z] = points;
        let n = x.len();
        assert!(y.len() == n && z.len() == n && out.len() == self.channels() * n);
        assert_eq!(times.len(), self.instrs.len(), "one time per instruction");
        workspace.bind(self);
        let mut start = 0;
        while start < n {
            let end = (start + LANES).min(n);
            let lanes = end - start;
            let (cx, cy, cz) = (&x[start..end], &y[start..end], &z[start..end]);
            for (instr, time) in self.instrs.iter().zip(times.iter_mut()) {
                let began = std::time::Instant::now();
                self.step::<S, false>(workspace, instr, [cx, cy, cz], None, lanes);
                *time += began.elapsed();
            }
            self.write_outputs::<S, false>(workspace, lanes, start, n, out);
            start = end;
        }
    }

    /// Runs one instruction over `n` lanes (the body of [`Tape::run_chunk`]'s loop).
    /// `spacing`: level of detail per lane ([`Tape::eval_batch_lod`]).
    ///
    /// An instruction with scalar operands runs on the slot file its precision names (the
    /// lane type's, or f64 for a promoted one, `in_file!`): one handler, generic over the
    /// file's type, serves both.
    #[inline(always)]
    fn step<S: Real, const ONE_LANE: bool>(
        &self,
        ws: &mut Workspace<S>,
        instr: &Instr,
        [x, y, z]: [&[f64]; 3],
        spacing: Option<&[f64]>,
        n: usize,
    ) {
        match *instr {
            Instr::Position { dst } => {
                let planes = &mut ws.vec3s[dst as usize];
                planes[..n].copy_from_slice(x);
                planes[LANES..LANES + n].copy_from_slice(y);
                planes[2 * LANES..2 * LANES + n].copy_from_slice(z);
            }
            Instr::Splat { prec, dst, src } => in_file!(ws, prec, f => {
                let s = &f[src as usize][..n];
                for plane in ws.vec3s[dst as usize].chunks_exact_mut(LANES) {
                    for (o, v) in plane[..n].iter_mut().zip(s) {
                        *o = v.to_f64();
                    }
                }
            }),
            Instr::Combine {
                prec,
                dst,
                x: sx,
                y: sy,
                z: sz,
            } => in_file!(ws, prec, f => {
                let out = &mut ws.vec3s[dst as usize];
                for (plane, src) in out.chunks_exact_mut(LANES).zip([sx, sy, sz]) {
                    for (o, v) in plane[..n].iter_mut().zip(&f[src as usize][..n]) {
                        *o = v.to_f64();
                    }
                }
            }),
            Instr::Component {
                prec,
                dst,
                src,
                axis,
            } => in_file!(ws, prec, f => {
                let plane = &ws.vec3s[src as usize][axis as usize % 3 * LANES..][..n];
                for (o, v) in f[dst as usize][..n].iter_mut().zip(plane) {
                    *o = Real::from_f64(*v);
                }
            }),
            // One lane (eval_point): the same per-lane `apply` on lane 0 directly; moving the
            // lane arrays out and back costs as much as the operation (5% of a marble point).
            Instr::UnaryScalar { prec, op, dst, src } if ONE_LANE => in_file!(ws, prec, f => {
                f[dst as usize][0] = op.apply(f[src as usize][0]);
            }),
            Instr::BinaryScalar {
                prec,
                op,
                dst,
                a,
                b,
            } if ONE_LANE => in_file!(ws, prec, f => {
                let (x, y) = (f[a as usize][0], f[b as usize][0]);
                f[dst as usize][0] = op.apply(x, y);
            }),
            Instr::UnaryScalar { prec, op, dst, src } => in_file!(ws, prec, f => {
                let mut out = take(&mut f[dst as usize]);
                unary_lanes(op, &mut out[..n], &f[src as usize][..n]);
                f[dst as usize] = out;
            }),
            Instr::UnaryVec3 { op, dst, src } => {
                let mut out = take(&mut ws.vec3s[dst as usize]);
                let a = &ws.vec3s[src as usize];
                for c in 0..3 {
                    unary_lanes(op, &mut out[c * LANES..][..n], &a[c * LANES..][..n]);
                }
                ws.vec3s[dst as usize] = out;
            }
            Instr::BinaryScalar {
                prec,
                op,
                dst,
                a,
                b,
            } => in_file!(ws, prec, f => {
                let mut out = take(&mut f[dst as usize]);
                binary_lanes(op, &mut out[..n], &f[a as usize][..n], &f[b as usize][..n]);
                f[dst as usize] = out;
            }),
            Instr::BinaryVec3 { op, dst, a, b } => {
                let mut out = take(&mut ws.vec3s[dst as usize]);
                let (a, b) = (&ws.vec3s[a as usize], &ws.vec3s[b as usize]);
                for c in 0..3 {
                    binary_lanes(
                        op,
                        &mut out[c * LANES..][..n],
                        &a[c * LANES..][..n],
                        &b[c * LANES..][..n],
                    );
                }
                ws.vec3s[dst as usize] = out;
            }
            Instr::TernaryScalar {
                prec,
                op,
                dst,
                a,
                b,
                c,
            } => in_file!(ws, prec, f => {
                let mut out = take(&mut f[dst as usize]);
                let [a, b, c] = [a, b, c].map(|s| &f[s as usize][..n]);
                ternary_lanes(op, &mut out[..n], a, b, c);
                f[dst as usize] = out;
            }),
            Instr::TernaryVec3 { op, dst, a, b, c } => {
                let mut out = take(&mut ws.vec3s[dst as usize]);
                let v = &ws.vec3s;
                for k in 0..3 {
                    let plane = |slot: u32| &v[slot as usize][k * LANES..][..n];
                    ternary_lanes(op, &mut out[k * LANES..][..n], plane(a), plane(b), plane(c));
                }
                ws.vec3s[dst as usize] = out;
            }
            Instr::Dot { .. }
            | Instr::Length { .. }
            | Instr::Cross { .. }
            | Instr::Normalize { .. }
            | Instr::RotateConst { .. }
            | Instr::RotateVarying { .. } => self.geometry(instr, ws, n),
            Instr::Noise { .. }
            | Instr::Fractal { .. }
            | Instr::NoiseGradient { .. }
            | Instr::FractalGradient { .. } => self.noise(instr, ws, spacing, n),
            Instr::Hermite { .. } | Instr::Ramp { .. } | Instr::Curve { .. } => {
                self.splines(instr, ws, n)
            }
            Instr::Widen { dst, src } => {
                let s = &ws.scalars[src as usize][..n];
                for (o, v) in ws.wides[dst as usize][..n].iter_mut().zip(s) {
                    *o = v.to_f64();
                }
            }
            Instr::Narrow { dst, src } => {
                let d = &ws.wides[src as usize][..n];
                for (o, v) in ws.scalars[dst as usize][..n].iter_mut().zip(d) {
                    *o = S::from_f64(*v);
                }
            }
        }
    }

    /// Per-lane vector geometry: dot, length, cross product, normalisation, rotation.
    #[inline(always)]
    fn geometry<S: Real>(&self, instr: &Instr, ws: &mut Workspace<S>, n: usize) {
        match *instr {
            Instr::Dot { prec, dst, a, b } => in_file!(ws, prec, f => {
                let (a, b) = (&ws.vec3s[a as usize], &ws.vec3s[b as usize]);
                for (i, o) in f[dst as usize][..n].iter_mut().enumerate() {
                    let lane = |v: &[f64]| [v[i], v[LANES + i], v[2 * LANES + i]];
                    *o = Real::from_f64(ops::dot(lane(a), lane(b)));
                }
            }),
            Instr::Length { prec, dst, src } => in_file!(ws, prec, f => {
                let a = &ws.vec3s[src as usize];
                for (i, o) in f[dst as usize][..n].iter_mut().enumerate() {
                    *o = Real::from_f64(ops::length([a[i], a[LANES + i], a[2 * LANES + i]]));
                }
            }),
            Instr::Cross { dst, a, b } => {
                let mut out = take(&mut ws.vec3s[dst as usize]);
                let (a, b) = (&ws.vec3s[a as usize], &ws.vec3s[b as usize]);
                for i in 0..n {
                    let lane = |v: &[f64]| [v[i], v[LANES + i], v[2 * LANES + i]];
                    set_lane(&mut out, i, ops::cross(lane(a), lane(b)));
                }
                ws.vec3s[dst as usize] = out;
            }
            Instr::Normalize { dst, src } => {
                let mut out = take(&mut ws.vec3s[dst as usize]);
                let a = &ws.vec3s[src as usize];
                for i in 0..n {
                    let c = ops::normalize([a[i], a[LANES + i], a[2 * LANES + i]]);
                    set_lane(&mut out, i, c);
                }
                ws.vec3s[dst as usize] = out;
            }
            Instr::RotateConst { dst, src, matrix } => {
                let m = &self.matrices[matrix as usize];
                let mut out = take(&mut ws.vec3s[dst as usize]);
                let a = &ws.vec3s[src as usize];
                for i in 0..n {
                    let p = ops::apply_matrix(m, [a[i], a[LANES + i], a[2 * LANES + i]]);
                    set_lane(&mut out, i, p);
                }
                ws.vec3s[dst as usize] = out;
            }
            Instr::RotateVarying {
                prec,
                dst,
                src,
                degrees,
                axis,
            } => in_file!(ws, prec, f => {
                let axis = self.axes[axis as usize];
                let mut out = take(&mut ws.vec3s[dst as usize]);
                let a = &ws.vec3s[src as usize];
                let d = &f[degrees as usize];
                for i in 0..n {
                    let m = ops::rotation_matrix(axis, d[i].to_f64());
                    let p = ops::apply_matrix(&m, [a[i], a[LANES + i], a[2 * LANES + i]]);
                    set_lane(&mut out, i, p);
                }
                ws.vec3s[dst as usize] = out;
            }),
            _ => unreachable!("run_chunk dispatches only geometry instructions here"),
        }
    }

    /// Noise samples, fractal sums and their gradients, through the tables' batch kernels, in
    /// the lane type or (promoted) in f64: every basis' f64 form is the reference path's.
    #[inline(always)]
    fn noise<S: Real>(
        &self,
        instr: &Instr,
        ws: &mut Workspace<S>,
        spacing: Option<&[f64]>,
        n: usize,
    ) {
        match *instr {
            Instr::Noise {
                prec,
                dst,
                src,
                table,
            } => in_file!(ws, prec, f => {
                self.sample_into(table, &ws.vec3s[src as usize], n, &mut f[dst as usize]);
            }),
            Instr::Fractal {
                prec,
                dst,
                src,
                table,
                octaves,
                style,
                bias,
            } => in_file!(ws, prec, f => {
                let fractal = FractalInstr {
                    table,
                    octaves,
                    style,
                    bias,
                };
                let scratch = (&mut ws.kept[..], &mut ws.bias[..]);
                let out = &mut f[dst as usize];
                self.fractal_into(fractal, &ws.vec3s[src as usize], spacing, scratch, n, out);
            }),
            Instr::NoiseGradient {
                prec,
                dst,
                src,
                table,
            } => match prec {
                Prec::Lane => self.gradient_into::<S, S>(dst, src, table, None, ws, spacing, n),
                Prec::Wide => self.gradient_into::<f64, S>(dst, src, table, None, ws, spacing, n),
            },
            Instr::FractalGradient {
                prec,
                dst,
                src,
                table,
                octaves,
                style,
            } => {
                let fractal = Some((octaves, style));
                match prec {
                    Prec::Lane => {
                        self.gradient_into::<S, S>(dst, src, table, fractal, ws, spacing, n)
                    }
                    Prec::Wide => {
                        self.gradient_into::<f64, S>(dst, src, table, fractal, ws, spacing, n)
                    }
                }
            }
            _ => unreachable!("run_chunk dispatches only noise instructions here"),
        }
    }

    /// `NoiseGradient` (`fractal` None) or `FractalGradient` (its schedule and style): the
    /// gradient per lane of the point planes `src` into vec3 slot `dst`, the kernels in `K` (the
    /// lane type, or f64 for a promoted gradient; vec3 slots are f64 either way).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn gradient_into<K: Real, S: Real>(
        &self,
        dst: Slot,
        src: Slot,
        table: u32,
        fractal: Option<(u32, noise::Style)>,
        ws: &mut Workspace<S>,
        spacing: Option<&[f64]>,
        n: usize,
    ) {
        let mut out = take(&mut ws.vec3s[dst as usize]);
        let a = &ws.vec3s[src as usize];
        let (x, y, z) = (&a[..n], &a[LANES..LANES + n], &a[2 * LANES..2 * LANES + n]);
        let (gx, rest) = out.split_at_mut(LANES);
        let (gy, gz) = rest.split_at_mut(LANES);
        let g = [&mut gx[..n], &mut gy[..n], &mut gz[..n]];
        let table = &self.tables[table as usize].1;
        match fractal {
            None => table.sample_grad_batch::<K>(x, y, z, g),
            Some((octaves, style)) => {
                let schedule = &self.octaves[octaves as usize];
                // The dropped octaves' mean is a constant: it adds no slope.
                match self.lanes_dropping(octaves, spacing, &mut ws.kept[..n]) {
                    Some(lod) => {
                        let lanes = noise::LaneOctaves {
                            powers: lod.powers(),
                            kept: &ws.kept[..n],
                        };
                        noise::fractal_styled_grad_batch_lanes::<K>(
                            table, schedule, lanes, style, x, y, z, g,
                        )
                    }
                    None => {
                        noise::fractal_styled_grad_batch::<K>(table, schedule, style, x, y, z, g)
                    }
                }
            }
        }
        ws.vec3s[dst as usize] = out;
    }

    /// `Noise`: a sample per lane of the point planes `a`, in `T` (the lane type, or f64 for a
    /// promoted instruction), through the table's batch kernel.
    #[inline(always)]
    fn sample_into<T: Real>(&self, table: u32, a: &[f64], n: usize, out: &mut [T]) {
        let table = &self.tables[table as usize].1;
        let (x, y, z) = (&a[..n], &a[LANES..LANES + n], &a[2 * LANES..2 * LANES + n]);
        table.sample_batch(x, y, z, &mut out[..n]);
    }

    /// `Fractal`: the sum per lane of the point planes `a`, in `T`, with level of detail per
    /// lane where `spacing` drops octaves (`scratch`: the workspace's kept counts and biases),
    /// plus the instruction's bias.
    #[inline(always)]
    fn fractal_into<T: Real>(
        &self,
        f: FractalInstr,
        a: &[f64],
        spacing: Option<&[f64]>,
        (kept, biases): (&mut [f64], &mut [f64]),
        n: usize,
        out: &mut [T],
    ) {
        let (x, y, z) = (&a[..n], &a[LANES..LANES + n], &a[2 * LANES..2 * LANES + n]);
        let table = &self.tables[f.table as usize].1;
        let schedule = &self.octaves[f.octaves as usize];
        let out = &mut out[..n];
        if let Some(lod) = self.lanes_dropping(f.octaves, spacing, &mut kept[..n]) {
            let kept = &kept[..n];
            let lanes = noise::LaneOctaves {
                powers: lod.powers(),
                kept,
            };
            noise::fractal_styled_batch_lanes(table, schedule, lanes, f.style, x, y, z, out);
            lod.biases(kept, biases);
            for (v, &bias) in out.iter_mut().zip(&biases[..n]) {
                // As the plain path: a zero bias adds nothing (not even to a -0).
                *v = if bias != 0.0 {
                    *v + T::from_f64(bias)
                } else {
                    *v
                };
            }
            return;
        }
        noise::fractal_styled_batch(table, schedule, f.style, x, y, z, out);
        if f.bias != 0.0 {
            let bias = T::from_f64(f.bias);
            for v in out {
                *v = *v + bias;
            }
        }
    }

    /// With level of detail per lane: each lane's kept octaves of schedule `octaves` into
    /// `kept`, and the schedule's [`LaneLod`](crate::lod::LaneLod) when some lane drops an octave
    /// the schedule has (else the plain kernels run, whose bits are the same for lanes that drop
    /// nothing).
    #[inline(always)]
    fn lanes_dropping(
        &self,
        octaves: u32,
        spacing: Option<&[f64]>,
        kept: &mut [f64],
    ) -> Option<&crate::lod::LaneLod> {
        let lod = self.lane_lods[octaves as usize].as_ref()?;
        let mut drops = false;
        for (k, &h) in kept.iter_mut().zip(spacing?) {
            *k = lod.kept(h);
            drops |= lod.drops(*k);
        }
        drops.then_some(lod)
    }

    /// Splines: Hermite, colour ramps and curves.
    #[inline(always)]
    fn splines<S: Real>(&self, instr: &Instr, ws: &mut Workspace<S>, n: usize) {
        match *instr {
            Instr::Hermite { dst, src, spline } => {
                let h = self.hermites[spline as usize];
                let mut out = take(&mut ws.scalars[dst as usize]);
                for (o, v) in out[..n].iter_mut().zip(&ws.scalars[src as usize][..n]) {
                    *o = h.apply(*v);
                }
                ws.scalars[dst as usize] = out;
            }
            Instr::Ramp { dst, src, ramp } => {
                let ramp = &self.ramps[ramp as usize];
                let out = &mut ws.vec3s[dst as usize];
                for (i, t) in ws.scalars[src as usize][..n].iter().enumerate() {
                    let c = ramp.eval(t.to_f64());
                    out[i] = c[0];
                    out[LANES + i] = c[1];
                    out[2 * LANES + i] = c[2];
                }
            }
            Instr::Curve { dst, src, curve } => {
                let curve = &self.curves[curve as usize];
                let mut out = take(&mut ws.scalars[dst as usize]);
                for (o, t) in out[..n].iter_mut().zip(&ws.scalars[src as usize][..n]) {
                    *o = S::from_f64(curve.eval(t.to_f64())[0]);
                }
                ws.scalars[dst as usize] = out;
            }
            _ => unreachable!("run_chunk dispatches only splines instructions here"),
        }
    }
}

/// A fractal instruction's parameters (`Instr::Fractal`).
#[derive(Clone, Copy)]
struct FractalInstr {
    table: u32,
    octaves: u32,
    style: noise::Style,
    bias: f64,
}

/// Writes a vec3 into lane `i` of three planes.
#[inline(always)]
fn set_lane(planes: &mut [f64], i: usize, v: [f64; 3]) {
    planes[i] = v[0];
    planes[LANES + i] = v[1];
    planes[2 * LANES + i] = v[2];
}

/// One loop per operation: the `match` is outside, so each loop body is a single operation the
/// compiler can vectorise. Each arm calls the op's own `apply` with a constant op, so the lane
/// semantics are the ones defined in `ops` (also used by constant folding).
#[inline]
fn unary_lanes<T: Real>(op: UnaryOp, out: &mut [T], a: &[T]) {
    macro_rules! lanes {
        ($op:expr) => {
            for (o, x) in out.iter_mut().zip(a) {
                *o = $op.apply(*x);
            }
        };
    }
    match op {
        UnaryOp::Abs => lanes!(UnaryOp::Abs),
        UnaryOp::Neg => lanes!(UnaryOp::Neg),
        UnaryOp::Sin => lanes!(UnaryOp::Sin),
        UnaryOp::Cos => lanes!(UnaryOp::Cos),
        UnaryOp::Sqrt => lanes!(UnaryOp::Sqrt),
        UnaryOp::Floor => lanes!(UnaryOp::Floor),
        UnaryOp::Fract => lanes!(UnaryOp::Fract),
        UnaryOp::Exp => lanes!(UnaryOp::Exp),
        UnaryOp::Log => lanes!(UnaryOp::Log),
        UnaryOp::Log2 => lanes!(UnaryOp::Log2),
        UnaryOp::Tan => lanes!(UnaryOp::Tan),
        UnaryOp::Asin => lanes!(UnaryOp::Asin),
        UnaryOp::Acos => lanes!(UnaryOp::Acos),
        UnaryOp::Sign => lanes!(UnaryOp::Sign),
        UnaryOp::Round => lanes!(UnaryOp::Round),
        UnaryOp::Trunc => lanes!(UnaryOp::Trunc),
    }
}

#[inline]
fn binary_lanes<T: Real>(op: BinaryOp, out: &mut [T], a: &[T], b: &[T]) {
    macro_rules! lanes {
        ($op:expr) => {
            for ((o, x), y) in out.iter_mut().zip(a).zip(b) {
                *o = $op.apply(*x, *y);
            }
        };
    }
    match op {
        BinaryOp::Add => lanes!(BinaryOp::Add),
        BinaryOp::Sub => lanes!(BinaryOp::Sub),
        BinaryOp::Mul => lanes!(BinaryOp::Mul),
        BinaryOp::Div => lanes!(BinaryOp::Div),
        BinaryOp::Min => lanes!(BinaryOp::Min),
        BinaryOp::Max => lanes!(BinaryOp::Max),
        BinaryOp::Pow => lanes!(BinaryOp::Pow),
        BinaryOp::Atan2 => lanes!(BinaryOp::Atan2),
        BinaryOp::Mod => lanes!(BinaryOp::Mod),
        BinaryOp::Step => lanes!(BinaryOp::Step),
    }
}

#[inline]
fn ternary_lanes<T: Real>(op: TernaryOp, out: &mut [T], a: &[T], b: &[T], c: &[T]) {
    macro_rules! lanes {
        ($op:expr) => {
            for (((o, x), y), z) in out.iter_mut().zip(a).zip(b).zip(c) {
                *o = $op.apply(*x, *y, *z);
            }
        };
    }
    match op {
        TernaryOp::Clamp => lanes!(TernaryOp::Clamp),
        TernaryOp::Mix => lanes!(TernaryOp::Mix),
        TernaryOp::Smoothstep => lanes!(TernaryOp::Smoothstep),
        TernaryOp::Select => lanes!(TernaryOp::Select),
    }
}
