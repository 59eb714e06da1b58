//! `wolfpack._core`: the thin pyo3 layer over `wolfpack-core`.
//!
//! Conversions, error mapping and GIL release only. Every core error becomes `ValueError` with
//! the core's one-line message; a panic (a bug) is caught at this border and becomes a
//! `RuntimeError` — it never unwinds into Python.

use std::panic::{catch_unwind, AssertUnwindSafe};

use numpy::{PyArray1, PyArrayMethods};
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use pythonize::{pythonize, Depythonizer};
use wolfpack_core::episode::{run_episodes as core_run_episodes, EpisodeResult, Trajectory};
use wolfpack_core::world::{Layout, World};
use wolfpack_core::{Error, Params};

fn value_error(e: Error) -> PyErr {
    PyValueError::new_err(e.to_string())
}

/// Runs `f`, turning a panic into a `RuntimeError` naming it as an internal error.
fn guarded<T>(f: impl FnOnce() -> T) -> PyResult<T> {
    catch_unwind(AssertUnwindSafe(f)).map_err(|payload| {
        let msg = payload
            .downcast_ref::<String>()
            .cloned()
            .or_else(|| payload.downcast_ref::<&str>().map(|s| s.to_string()))
            .unwrap_or_else(|| "unknown panic".into());
        PyRuntimeError::new_err(format!("internal error in wolfpack core (please report): {msg}"))
    })
}

fn params_from(obj: &Bound<'_, PyAny>) -> PyResult<Params> {
    if obj.is_none() {
        return Ok(Params::default());
    }
    if !obj.is_instance_of::<PyDict>() {
        return Err(PyValueError::new_err(format!("params must be a dict, got {}", obj.get_type().name()?)));
    }
    let mut de = Depythonizer::from_object(obj);
    Params::from_deserializer(&mut de).map_err(value_error)
}

fn layout_from(obj: &Bound<'_, PyAny>) -> PyResult<Option<Layout>> {
    if obj.is_none() {
        return Ok(None);
    }
    if !obj.is_instance_of::<PyDict>() {
        return Err(PyValueError::new_err(format!("layout must be a dict, got {}", obj.get_type().name()?)));
    }
    let mut de = Depythonizer::from_object(obj);
    serde_path_to_error::deserialize(&mut de).map(Some).map_err(|e| {
        let path = e.path().to_string();
        PyValueError::new_err(format!("layout: {path}: {}", e.into_inner()))
    })
}

fn params_to_py<'py>(py: Python<'py>, p: &Params) -> PyResult<Bound<'py, PyAny>> {
    pythonize(py, &p.resolved()).map_err(|e| PyRuntimeError::new_err(e.to_string()))
}

/// The documented scenario's parameters as a dict (`capture.count` resolved).
#[pyfunction]
fn default_params(py: Python<'_>) -> PyResult<Bound<'_, PyAny>> {
    params_to_py(py, &Params::default())
}

/// Validates a params dict; returns the complete, resolved dict. Raises ValueError naming the
/// offending key.
#[pyfunction]
fn validate_params<'py>(py: Python<'py>, params: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyAny>> {
    let p = params_from(params)?;
    params_to_py(py, &p)
}

/// Checks a layout against params by building the world it describes; returns the resolved
/// params the layout implies (agent counts taken from the layout).
#[pyfunction]
#[pyo3(signature = (params, layout, seed=0))]
fn check_layout<'py>(py: Python<'py>, params: &Bound<'py, PyAny>, layout: &Bound<'py, PyAny>, seed: u64) -> PyResult<Bound<'py, PyAny>> {
    let p = std::sync::Arc::new(params_from(params)?);
    let l = layout_from(layout)?.ok_or_else(|| PyValueError::new_err("layout: must be a dict, got None"))?;
    let w = guarded(|| World::from_layout(p, seed, &l))?.map_err(value_error)?;
    params_to_py(py, &w.params)
}

fn array<'py, T: numpy::Element>(py: Python<'py>, data: Vec<T>, shape: &[usize]) -> PyResult<Bound<'py, PyAny>> {
    Ok(PyArray1::from_vec(py, data).reshape(shape)?.into_any())
}

