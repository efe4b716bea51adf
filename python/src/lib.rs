//! `texgraph` for Python (issue 34): graph files checked and compiled by the library, evaluated
//! and baked into NumPy arrays. A thin layer: every evaluation is the library's (`Tape::
//! eval_batch`, `bake::bake_volume`, `filter::Filtered`), so values are the command line's bit
//! for bit; this crate converts arguments, arrays and errors, and releases the GIL while the
//! library works (docs/python.md).

use pyo3::exceptions::{PyFileNotFoundError, PyOSError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use std::sync::Arc;
use texgraph::diagnostic::{Diagnostics, SourceFile};
use texgraph::LoadError;

mod arrays;
mod graph;
mod run;

use graph::Graph;

pyo3::create_exception!(
    texgraph,
    GraphError,
    PyValueError,
    "An invalid graph. `str()` is the command line's rendered diagnostic text; `.diagnostics` \
     lists each problem as a `Diagnostic` (file, line, column, node, cls, message)."
);

/// One problem with a graph, located as the command line prints it (1-based line and column).
#[pyclass(frozen, get_all, module = "texgraph")]
struct Diagnostic {
    /// The file the problem is in (an imported graph's own file for a problem inside it).
    file: String,
    /// 1-based line, `None` for a problem with no place in the file (an unknown `set=` name).
    line: Option<usize>,
    /// 1-based column (in characters), `None` with `line`.
    column: Option<usize>,
    /// The node id (or `outputs.NAME`, `params.NAME`) it belongs to, if any.
    node: Option<String>,
    /// Its class, as in `error[CLASS]` (`unknown-kind`, `syntax`, `type`, …).
    cls: String,
    /// The message (without the location).
    message: String,
}

#[pymethods]
impl Diagnostic {
    fn __repr__(&self) -> String {
        let at = match (self.line, self.column) {
            (Some(l), Some(c)) => format!("{}:{l}:{c}", self.file),
            _ => self.file.clone(),
        };
        format!("<Diagnostic {} at {at}: {}>", self.cls, self.message)
    }
}

/// A `GraphError` for invalid-graph diagnostics, an `OSError` (`FileNotFoundError`) for a file
/// that cannot be read.
pub(crate) fn load_error(py: Python<'_>, error: LoadError) -> PyErr {
    match error {
        LoadError::Io { path, source } => {
            let text = format!("{}: {source}", path.display());
            if source.kind() == std::io::ErrorKind::NotFound {
                PyFileNotFoundError::new_err(text)
            } else {
                PyOSError::new_err(text)
            }
        }
        LoadError::Invalid(diagnostics) => graph_error(py, &diagnostics),
    }
}

fn graph_error(py: Python<'_>, diagnostics: &Diagnostics) -> PyErr {
    let err = GraphError::new_err(diagnostics.render_plain());
    let list = PyList::empty(py);
    for d in &diagnostics.list {
        let (file, at) = diagnostics.location(d);
        let item = Diagnostic {
            file: file.name.clone(),
            line: at.map(|(l, _)| l),
            column: at.map(|(_, c)| c),
            node: d.node.clone(),
            cls: d.class.code().to_string(),
            message: d.message.clone(),
        };
        if let Ok(item) = Bound::new(py, item) {
            let _ = list.append(item);
        }
    }
    let _ = err.value(py).setattr("diagnostics", list);
    err
}

/// `set=`: a mapping of param names to numbers, in its own order.
pub(crate) fn parse_sets(set: Option<&Bound<'_, PyDict>>) -> PyResult<Vec<(String, f64)>> {
    let Some(set) = set else {
        return Ok(Vec::new());
    };
    set.iter()
        .map(|(k, v)| {
            let name: String = k
                .extract()
                .map_err(|_| PyValueError::new_err("set=: param names are strings"))?;
            let value: f64 = v.extract().map_err(|_| {
                PyValueError::new_err(format!("set=: the value of {name:?} is not a number"))
            })?;
            Ok((name, value))
        })
        .collect()
}

/// Reads and checks the graph file at `path` (imports resolved relative to it). `set` overrides
/// params, as `--set NAME=VALUE`: `set={"period": 2.5}`. Raises `GraphError` (a `ValueError`)
/// for an invalid graph, `FileNotFoundError` for a missing file, `KeyError` for a `set` name the
/// graph has no param for.
#[pyfunction]
#[pyo3(signature = (path, set=None))]
fn load(
    py: Python<'_>,
    path: std::path::PathBuf,
    set: Option<&Bound<'_, PyDict>>,
) -> PyResult<Graph> {
    let sets = parse_sets(set)?;
    let file = texgraph::read_source(&path).map_err(|e| load_error(py, e))?;
    Graph::check(py, file, sets)
}

/// Checks a graph given as RON text; `name` is the file name its diagnostics give. Imports are
/// resolved relative to the working folder.
#[pyfunction]
#[pyo3(signature = (text, name="<string>", set=None))]
fn loads(
    py: Python<'_>,
    text: String,
    name: &str,
    set: Option<&Bound<'_, PyDict>>,
) -> PyResult<Graph> {
    let sets = parse_sets(set)?;
    Graph::check(py, SourceFile::new(name, text), sets)
}

/// The node catalogue, from the table `texgraph nodes` prints: per kind a dict with `kind`,
/// `output` (its type), `doc` (one line) and `args`, a list of dicts with `name`, `type`,
/// `default` (as printed: `required`, `default 0.5`, …) and `doc`.
#[pyfunction]
fn nodes(py: Python<'_>) -> PyResult<Bound<'_, PyList>> {
    use texgraph::nodes::{describe_arg, describe_default, describe_output, CATALOGUE};
    let list = PyList::empty(py);
    for def in CATALOGUE {
        let args = PyList::empty(py);
        for arg in def.args {
            let a = PyDict::new(py);
            a.set_item("name", arg.name)?;
            a.set_item("type", describe_arg(arg))?;
            a.set_item("default", describe_default(arg.default))?;
            a.set_item("doc", arg.doc)?;
            args.append(a)?;
        }
        let d = PyDict::new(py);
        d.set_item("kind", def.name)?;
        d.set_item("output", describe_output(def.output))?;
        d.set_item("doc", def.doc)?;
        d.set_item("args", args)?;
        list.append(d)?;
    }
    Ok(list)
}

/// A pickled `Graph` loaded again: its text checked under its file name with its `set=` values.
#[pyfunction]
fn _restore(
    py: Python<'_>,
    text: String,
    name: String,
    sets: Vec<(String, f64)>,
) -> PyResult<Graph> {
    Graph::check(py, SourceFile::new(name, text), sets)
}

/// The extension module; `texgraph/__init__.py` re-exports it.
#[pymodule]
fn _texgraph(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(load, m)?)?;
    m.add_function(wrap_pyfunction!(loads, m)?)?;
    m.add_function(wrap_pyfunction!(nodes, m)?)?;
    m.add_function(wrap_pyfunction!(_restore, m)?)?;
    m.add_class::<Graph>()?;
    m.add_class::<Diagnostic>()?;
    m.add("GraphError", m.py().get_type::<GraphError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}

/// Shared, immutable source text of a graph (kept to check it again with other `set` values).
pub(crate) type Source = Arc<SourceFile>;
