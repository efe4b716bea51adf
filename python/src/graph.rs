//! `texgraph.Graph`: a checked graph, its tapes compiled on demand (one per output selection
//! and region, kept), evaluated at points or baked over a grid.

use crate::arrays::{self, Points, Target};
use crate::{load_error, run, Source};
use numpy::{IntoPyArray, PyArrayMethods};
use pyo3::exceptions::{PyKeyError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::collections::HashMap;
use std::sync::{Arc, Mutex};
use texgraph::bake::{BakeError, BakeOptions, Grid, Precision, Region};
use texgraph::filter::Filter;
use texgraph::{CheckOptions, CheckedGraph, CompileOptions, LoadError, Tape};

/// Which tape: the outputs compiled (`None`: all) and the region its precision plan is for
/// (`None`: no region, every scalar in f32, as `eval --points`).
type TapeKey = (Option<String>, Option<[u64; 6]>);

/// A checked graph: `texgraph.load(path)` or `texgraph.loads(text)`.
///
/// `outputs` and `params` describe it; `eval(points)` evaluates it at points and `bake(size)`
/// over a grid of voxel centres, into NumPy arrays, on the library's thread pool with the GIL
/// released.
#[pyclass(frozen, module = "texgraph")]
pub struct Graph {
    graph: CheckedGraph,
    /// The `set=` overrides it was checked with (for pickling).
    sets: Vec<(String, f64)>,
    tapes: Mutex<HashMap<TapeKey, Arc<Tape>>>,
}

impl Graph {
    /// Checks `file` with `sets` as `--set` overrides.
    pub(crate) fn check(py: Python<'_>, file: Source, sets: Vec<(String, f64)>) -> PyResult<Graph> {
        let options = CheckOptions {
            overrides: sets.clone(),
        };
        let source = file.clone();
        let graph = py
            .detach(|| texgraph::check(source, &options))
            .map_err(|d| match unknown_params(&d, &sets) {
                Some(unknown) => known_params_error(py, file, unknown),
                None => load_error(py, LoadError::Invalid(d)),
            })?;
        Ok(Graph {
            graph,
            sets,
            tapes: Mutex::new(HashMap::new()),
        })
    }

    /// The tape for `output` (all when `None`) compiled for `region` (none when `None`).
    fn tape(
        &self,
        py: Python<'_>,
        output: Option<&str>,
        region: Option<Region>,
    ) -> PyResult<Arc<Tape>> {
        if let Some(name) = output {
            self.known_output(name)?;
        }
        let key: TapeKey = (
            output.map(str::to_string),
            region.map(|r| {
                let b = |v: f64| v.to_bits();
                [
                    b(r.min[0]),
                    b(r.min[1]),
                    b(r.min[2]),
                    b(r.max[0]),
                    b(r.max[1]),
                    b(r.max[2]),
                ]
            }),
        );
        let mut tapes = self.tapes.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(t) = tapes.get(&key) {
            return Ok(t.clone());
        }
        let options = CompileOptions {
            outputs: output.map(|o| vec![o.to_string()]).unwrap_or_default(),
            spacing: None,
            extent: region.map(|r| texgraph::Extent::new(r.min, r.max)),
            max_error: None,
        };
        let tape = texgraph::compile(&self.graph, &options)
            .map_err(|d| load_error(py, LoadError::Invalid(d)))?;
        let tape = Arc::new(tape);
        tapes.insert(key, tape.clone());
        Ok(tape)
    }

    fn known_output(&self, name: &str) -> PyResult<()> {
        if self.graph.output(name).is_some() {
            return Ok(());
        }
        let known: Vec<String> = self
            .graph
            .outputs()
            .iter()
            .map(|o| format!("{:?}", o.name))
            .collect();
        Err(PyKeyError::new_err(format!(
            "the graph has no output {name:?}; its outputs are: {}",
            known.join(", ")
        )))
    }
}

/// The `set=` names the graph has no param for, when they are its only problems.
fn unknown_params(d: &texgraph::Diagnostics, sets: &[(String, f64)]) -> Option<Vec<String>> {
    use texgraph::diagnostic::DiagnosticClass;
    let names: Vec<String> = d
        .list
        .iter()
        .filter(|d| d.class == DiagnosticClass::UnknownParam && d.span.is_none())
        .filter_map(|d| {
            sets.iter()
                .find(|(n, _)| d.message.ends_with(&format!("no param \"{n}\"")))
        })
        .map(|(n, _)| n.clone())
        .collect();
    (!names.is_empty() && names.len() == d.list.len()).then_some(names)
}

/// `KeyError` naming the unknown `set=` names and every param the graph has (checked again
/// without `set=` to list them).
fn known_params_error(py: Python<'_>, file: Source, unknown: Vec<String>) -> PyErr {
    let known = match py.detach(|| texgraph::check(file, &CheckOptions::default())) {
        Ok(g) => g
            .params()
            .iter()
            .map(|(n, _)| format!("{n:?}"))
            .collect::<Vec<_>>(),
        Err(_) => Vec::new(),
    };
    let unknown: Vec<String> = unknown.iter().map(|n| format!("{n:?}")).collect();
    PyKeyError::new_err(format!(
        "set=: the graph has no param {}; its params are: {}",
        unknown.join(", "),
        if known.is_empty() {
            "none".to_string()
        } else {
            known.join(", ")
        }
    ))
}

#[pymethods]
impl Graph {
    /// The file name the graph was read from (or the `name` given to `loads`).
    #[getter]
    fn name(&self) -> String {
        self.graph.file().name.clone()
    }

    /// `{output name: "scalar" | "vec3"}`, in file order.
    #[getter]
    fn outputs<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let tape = self.tape(py, None, None)?;
        let d = PyDict::new(py);
        for o in tape.outputs() {
            d.set_item(&o.name, o.ty.to_string())?;
        }
        Ok(d)
    }

    /// `{param name: value}`, in file order, with the `set=` values applied.
    #[getter]
    fn params<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for (name, value) in self.graph.params() {
            d.set_item(name, value)?;
        }
        Ok(d)
    }

    /// The compiled tape's disassembly, as `texgraph check --tape` prints it after its summary.
    #[pyo3(name = "tape", signature = (output=None))]
    fn tape_text(&self, py: Python<'_>, output: Option<&str>) -> PyResult<String> {
        Ok(self.tape(py, output, None)?.to_string())
    }

    /// The graph at each point of `points`, an array-like of shape (N, 3) (float32 or float64
    /// arrays are read in place when C-contiguous; other real dtypes are converted to float64).
    /// Returns `{name: array}`: float32 (float64 with `f64=True`), shape (N,) for a scalar output
    /// and (N, 3) for a vec3 one; with `output=NAME` that one array. `out=` writes into
    /// preallocated arrays instead (an array with `output=`, else a dict of arrays by output
    /// name) and returns them. The values are `texgraph eval --points` (`--f64`) bit for bit.
    /// `footprint=W` or `(WX, WY, WZ)`: each output's estimated mean over that box around each
    /// point (`eval --footprint`, docs/filtering.md). `threads=` as `--threads` (None or 0: one
    /// per core; 1: this thread alone).
    #[pyo3(signature = (points, output=None, f64=false, out=None, threads=None, footprint=None))]
    #[allow(clippy::too_many_arguments)]
    fn eval<'py>(
        &self,
        py: Python<'py>,
        points: &Bound<'py, PyAny>,
        output: Option<&str>,
        f64: bool,
        out: Option<&Bound<'py, PyAny>>,
        threads: Option<usize>,
        footprint: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let points = Points::from_python(py, points)?;
        let footprint = footprint.map(arrays::footprint).transpose()?;
        let tape = self.tape(py, output, None)?;
        let target = Target::new(py, &tape, points.len(), f64, output.is_some(), out)?;
        arrays::evaluate(py, &tape, &points, target, footprint, threads.unwrap_or(0))
    }

    /// Bakes over a grid of `size` voxels (an int, or (nx, ny, nz)) spanning `region`, each
    /// voxel its cell's centre, as `texgraph bake`: `{name: array}` of float32, shape
    /// (nz, ny, nx) for scalars and (nz, ny, nx, 3) for vec3 (x fastest), bit for bit the
    /// files of `texgraph bake --format raw --raw-type f32` (`f64=True`: evaluated in f64 and
    /// stored as float32, as `--f64`). `filter="box"`: each voxel the estimate of its cell's
    /// mean (`--filter box`). A volume of more than 2 GiB is refused (a `ValueError`) unless
    /// `allow_large=True`. Ctrl-C (KeyboardInterrupt) stops it within a window of voxels.
    #[pyo3(signature = (size, region=None, output=None, threads=None, f64=false, allow_large=false, filter="point"))]
    #[allow(clippy::too_many_arguments)]
    fn bake<'py>(
        &self,
        py: Python<'py>,
        size: &Bound<'py, PyAny>,
        region: Option<([f64; 3], [f64; 3])>,
        output: Option<&str>,
        threads: Option<usize>,
        f64: bool,
        allow_large: bool,
        filter: &str,
    ) -> PyResult<Bound<'py, PyAny>> {
        let size = arrays::size(size)?;
        let region = region.map_or_else(Region::default, |(min, max)| Region { min, max });
        let grid = Grid { size, region };
        texgraph::bake::validate_grid(&grid).map_err(|e| PyValueError::new_err(e.to_string()))?;
        let filter = match filter {
            "point" => Filter::Point,
            "box" => Filter::Box,
            other => {
                return Err(PyValueError::new_err(format!(
                    "filter={other:?}: give \"point\" or \"box\""
                )))
            }
        };
        let tape = self.tape(py, output, Some(region))?;
        arrays::check_held(&grid, tape.channels(), allow_large)?;
        let options = BakeOptions {
            grid,
            threads: threads.unwrap_or(0),
            precision: if f64 { Precision::F64 } else { Precision::F32 },
            cancel: None,
            device: texgraph::gpu::Device::Cpu,
            filter,
            replay: None,
        };
        let volume = run::interruptible(py, true, |cancel| {
            let options = BakeOptions {
                cancel: Some(cancel.clone()),
                ..options
            };
            texgraph::bake::bake_volume(&tape, &options)
        })?
        .map_err(|e| match e {
            BakeError::Cancelled => pyo3::exceptions::PyKeyboardInterrupt::new_err("bake stopped"),
            other => PyValueError::new_err(other.to_string()),
        })?;
        let [nx, ny, nz] = grid.size;
        let d = PyDict::new(py);
        for o in volume.outputs {
            let array = o.data.into_pyarray(py);
            let array = match o.ty.channels() {
                1 => array.reshape([nz, ny, nx])?.into_any(),
                c => array.reshape([nz, ny, nx, c])?.into_any(),
            };
            if output.is_some() {
                return Ok(array);
            }
            d.set_item(&o.name, array)?;
        }
        Ok(d.into_any())
    }

    /// Bakes the graph into the UV layout of the model at `path` (glTF `.gltf`/`.glb` or
    /// `.obj`), as `texgraph bake --mesh`: `size` is W or (W, H) texels; returns `{name:
    /// array}` of float32, shape (H, W) for scalars and (H, W, 3) for colours (row 0 the top,
    /// texel (i, j) at `[j, i]`), bit for bit the values `--format exr` writes; with
    /// `output=NAME` that output only. `normal=NAME` adds `"normal"`, the tangent-space normal
    /// map of that scalar output's gradient, encoded (n · 0.5 + 0.5) as `--normal` writes it;
    /// `filter`, `padding`, `space`, `normal_strength`, `normal_y` as the command's options.
    #[pyo3(signature = (path, size, output=None, normal=None, filter="point", padding=8, space="object", normal_strength=1.0, normal_y="up", f64=false, threads=None))]
    #[allow(clippy::too_many_arguments)]
    fn bake_mesh<'py>(
        &self,
        py: Python<'py>,
        path: std::path::PathBuf,
        size: &Bound<'py, PyAny>,
        output: Option<&str>,
        normal: Option<&str>,
        filter: &str,
        padding: u32,
        space: &str,
        normal_strength: f64,
        normal_y: &str,
        f64: bool,
        threads: Option<usize>,
    ) -> PyResult<Bound<'py, PyAny>> {
        use texgraph::mesh::{GreenAxis, MeshBakeOptions, Space};
        let choice = |what: &str, given: &str, options: &[&str]| {
            PyValueError::new_err(format!("{what}={given:?}: give one of {options:?}"))
        };
        let (width, height) = match size.extract::<usize>() {
            Ok(w) => (w, w),
            Err(_) => size.extract::<(usize, usize)>()?,
        };
        if width == 0 || height == 0 {
            return Err(PyValueError::new_err("size: W and H must be positive"));
        }
        let filter = match filter {
            "point" => Filter::Point,
            "box" => Filter::Box,
            other => return Err(choice("filter", other, &["point", "box"])),
        };
        let space = match space {
            "object" => Space::Object,
            "world" => Space::World,
            other => return Err(choice("space", other, &["object", "world"])),
        };
        let green = match normal_y {
            "up" => GreenAxis::Up,
            "down" => GreenAxis::Down,
            other => return Err(choice("normal_y", other, &["up", "down"])),
        };
        let tape = self.tape(py, output, None)?;
        let gradient = match normal {
            Some(height) => {
                self.known_output(height)?;
                let options = CompileOptions::default();
                Some(
                    texgraph::mesh::gradient_tape(&self.graph, height, &options)
                        .map_err(PyValueError::new_err)?,
                )
            }
            None => None,
        };
        let held = texgraph::mesh::held_bytes(width, height, tape.channels(), gradient.is_some());
        if held > texgraph::bake::DEFAULT_MAX_HELD_BYTES {
            return Err(PyValueError::new_err(format!(
                "a {width}×{height} texture set would hold about {} in memory, more than 2 GiB",
                texgraph::bake::human_bytes(held)
            )));
        }
        let model = py
            .detach(|| texgraph::mesh::load_model(&path, space))
            .map_err(|e| match e.exit_code() {
                1 => PyValueError::new_err(e.to_string()),
                _ => pyo3::exceptions::PyOSError::new_err(e.to_string()),
            })?;
        let options = MeshBakeOptions {
            width,
            height,
            filter,
            padding,
            precision: if f64 { Precision::F64 } else { Precision::F32 },
            normal_strength,
            green,
        };
        let threads = texgraph::bake::capped_threads(threads.unwrap_or(0)).0;
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        let set = run::interruptible(py, true, |cancel| {
            pool.install(|| {
                texgraph::mesh::bake_texture_set(
                    &tape,
                    gradient.as_ref(),
                    &model,
                    &options,
                    Some(cancel),
                )
            })
        })?
        .map_err(|e| match e {
            BakeError::Cancelled => pyo3::exceptions::PyKeyboardInterrupt::new_err("bake stopped"),
            other => PyValueError::new_err(other.to_string()),
        })?;
        let d = PyDict::new(py);
        for image in set.images.into_iter().chain(set.normal) {
            let array = image.data.into_pyarray(py);
            let array = match image.ty.channels() {
                1 => array.reshape([height, width])?.into_any(),
                c => array.reshape([height, width, c])?.into_any(),
            };
            if output.is_some() && normal.is_none() {
                return Ok(array);
            }
            d.set_item(&image.name, array)?;
        }
        Ok(d.into_any())
    }

    /// Pickling (`multiprocessing`, `concurrent.futures`): the graph's text, file name and
    /// `set=` values, checked again on loading (imports resolve from the same file name).
    #[allow(clippy::type_complexity)]
    fn __reduce__<'py>(
        &self,
        py: Python<'py>,
    ) -> PyResult<(Bound<'py, PyAny>, (String, String, Vec<(String, f64)>))> {
        let restore = py.import("texgraph")?.getattr("_restore")?;
        let file = self.graph.file();
        Ok((
            restore,
            (file.text.clone(), file.name.clone(), self.sets.clone()),
        ))
    }

    fn __repr__(&self) -> String {
        let outputs: Vec<&str> = self
            .graph
            .outputs()
            .iter()
            .map(|o| o.name.as_str())
            .collect();
        format!(
            "<texgraph.Graph {:?} outputs=[{}]>",
            self.graph.file().name,
            outputs.join(", ")
        )
    }
}
