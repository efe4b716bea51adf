//! NumPy arrays in and out: points read in place, outputs written in place, the batch split
//! into chunks over the thread pool (each chunk the library's `Tape::eval_batch` or the
//! filtered form's `eval_batch_with`).

use crate::run;
use numpy::{
    PyArray2, PyArrayDescrMethods, PyArrayMethods, PyReadonlyArray2, PyUntypedArray,
    PyUntypedArrayMethods,
};
use pyo3::exceptions::{PyKeyError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};
use texgraph::filter::{FilterWorkspace, Filtered, Footprint};
use texgraph::{Real, Tape, Type, Workspace};

/// Points per chunk: the command line's `eval --points` chunk.
const CHUNK: usize = 4096;
/// Below this many points an evaluation runs without a watcher thread for Ctrl-C.
const WATCHED: usize = 1 << 18;

/// `points`, shape (N, 3), C-contiguous, as float32 or float64.
pub enum Points<'py> {
    F32(PyReadonlyArray2<'py, f32>),
    F64(PyReadonlyArray2<'py, f64>),
}

impl<'py> Points<'py> {
    /// Any array-like: a float32 or float64 C-contiguous (N, 3) array is read in place; any
    /// other real array-like is converted to float64 first.
    pub fn from_python(py: Python<'py>, points: &Bound<'py, PyAny>) -> PyResult<Points<'py>> {
        let np = py.import("numpy")?;
        let array = np.call_method1("asarray", (points,))?;
        let untyped = array.cast::<PyUntypedArray>()?;
        let kind = untyped.dtype().kind();
        if !matches!(kind, b'f' | b'i' | b'u') || untyped.ndim() != 2 || untyped.shape()[1] != 3 {
            return Err(PyValueError::new_err(format!(
                "points: expected an array of shape (N, 3) of real numbers, got shape {:?} of dtype {}",
                untyped.shape(),
                untyped.dtype().str()?
            )));
        }
        if let Ok(a) = array.cast::<PyArray2<f32>>() {
            if a.is_c_contiguous() {
                return Ok(Points::F32(a.readonly()));
            }
        }
        if let Ok(a) = array.cast::<PyArray2<f64>>() {
            if a.is_c_contiguous() {
                return Ok(Points::F64(a.readonly()));
            }
        }
        let copy = np.call_method1("ascontiguousarray", (array, np.getattr("float64")?))?;
        Ok(Points::F64(copy.cast_into::<PyArray2<f64>>()?.readonly()))
    }

    pub fn len(&self) -> usize {
        match self {
            Points::F32(a) => a.shape()[0],
            Points::F64(a) => a.shape()[0],
        }
    }
}

/// Where an evaluation's outputs go: one array per output of the tape, each (N,) or (N, 3).
pub struct Target<'py> {
    arrays: Vec<Bound<'py, PyUntypedArray>>,
    /// What to return: one array (`output=`) or a dict by name.
    result: Bound<'py, PyAny>,
    f64: bool,
}

impl<'py> Target<'py> {
    /// New arrays, or the arrays of `out=` checked against the tape's outputs.
    pub fn new(
        py: Python<'py>,
        tape: &Tape,
        n: usize,
        f64: bool,
        single: bool,
        out: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Target<'py>> {
        let dict = PyDict::new(py);
        let mut arrays = Vec::new();
        for o in tape.outputs() {
            let given = match out {
                None => None,
                Some(a) if single => Some(a.clone()),
                Some(d) => {
                    let d = d.cast::<PyDict>().map_err(|_| {
                        PyValueError::new_err(
                            "out=: without output=, give a dict of arrays by output name",
                        )
                    })?;
                    Some(d.get_item(&o.name)?.ok_or_else(|| {
                        PyKeyError::new_err(format!("out=: no array for output {:?}", o.name))
                    })?)
                }
            };
            let array = match given {
                Some(a) => checked_out(&a, &o.name, o.ty, n, f64)?,
                None => new_array(py, o.ty, n, f64)?,
            };
            dict.set_item(&o.name, &array)?;
            arrays.push(array);
        }
        let result = match (single, arrays.first()) {
            (true, Some(a)) => a.clone().into_any(),
            _ => dict.into_any(),
        };
        Ok(Target {
            arrays,
            result,
            f64,
        })
    }
}

fn shape_of(ty: Type, n: usize) -> Vec<usize> {
    match ty.channels() {
        1 => vec![n],
        c => vec![n, c],
    }
}