fn trajectory_to_py<'py>(py: Python<'py>, t: Trajectory, n: usize, m: usize) -> PyResult<Bound<'py, PyDict>> {
    let rows = t.energy.len() / (n + m);
    let k = t.obstacle_shapes.len();
    let d = PyDict::new(py);
    d.set_item("wolves", array(py, t.wolves, &[rows, n, 5])?)?;
    d.set_item("targets", array(py, t.targets, &[rows, m, 5])?)?;
    d.set_item("energy", array(py, t.energy, &[rows, n + m])?)?;
    d.set_item("interaction", array(py, t.interaction, &[rows - 1, n + m, n + m])?)?;
    d.set_item("obstacle_poses", array(py, t.obstacles, &[rows, k, 3])?)?;
    let shapes = PyList::empty(py);
    for s in t.obstacle_shapes {
        let o = PyDict::new(py);
        o.set_item("kind", s.kind)?;
        o.set_item("radius", s.radius)?;
        o.set_item("vertices", s.local)?;
        shapes.append(o)?;
    }
    d.set_item("obstacle_shapes", shapes)?;
    Ok(d)
}

fn result_to_py<'py>(py: Python<'py>, r: EpisodeResult) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("seed", r.seed)?;
    d.set_item("outcome", r.outcome.as_str())?;
    d.set_item("steps", r.steps)?;
    d.set_item("capture_step", r.capture_step)?;
    d.set_item("wolves", r.wolves)?;
    d.set_item("targets", r.targets)?;
    d.set_item("energy", PyArray1::from_vec(py, r.energy))?;
    d.set_item("collisions", PyArray1::from_vec(py, r.collisions))?;
    if let Some(t) = r.trajectory {
        d.set_item("trajectory", trajectory_to_py(py, t, r.wolves, r.targets)?)?;
    }
    Ok(d)
}

/// Runs scripted episodes `first .. first+count` with seeds `seed + k`, in parallel on
/// `threads` threads (None: all cores) with the GIL released. Results (in episode order) do not
/// depend on `threads`. Each result is a dict: seed, outcome, steps, capture_step, wolves,
/// targets, energy [N+M], collisions [N+M], and with `record` a `trajectory` dict of arrays
/// (wolves [T+1,N,5], targets [T+1,M,5], energy [T+1,N+M], interaction uint8 [T,N+M,N+M],
/// obstacle_poses [T+1,K,3], obstacle_shapes list).
#[pyfunction]
#[pyo3(signature = (params, seed, first=0, count=1, layout=None, record=false, threads=None))]
#[allow(clippy::too_many_arguments)]
fn run_episodes<'py>(
    py: Python<'py>,
    params: &Bound<'py, PyAny>,
    seed: u64,
    first: u64,
    count: u64,
    layout: Option<&Bound<'py, PyAny>>,
    record: bool,
    threads: Option<usize>,
) -> PyResult<Bound<'py, PyList>> {
    let p = params_from(params)?;
    let l = match layout {
        Some(obj) => layout_from(obj)?,
        None => None,
    };
    if threads == Some(0) {
        return Err(PyValueError::new_err("threads must be >= 1"));
    }
    let results = py.detach(|| guarded(|| core_run_episodes(&p, seed, first, count, l.as_ref(), record, threads)))?.map_err(value_error)?;
    let out = PyList::empty(py);
    for r in results {
        out.append(result_to_py(py, r)?)?;
    }
    Ok(out)
}

#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    // Panics are caught at the border and reported as RuntimeError; keep their default
    // "thread panicked at" text off the user's terminal.
    std::panic::set_hook(Box::new(|_| {}));
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_function(wrap_pyfunction!(default_params, m)?)?;
    m.add_function(wrap_pyfunction!(validate_params, m)?)?;
    m.add_function(wrap_pyfunction!(check_layout, m)?)?;
    m.add_function(wrap_pyfunction!(run_episodes, m)?)?;
    Ok(())
}