fn new_array<'py>(
    py: Python<'py>,
    ty: Type,
    n: usize,
    f64: bool,
) -> PyResult<Bound<'py, PyUntypedArray>> {
    let shape = shape_of(ty, n);
    let any = match f64 {
        true => numpy::PyArrayDyn::<f64>::zeros(py, shape, false).into_any(),
        false => numpy::PyArrayDyn::<f32>::zeros(py, shape, false).into_any(),
    };
    Ok(any.cast_into::<PyUntypedArray>()?)
}

fn checked_out<'py>(
    a: &Bound<'py, PyAny>,
    name: &str,
    ty: Type,
    n: usize,
    f64: bool,
) -> PyResult<Bound<'py, PyUntypedArray>> {
    let dtype = if f64 { "float64" } else { "float32" };
    let shape = shape_of(ty, n);
    let wrong = || {
        PyValueError::new_err(format!(
            "out= for output {name:?}: expected a writeable C-contiguous {dtype} array of shape {:?}",
            shape
        ))
    };
    let array = a.cast::<PyUntypedArray>().map_err(|_| wrong())?;
    let typed = if f64 {
        array.cast::<numpy::PyArrayDyn<f64>>().is_ok()
    } else {
        array.cast::<numpy::PyArrayDyn<f32>>().is_ok()
    };
    let writeable: bool = array.getattr("flags")?.getattr("writeable")?.extract()?;
    if !typed || array.shape() != shape.as_slice() || !array.is_c_contiguous() || !writeable {
        return Err(wrong());
    }
    Ok(array.clone())
}

/// `footprint=`: a side W or sides (WX, WY, WZ), each >= 0.
pub fn footprint(value: &Bound<'_, PyAny>) -> PyResult<Footprint> {
    let sides = match value.extract::<f64>() {
        Ok(w) => [w; 3],
        Err(_) => value.extract::<[f64; 3]>().map_err(|_| {
            PyValueError::new_err("footprint=: give a side W or sides (WX, WY, WZ)")
        })?,
    };
    Footprint::from_sides(sides).map_err(|e| PyValueError::new_err(format!("footprint=: {e}")))
}

/// `size=`: n (a cube) or (nx, ny, nz).
pub fn size(value: &Bound<'_, PyAny>) -> PyResult<[usize; 3]> {
    match value.extract::<usize>() {
        Ok(n) => Ok([n; 3]),
        Err(_) => value.extract::<[usize; 3]>().map_err(|_| {
            PyValueError::new_err("size=: give n or (nx, ny, nz), whole numbers >= 1")
        }),
    }
}

/// Refuses a bake whose arrays would hold more than the command line's bound on a volume held
/// in memory (`DEFAULT_MAX_HELD_BYTES`, 2 GiB) unless `allow_large`.
pub fn check_held(grid: &texgraph::bake::Grid, channels: usize, allow_large: bool) -> PyResult<()> {
    use texgraph::bake::{human_bytes, DEFAULT_MAX_HELD_BYTES};
    let bytes = grid
        .voxels()
        .map_or(u64::MAX, |v| v.saturating_mul(channels as u64 * 4));
    if bytes > DEFAULT_MAX_HELD_BYTES && !allow_large {
        return Err(PyValueError::new_err(format!(
            "Graph.bake holds the whole volume in memory: this bake would hold about {}, more than the limit of {}; a smaller size, or pass allow_large=True",
            human_bytes(bytes),
            human_bytes(DEFAULT_MAX_HELD_BYTES)
        )));
    }
    Ok(())
}

/// Evaluates `tape` (filtered over `footprint` when given) at `points` into `target`'s arrays,
/// with the GIL released; returns what `target` returns.
pub fn evaluate<'py>(
    py: Python<'py>,
    tape: &Tape,
    points: &Points<'py>,
    target: Target<'py>,
    footprint: Option<Footprint>,
    threads: usize,
) -> PyResult<Bound<'py, PyAny>> {
    let filtered = footprint.map(|f| (Filtered::new(tape), f));
    match (points, target.f64) {
        (Points::F32(p), false) => {
            into::<f32, f32>(py, tape, p.as_slice()?, &target, &filtered, threads)?
        }
        (Points::F32(p), true) => {
            into::<f32, f64>(py, tape, p.as_slice()?, &target, &filtered, threads)?
        }
        (Points::F64(p), false) => {
            into::<f64, f32>(py, tape, p.as_slice()?, &target, &filtered, threads)?
        }
        (Points::F64(p), true) => {
            into::<f64, f64>(py, tape, p.as_slice()?, &target, &filtered, threads)?
        }
    }
    Ok(target.result)
}

/// A coordinate type of the points array.
pub trait Coordinate: Copy + Send + Sync + numpy::Element {
    fn to_f64(self) -> f64;
}
impl Coordinate for f32 {
    fn to_f64(self) -> f64 {
        f64::from(self)
    }
}
impl Coordinate for f64 {
    fn to_f64(self) -> f64 {
        self
    }
}

fn into<T: Coordinate, S: Real + numpy::Element>(
    py: Python<'_>,
    tape: &Tape,
    points: &[T],
    target: &Target<'_>,
    filtered: &Option<(Filtered<'_>, Footprint)>,
    threads: usize,
) -> PyResult<()> {
    let mut guards = Vec::with_capacity(target.arrays.len());
    for a in &target.arrays {
        guards.push(a.cast::<numpy::PyArrayDyn<S>>()?.readwrite());
    }
    let mut outs: Vec<&mut [S]> = Vec::with_capacity(guards.len());
    for g in guards.iter_mut() {
        outs.push(g.as_slice_mut()?);
    }
    let n = points.len() / 3;
    run::interruptible(py, n >= WATCHED, move |cancel| {
        fill(tape, points, outs, filtered, threads, cancel)
    })?;
    Ok(())
}

/// Per-worker buffers of a chunk.
struct Scratch<S: Real> {
    workspace: Workspace<S>,
    filter: FilterWorkspace<S>,
    xyz: [Vec<f64>; 3],
    planar: Vec<S>,
}

/// One chunk's share of every output array.
struct Job<'a, S> {
    start: usize,
    len: usize,
    outs: Vec<&'a mut [S]>,
}

fn fill<T: Coordinate, S: Real>(
    tape: &Tape,
    points: &[T],
    outs: Vec<&mut [S]>,
    filtered: &Option<(Filtered<'_>, Footprint)>,
    threads: usize,
    cancel: &AtomicBool,
) {
    let n = points.len() / 3;
    let mut jobs: Vec<Job<'_, S>> = (0..n.div_ceil(CHUNK))
        .map(|j| Job {
            start: j * CHUNK,
            len: CHUNK.min(n - j * CHUNK),
            outs: Vec::with_capacity(outs.len()),
        })
        .collect();
    for (out, o) in outs.into_iter().zip(tape.outputs()) {
        for (job, part) in jobs.iter_mut().zip(out.chunks_mut(CHUNK * o.ty.channels())) {
            job.outs.push(part);
        }
    }
    let new_scratch = || Scratch {
        workspace: Workspace::<S>::new(),
        filter: FilterWorkspace::<S>::default(),
        xyz: Default::default(),
        planar: Vec::new(),
    };
    let work = |s: &mut Scratch<S>, job: Job<'_, S>| {
        if !cancel.load(Ordering::Relaxed) {
            chunk(tape, points, filtered, s, job);
        }
    };
    let threads = texgraph::bake::capped_threads(threads).0;
    if threads <= 1 || jobs.len() <= 1 {
        let mut s = new_scratch();
        jobs.into_iter().for_each(|job| work(&mut s, job));
    } else {
        run::pool(threads).install(|| jobs.into_par_iter().for_each_init(new_scratch, work));
    }
}

/// One chunk: its coordinates as f64 planes, the library's batch, the planar result spread
/// into each output's rows.
fn chunk<T: Coordinate, S: Real>(
    tape: &Tape,
    points: &[T],
    filtered: &Option<(Filtered<'_>, Footprint)>,
    s: &mut Scratch<S>,
    job: Job<'_, S>,
) {
    let (start, m) = (job.start, job.len);
    for plane in s.xyz.iter_mut() {
        plane.resize(m, 0.0);
    }
    let [x, y, z] = &mut s.xyz;
    for (i, p) in points[start * 3..(start + m) * 3]
        .chunks_exact(3)
        .enumerate()
    {
        x[i] = p[0].to_f64();
        y[i] = p[1].to_f64();
        z[i] = p[2].to_f64();
    }
    // Every channel of every point is written by the evaluation: no clearing.
    s.planar.resize(tape.channels() * m, S::ZERO);
    let [x, y, z] = &s.xyz;
    match filtered {
        Some((f, footprint)) => f.eval_batch_with(
            &mut s.filter,
            [x, y, z],
            std::slice::from_ref(footprint),
            &mut s.planar,
        ),
        None => tape.eval_batch(&mut s.workspace, x, y, z, &mut s.planar),
    }
    for (out, o) in job.outs.into_iter().zip(tape.outputs()) {
        let plane = |c: usize| &s.planar[(o.first_channel + c) * m..][..m];
        match o.ty.channels() {
            1 => out.copy_from_slice(plane(0)),
            _ => {
                let (a, b, c) = (plane(0), plane(1), plane(2));
                for (i, v) in out.chunks_exact_mut(3).enumerate() {
                    v[0] = a[i];
                    v[1] = b[i];
                    v[2] = c[i];
                }
            }
        }
    }
}
