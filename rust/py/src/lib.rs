//! `wolfpack._core`: the thin pyo3 layer over `wolfpack-core`.
//!
//! Conversions, error mapping and GIL release only. Every core error becomes `ValueError` with
//! the core's one-line message; a panic (a bug) is caught at this border and becomes a
//! `RuntimeError` — it never unwinds into Python.

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{channel, RecvTimeoutError};
use std::time::Duration;

use numpy::ndarray::{Array, IxDyn};
use numpy::{IntoPyArray, PyArray1, PyArray3, PyArrayDyn, PyArrayMethods, PyReadonlyArray3, PyReadwriteArrayDyn, PyUntypedArrayMethods};
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::intern;
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};
use pythonize::pythonize;
use wolfpack_core::batch::{BatchEnv, Learners, OutputSpec, StepBuffers, StepOutput};
use wolfpack_core::episode::{run_episodes_until, EpisodeResult, Trajectory};
use wolfpack_core::render::{render, Scene};
use wolfpack_core::world::{Layout, World};
use wolfpack_core::{Error, Params};

/// The extension's Rust allocations (the worlds, their obstacles and vertex lists, the step's
/// outputs) come from mimalloc, not glibc's malloc. Measured: a batch of 8,192 worlds (≈ 94 MB
/// of state, far beyond the caches) steps several per cent faster; smaller batches and the
/// scripted hunt are unchanged (BENCHMARKS.md, "Optimisations"). Most likely its
/// size-segregated pages without per-block headers pack a batch's ≈ 54 small allocations per
/// world more densely than glibc does. Python's own objects keep Python's allocator; numpy
/// arrays made from Rust vectors are freed by Rust. `local_dynamic_tls`: Python loads this
/// library with dlopen, after libraries such as torch that use up the static TLS block, where
/// mimalloc's default initial-exec TLS can fail to load ("cannot allocate memory in static TLS
/// block"); tests/test_build.py checks the library needs no static TLS and imports it after
/// torch.
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn value_error(e: Error) -> PyErr {
    PyValueError::new_err(e.to_string())
}

/// Runs `f`, turning a panic into a `RuntimeError` naming it as an internal error.
fn guarded<T>(f: impl FnOnce() -> T) -> PyResult<T> {
    catch_unwind(AssertUnwindSafe(f)).map_err(|payload| {
        let msg = payload.downcast_ref::<String>().cloned().or_else(|| payload.downcast_ref::<&str>().map(|s| s.to_string())).unwrap_or_else(|| "unknown panic".into());
        PyRuntimeError::new_err(format!("internal error in wolfpack core (please report): {msg}"))
    })
}

/// How often a long native call looks for a pending signal (Ctrl-C) while it runs.
const SIGNAL_POLL: Duration = Duration::from_millis(50);

/// Runs `work` on a helper thread with the GIL released while this thread looks for pending
/// signals every [`SIGNAL_POLL`]. On one (Ctrl-C), `stop` is set — the work checks it every
/// step and returns within a step — and the signal's exception (KeyboardInterrupt) is raised.
/// Python's signal handlers only run on the main thread with the GIL, so a native loop that
/// never returns to Python would otherwise ignore Ctrl-C until it ends.
fn interruptible<T: Send>(py: Python<'_>, stop: &AtomicBool, work: impl FnOnce() -> PyResult<T> + Send) -> PyResult<T> {
    py.detach(|| {
        std::thread::scope(|scope| {
            let (tx, rx) = channel();
            scope.spawn(move || {
                let _ = tx.send(work());
            });
            loop {
                match rx.recv_timeout(SIGNAL_POLL) {
                    Ok(result) => return result,
                    Err(RecvTimeoutError::Timeout) => {
                        if let Err(signal) = Python::attach(|py| py.check_signals()) {
                            stop.store(true, Ordering::Relaxed);
                            let _ = rx.recv(); // the work ends within a step
                            return Err(signal);
                        }
                    }
                    Err(RecvTimeoutError::Disconnected) => return Err(PyRuntimeError::new_err("internal error in wolfpack core (please report): the worker thread ended without a result")),
                }
            }
        })
    })
}

/// Deepest nesting a params or layout tree may have (the real ones are 3 levels deep); deeper
/// input is refused before anything recurses over it.
const MAX_DEPTH: usize = 32;

/// Most values (leaves and containers) a params or layout tree may hold.
const MAX_NODES: usize = 1_000_000;

fn params_from(obj: &Bound<'_, PyAny>) -> PyResult<Params> {
    if obj.is_none() {
        return Ok(Params::default());
    }
    if !obj.is_instance_of::<PyDict>() {
        return Err(PyValueError::new_err(format!("params must be a dict, got {}", obj.get_type().name()?)));
    }
    Params::from_deserializer(plain_value(obj)?).map_err(value_error)
}

/// A Python value tree as plain JSON-like data, so that serde sees Python's own types (a
/// `bool` is not an integer here, as it would be through a generic converter). Values JSON
/// cannot hold are rejected with their key path: integers beyond 64 bits, NaN and ±inf.
fn plain_value(obj: &Bound<'_, PyAny>) -> PyResult<serde_json::Value> {
    to_plain(obj, &mut String::new(), 0, &mut { MAX_NODES })
}

fn to_plain(obj: &Bound<'_, PyAny>, path: &mut String, depth: usize, budget: &mut usize) -> PyResult<serde_json::Value> {
    use serde_json::Value;
    let at = |path: &str| if path.is_empty() { "params".to_string() } else { path.to_string() };
    if depth > MAX_DEPTH {
        return Err(PyValueError::new_err(format!("{}: nested deeper than {MAX_DEPTH} levels", at(path))));
    }
    // Shared objects (YAML aliases) are expanded here, so count every visit: a "billion laughs"
    // tree is refused after a million values instead of exhausting memory.
    if *budget == 0 {
        return Err(PyValueError::new_err(format!("{}: more than {MAX_NODES} values in all", at(path))));
    }
    *budget -= 1;
    if obj.is_none() {
        Ok(Value::Null)
    } else if let Ok(b) = obj.cast::<PyBool>() {
        Ok(Value::Bool(b.is_true()))
    } else if obj.is_instance_of::<PyInt>() {
        if let Ok(i) = obj.extract::<i64>() {
            Ok(Value::from(i))
        } else if let Ok(u) = obj.extract::<u64>() {
            Ok(Value::from(u))
        } else {
            Err(PyValueError::new_err(format!("{}: integer {} is out of range", at(path), obj.str()?)))
        }
    } else if let Ok(f) = obj.cast::<PyFloat>() {
        let x = f.value();
        serde_json::Number::from_f64(x).map(Value::Number).ok_or_else(|| PyValueError::new_err(format!("{}: must be finite, got {x}", at(path))))
    } else if let Ok(s) = obj.cast::<PyString>() {
        Ok(Value::String(s.to_str()?.to_owned()))
    } else if let Ok(d) = obj.cast::<PyDict>() {
        let mut map = serde_json::Map::new();
        for (k, v) in d.iter() {
            let key: String = k.extract().map_err(|_| PyValueError::new_err(format!("{}: keys must be strings, got {}", at(path), k.repr().map(|r| r.to_string()).unwrap_or_default())))?;
            let len = path.len();
            if !path.is_empty() {
                path.push('.');
            }
            path.push_str(&key);
            let value = to_plain(&v, path, depth + 1, budget)?;
            path.truncate(len);
            map.insert(key, value);
        }
        Ok(Value::Object(map))
    } else if obj.is_instance_of::<PyList>() || obj.is_instance_of::<PyTuple>() {
        let mut items = Vec::new();
        for (i, v) in obj.try_iter()?.enumerate() {
            let len = path.len();
            path.push_str(&format!("[{i}]"));
            items.push(to_plain(&v?, path, depth + 1, budget)?);
            path.truncate(len);
        }
        Ok(Value::Array(items))
    } else if let Ok(i) = obj.extract::<i64>() {
        // numpy integer scalars (they implement __index__).
        Ok(Value::from(i))
    } else if let Ok(x) = obj.extract::<f64>() {
        // Other number-likes.
        serde_json::Number::from_f64(x).map(Value::Number).ok_or_else(|| PyValueError::new_err(format!("{}: must be finite, got {x}", at(path))))
    } else {
        Err(PyValueError::new_err(format!("{}: unsupported value of type {}", at(path), obj.get_type().name()?)))
    }
}

fn layout_from(obj: &Bound<'_, PyAny>) -> PyResult<Option<Layout>> {
    if obj.is_none() {
        return Ok(None);
    }
    if !obj.is_instance_of::<PyDict>() {
        return Err(PyValueError::new_err(format!("layout must be a dict, got {}", obj.get_type().name()?)));
    }
    let py = obj.py();
    let tree = plain_value(obj).map_err(|e| PyValueError::new_err(format!("layout: {}", e.value(py))))?;
    serde_path_to_error::deserialize(tree).map(Some).map_err(|e| {
        let path = e.path().to_string();
        PyValueError::new_err(format!("layout: {path}: {}", wolfpack_core::config::plain_words("", &e.into_inner().to_string())))
    })
}

fn params_to_py<'py>(py: Python<'py>, p: &Params) -> PyResult<Bound<'py, PyAny>> {
    pythonize(py, p).map_err(|e| PyRuntimeError::new_err(e.to_string()))
}

/// The documented scenario's parameters as a dict (`capture.count` null: derived as ⌈0.8 N⌉).
#[pyfunction]
fn default_params(py: Python<'_>) -> PyResult<Bound<'_, PyAny>> {
    params_to_py(py, &Params::default())
}

/// Validates a params dict; returns it complete (every key, defaults filled in). With
/// `resolve`, derived values are filled in too (`capture.count`), as tools show them; without,
/// a derived value stays null so that it follows later changes of the agent counts (layouts).
/// Raises ValueError naming the offending key.
#[pyfunction]
#[pyo3(signature = (params, resolve=false))]
fn validate_params<'py>(py: Python<'py>, params: &Bound<'py, PyAny>, resolve: bool) -> PyResult<Bound<'py, PyAny>> {
    let p = params_from(params)?;
    params_to_py(py, &if resolve { p.resolved() } else { p })
}

/// The documented range of every numeric parameter (`wolfpack_core::limits::LIMITS`): a list of
/// dicts `{key, lo, hi, open_lo, unit}`; `key` is dotted, array elements share their array's key,
/// and a table key (`avoidance.wolf_single`) covers each of its fields.
#[pyfunction]
fn param_limits(py: Python<'_>) -> PyResult<Bound<'_, PyList>> {
    let out = PyList::empty(py);
    for l in wolfpack_core::limits::LIMITS {
        let d = PyDict::new(py);
        d.set_item("key", l.key)?;
        d.set_item("lo", l.lo)?;
        d.set_item("hi", l.hi)?;
        d.set_item("open_lo", l.open_lo)?;
        d.set_item("unit", l.unit)?;
        out.append(d)?;
    }
    Ok(out)
}

/// The blocks of `side`'s observation ("wolves" or "targets") under `params`, in order:
/// a list of dicts `{name, start, size}` that tile the observation (`wolfpack_core::observe::layout`);
/// an entity layout's row blocks add `rows` and `row_size`.
#[pyfunction]
fn observation_layout<'py>(py: Python<'py>, params: &Bound<'py, PyAny>, side: &str) -> PyResult<Bound<'py, PyList>> {
    let p = params_from(params)?;
    let blocks = wolfpack_core::observe::layout(&p, side).ok_or_else(|| PyValueError::new_err(format!("side must be 'wolves' or 'targets', got {side:?}")))?;
    let out = PyList::empty(py);
    for b in blocks {
        let d = PyDict::new(py);
        d.set_item("name", b.name)?;
        d.set_item("start", b.start)?;
        d.set_item("size", b.len)?;
        if b.rows > 0 {
            d.set_item("rows", b.rows)?;
            d.set_item("row_size", wolfpack_core::observe::ENTITY_ROW)?;
        }
        out.append(d)?;
    }
    Ok(out)
}

/// Checks a layout against params by building the world it describes; returns the resolved
/// params the layout implies (agent counts taken from the layout).
#[pyfunction]
#[pyo3(signature = (params, layout, seed=0))]
fn check_layout<'py>(py: Python<'py>, params: &Bound<'py, PyAny>, layout: &Bound<'py, PyAny>, seed: u64) -> PyResult<Bound<'py, PyAny>> {
    let p = std::sync::Arc::new(params_from(params)?);
    let l = layout_from(layout)?.ok_or_else(|| PyValueError::new_err("layout: must be a dict, got None"))?;
    let w = guarded(|| World::from_layout(p, seed, &l))?.map_err(value_error)?;
    params_to_py(py, &w.params.resolved())
}

/// `data` as a numpy array of `shape`, built with that shape (no reshape, so one array object
/// instead of two; the data is moved, not copied). C-contiguous and writeable.
fn array<'py, T: numpy::Element>(py: Python<'py>, data: Vec<T>, shape: &[usize]) -> PyResult<Bound<'py, PyAny>> {
    let bad = |e: numpy::ndarray::ShapeError| PyRuntimeError::new_err(format!("internal error in wolfpack core (please report): {e}"));
    // Fixed dimensions where they fit: a dynamic one allocates its shape and strides.
    Ok(match *shape {
        [a] if a == data.len() => PyArray1::from_vec(py, data).into_any(),
        [a, b] => Array::from_shape_vec((a, b), data).map_err(bad)?.into_pyarray(py).into_any(),
        [a, b, c] => Array::from_shape_vec((a, b, c), data).map_err(bad)?.into_pyarray(py).into_any(),
        _ => Array::from_shape_vec(IxDyn(shape), data).map_err(bad)?.into_pyarray(py).into_any(),
    })
}

fn trajectory_to_py<'py>(py: Python<'py>, t: Trajectory, n: usize, m: usize) -> PyResult<Bound<'py, PyDict>> {
    let rows = t.energy.len() / (n + m);
    let k = t.obstacle_shapes.len();
    let d = PyDict::new(py);
    d.set_item("wolves", array(py, t.wolves, &[rows, n, 5])?)?;
    d.set_item("targets", array(py, t.targets, &[rows, m, 5])?)?;
    d.set_item("energy", array(py, t.energy, &[rows, n + m])?)?;
    d.set_item("interaction", array(py, t.interaction, &[rows - 1, n + m, n + m])?)?;
    d.set_item("wolf_mode", array(py, t.wolf_modes, &[rows, n])?)?;
    d.set_item("target_mode", array(py, t.target_modes, &[rows, m])?)?;
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
    d.set_item("target_capture_steps", r.target_capture_steps)?;
    d.set_item("cornered_step", r.cornered_step)?;
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
/// depend on `threads`. Each result is a dict: seed, outcome, steps, capture_step,
/// target_capture_steps [M] (each target's capture step or None), cornered_step (first step a
/// target was cornered, or None), wolves,
/// targets, energy [N+M], collisions [N+M], and with `record` a `trajectory` dict of arrays
/// (wolves [T+1,N,5], targets [T+1,M,5], energy [T+1,N+M], interaction uint8 [T,N+M,N+M],
/// wolf_mode uint8 [T+1,N] and target_mode uint8 [T+1,M] (each law's mode in the step that led
/// to the state, codes into `LAW_MODES`; row 0 is 0), obstacle_poses [T+1,K,3], obstacle_shapes
/// list).
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
    let stop = AtomicBool::new(false);
    let results = interruptible(py, &stop, || guarded(|| run_episodes_until(&p, seed, first, count, l.as_ref(), record, threads, &stop))?.map_err(value_error))?;
    let out = PyList::empty(py);
    for r in results {
        out.append(result_to_py(py, r)?)?;
    }
    Ok(out)
}

/// `shape` as Python writes a tuple: `(4, 3, 2)`, `(4,)`.
fn py_shape(shape: &[usize]) -> String {
    match shape {
        [a] => format!("({a},)"),
        _ => format!("({})", shape.iter().map(usize::to_string).collect::<Vec<_>>().join(", ")),
    }
}

/// The actions of one side ("wolf" or "target") for a batch step: None where the side gives
/// none. A float32 C-contiguous array of `shape` is used as it is; any other floating array
/// (or nested list) is converted by numpy; a missing or unexpected side, an integer dtype or a
/// wrong shape is a ValueError in the words of `wolfpack.BatchEnv.step`.
fn actions_from<'py>(py: Python<'py>, obj: Option<&Bound<'py, PyAny>>, side: &str, learns: bool, shape: [usize; 3]) -> PyResult<Option<PyReadonlyArray3<'py, f32>>> {
    let plural = if side == "wolf" { "wolves" } else { "targets" };
    let Some(obj) = obj.filter(|o| !o.is_none()) else {
        return if learns { Err(PyValueError::new_err(format!("{side} actions are required: {plural} are learners here"))) } else { Ok(None) };
    };
    if !learns {
        return Err(PyValueError::new_err(format!("{side} actions given, but the {plural} are not learners here")));
    }
    if let Ok(a) = obj.cast::<PyArray3<f32>>() {
        if a.shape() == shape && a.is_c_contiguous() {
            if let Ok(r) = a.try_readonly() {
                return Ok(Some(r));
            }
        }
    }
    let np = py.import(intern!(py, "numpy"))?;
    let a = np.call_method1(intern!(py, "asarray"), (obj,))?;
    let dtype = a.getattr(intern!(py, "dtype"))?;
    if dtype.getattr(intern!(py, "kind"))?.extract::<String>()? != "f" {
        return Err(PyValueError::new_err(format!("{side} actions: actions must be floating point, got dtype {}", dtype.str()?)));
    }
    let got: Vec<usize> = a.getattr(intern!(py, "shape"))?.extract()?;
    if got != shape {
        return Err(PyValueError::new_err(format!("{side} actions: expected shape {}, got {}", py_shape(&shape), py_shape(&got))));
    }
    let kwargs = PyDict::new(py);
    kwargs.set_item(intern!(py, "dtype"), np.getattr(intern!(py, "float32"))?)?;
    let a = np.call_method(intern!(py, "ascontiguousarray"), (a,), Some(&kwargs))?;
    Ok(Some(a.cast_into::<PyArray3<f32>>()?.try_readonly()?))
}

fn slice_of<'a>(a: &'a Option<PyReadonlyArray3<'_, f32>>) -> PyResult<&'a [f32]> {
    match a {
        Some(a) => a.as_slice().map_err(|e| PyValueError::new_err(e.to_string())),
        None => Ok(&[]),
    }
}

/// One side's actions or observations, or None where that side has none.
type SideArray<'py> = Option<Bound<'py, PyAny>>;

/// Declares, from the core's one list of the output arrays (`wolfpack_core::for_each_output!`),
/// the two places where the binding meets them one by one: `output_to_py` (a fresh reset's or
/// step's dict) and `OutViews` (the caller's `out=` arrays, checked and borrowed).
macro_rules! binding_outputs {
    ($($(#[$doc:meta])* $name:ident: $t:ty,)*) => {
        /// `o`'s arrays as a dict of numpy arrays, keyed, shaped and typed as
        /// `BatchEnv::output_specs` says (an array the batch does not write is left out); the
        /// vectors are moved into numpy, not copied. The one place that builds a reset's or
        /// step's dict.
        fn output_to_py<'py>(py: Python<'py>, env: &BatchEnv, o: StepOutput) -> PyResult<Bound<'py, PyDict>> {
            let d = PyDict::new(py);
            let mut specs = env.output_specs().into_iter();
            $(
                let spec = specs.next().expect("one spec per output");
                if !spec.is_empty() {
                    // Interned once for the life of the module, not once per step.
                    d.set_item(intern!(py, stringify!($name)), array(py, o.$name, spec.shape())?)?;
                }
            )*
            Ok(d)
        }

        /// The caller's output arrays, checked and borrowed for one reset or step (None where
        /// the batch writes nothing).
        struct OutViews<'py> {
            $($name: Option<PyReadwriteArrayDyn<'py, $t>>,)*
        }

        impl<'py> OutViews<'py> {
            fn new(out: &Bound<'py, PyDict>, env: &BatchEnv) -> PyResult<Self> {
                let py = out.py();
                let mut specs = env.output_specs().into_iter();
                // Struct fields are evaluated in the order written: the core's order.
                Ok(Self { $($name: out_view::<$t>(out, intern!(py, stringify!($name)), &specs.next().expect("one spec per output"))?,)* })
            }

            /// The arrays as the core writes them.
            fn buffers(&mut self) -> PyResult<StepBuffers<'_>> {
                fn slice<'a, T: numpy::Element>(v: &'a mut Option<PyReadwriteArrayDyn<'_, T>>) -> PyResult<&'a mut [T]> {
                    match v {
                        Some(a) => a.as_slice_mut().map_err(|e| PyValueError::new_err(e.to_string())),
                        None => Ok(&mut []),
                    }
                }
                Ok(StepBuffers { $($name: slice(&mut self.$name)?,)* })
            }
        }
    };
}

wolfpack_core::for_each_output!(binding_outputs);

/// The writeable view of output `spec` (key `key`) in `out` (None where the batch writes nothing
/// there): a C-contiguous array of exactly its dtype and shape, or a ValueError naming the key.
fn out_view<'py, T: numpy::Element>(out: &Bound<'py, PyDict>, key: &Bound<'py, PyString>, spec: &OutputSpec) -> PyResult<Option<PyReadwriteArrayDyn<'py, T>>> {
    if spec.is_empty() {
        return Ok(None);
    }
    let py = out.py();
    let bad = |got: String| {
        let dtype = numpy::dtype::<T>(py).str().map(|s| s.to_string()).unwrap_or_default();
        PyValueError::new_err(format!("out['{}']: expected a writeable, C-contiguous {dtype} array of shape {} (BatchEnv.new_outputs() makes them), got {got}", spec.name, py_shape(spec.shape())))
    };
    let Some(obj) = out.get_item(key)? else { return Err(bad("no such key".into())) };
    let Ok(a) = obj.cast::<PyArrayDyn<T>>() else {
        let what = obj.getattr("dtype").and_then(|d| d.str()).map(|d| format!("an array of dtype {d}")).unwrap_or_else(|_| obj.get_type().name().map(|n| n.to_string()).unwrap_or_default());
        return Err(bad(what));
    };
    if a.shape() != spec.shape() {
        return Err(bad(format!("shape {}", py_shape(a.shape()))));
    }
    if !a.is_c_contiguous() {
        return Err(bad("a non-contiguous array".into()));
    }
    a.try_readwrite().map(Some).map_err(|_| bad("a read-only array, or one given for two keys".into()))
}

/// The native batch: `num_envs` worlds stepped together on a thread pool with the GIL
/// released. See `wolfpack.BatchEnv` for the documented Python face; this class is private.
#[pyclass(module = "wolfpack._core", name = "BatchEnv")]
struct PyBatchEnv {
    inner: BatchEnv,
}

/// One env takes one call at a time (its calls release the GIL while the worlds step): a call
/// made while another thread is inside one gets this error instead of pyo3's "Already borrowed".
const BUSY: &str = "this env is in use by another thread right now (a step, reset or read is under way there): \
                    one env takes one call at a time; give each thread its own env, or hold a lock around its calls";

fn exclusive<'py>(slf: &Bound<'py, PyBatchEnv>) -> PyResult<PyRefMut<'py, PyBatchEnv>> {
    slf.try_borrow_mut().map_err(|_| PyRuntimeError::new_err(BUSY))
}

fn shared<'py>(slf: &Bound<'py, PyBatchEnv>) -> PyResult<PyRef<'py, PyBatchEnv>> {
    slf.try_borrow().map_err(|_| PyRuntimeError::new_err(BUSY))
}

#[pymethods]
impl PyBatchEnv {
    #[new]
    #[pyo3(signature = (params=None, num_envs=1, learners="wolves", seed=0, autoreset=true, threads=None, with_state=false))]
    #[allow(clippy::too_many_arguments)]
    fn new(py: Python<'_>, params: Option<&Bound<'_, PyAny>>, num_envs: usize, learners: &str, seed: u64, autoreset: bool, threads: Option<usize>, with_state: bool) -> PyResult<Self> {
        let p = match params {
            Some(obj) => params_from(obj)?,
            None => Params::default(),
        };
        let l = Learners::parse(learners).map_err(value_error)?;
        let stop = AtomicBool::new(false);
        let mut inner = interruptible(py, &stop, || guarded(|| BatchEnv::new_until(p, num_envs, l, seed, autoreset, threads, &stop))?.map_err(value_error))?;
        inner.set_with_state(with_state);
        Ok(Self { inner })
    }

    #[getter]
    fn num_envs(slf: &Bound<'_, Self>) -> PyResult<usize> {
        let this = shared(slf)?;
        Ok(this.inner.num_envs())
    }
    #[getter]
    fn n_wolves(slf: &Bound<'_, Self>) -> PyResult<usize> {
        let this = shared(slf)?;
        Ok(this.inner.n_wolves())
    }
    #[getter]
    fn n_targets(slf: &Bound<'_, Self>) -> PyResult<usize> {
        let this = shared(slf)?;
        Ok(this.inner.n_targets())
    }
    #[getter]
    fn wolf_obs_dim(slf: &Bound<'_, Self>) -> PyResult<usize> {
        let this = shared(slf)?;
        Ok(this.inner.wolf_obs_dim())
    }
    #[getter]
    fn target_obs_dim(slf: &Bound<'_, Self>) -> PyResult<usize> {
        let this = shared(slf)?;
        Ok(this.inner.target_obs_dim())
    }
    /// The params in force, complete and resolved (`capture.count` filled in).
    #[getter]
    fn params<'py>(slf: &Bound<'py, Self>, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let this = shared(slf)?;
        params_to_py(py, &this.inner.params().resolved())
    }

    /// A dict of zeroed output arrays of this batch's shapes: the arrays `step(out=...)`
    /// writes into (keys, shapes and dtypes as `step` returns them).
    fn new_outputs<'py>(slf: &Bound<'py, Self>, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let this = shared(slf)?;
        output_to_py(py, &this.inner, this.inner.new_outputs())
    }

    /// Resets every world (world i seeded `seed + i` when a seed is given, else its next
    /// episode). Returns a new output dict with observations and infos.
    #[pyo3(signature = (seed=None))]
    fn reset<'py>(slf: &Bound<'py, Self>, py: Python<'py>, seed: Option<u64>) -> PyResult<Bound<'py, PyDict>> {
        let mut this = exclusive(slf)?;
        let env = &mut this.inner;
        let stop = AtomicBool::new(false);
        let out = interruptible(py, &stop, || guarded(|| env.reset_until(seed, &stop))?.map_err(value_error))?;
        output_to_py(py, &this.inner, out)
    }

    /// Resets world `index` alone, optionally seeded and from a LAYOUT dict. Returns a new
    /// output dict of every world's current observations and infos.
    #[pyo3(signature = (index, seed=None, layout=None))]
    fn reset_world<'py>(slf: &Bound<'py, Self>, py: Python<'py>, index: usize, seed: Option<u64>, layout: Option<&Bound<'py, PyAny>>) -> PyResult<Bound<'py, PyDict>> {
        let mut this = exclusive(slf)?;
        let l = match layout {
            Some(obj) => layout_from(obj)?,
            None => None,
        };
        let env = &mut this.inner;
        let out = py.detach(|| guarded(|| env.reset_world(index, seed, l.as_ref())))?.map_err(value_error)?;
        output_to_py(py, &this.inner, out)
    }

    /// The one step call. `wolf_actions` [E, N, 2] and `target_actions` [E, M, 2], given for
    /// (and only for) the learning sides (float32 C-contiguous arrays are used as they are;
    /// other floating arrays are converted). The outputs are written into `out` (a dict from
    /// `new_outputs()`, every element written) and `out` is returned; without it, into a new
    /// dict. Nothing moves, and `out` is untouched, when the actions or `out` are wrong.
    #[pyo3(signature = (wolf_actions=None, target_actions=None, out=None))]
    fn step<'py>(
        slf: &Bound<'py, Self>,
        py: Python<'py>,
        wolf_actions: Option<&Bound<'py, PyAny>>,
        target_actions: Option<&Bound<'py, PyAny>>,
        out: Option<Bound<'py, PyDict>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let mut this = exclusive(slf)?;
        let (e, l) = (this.inner.num_envs(), this.inner.learners());
        let wa = actions_from(py, wolf_actions, "wolf", l.wolves(), [e, this.inner.n_wolves(), 2])?;
        let ta = actions_from(py, target_actions, "target", l.targets(), [e, this.inner.n_targets(), 2])?;
        let (ws, ts) = (slice_of(&wa)?, slice_of(&ta)?);
        let Some(out) = out else {
            let env = &mut this.inner;
            let o = py.detach(|| guarded(|| env.step(ws, ts)))?.map_err(value_error)?;
            return output_to_py(py, &this.inner, o);
        };
        let mut views = OutViews::new(&out, &this.inner)?;
        let mut bufs = views.buffers()?;
        let env = &mut this.inner;
        py.detach(|| guarded(|| env.step_into(ws, ts, &mut bufs)))?.map_err(value_error)?;
        Ok(out)
    }

    /// The current observations and infos of every world, as a reset would return them (no
    /// rewards; nothing moves): for a side that just became driven (`set_drivers`).
    fn observe<'py>(slf: &Bound<'py, Self>, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let mut this = exclusive(slf)?;
        let env = &mut this.inner;
        let out = py.detach(|| guarded(|| env.observe_all()))?.map_err(value_error)?;
        output_to_py(py, &this.inner, out)
    }

    /// Who drives each side from the next step on, keeping every world: `learners` and a
    /// params dict that differs from this batch's only in `policies.*` and
    /// `env.*action_mode` (wolfpack_core::batch::BatchEnv::set_drivers).
    fn set_drivers(slf: &Bound<'_, Self>, learners: &str, params: &Bound<'_, PyAny>) -> PyResult<()> {
        let mut this = exclusive(slf)?;
        let l = Learners::parse(learners).map_err(value_error)?;
        let p = params_from(params)?;
        let env = &mut this.inner;
        guarded(|| env.set_drivers(l, p))?.map_err(value_error)
    }

    /// The scripted laws' actions for the learning sides: (wolves [E, N, 2] or None,
    /// targets [E, M, 2] or None), float32.
    fn expert_actions<'py>(slf: &Bound<'py, Self>, py: Python<'py>) -> PyResult<(SideArray<'py>, SideArray<'py>)> {
        let mut this = exclusive(slf)?;
        let env = &mut this.inner;
        let (aw, at) = py.detach(|| guarded(|| env.expert_actions()))?;
        let e = this.inner.num_envs();
        let l = this.inner.learners();
        let w = if l.wolves() { Some(array(py, aw, &[e, this.inner.n_wolves(), 2])?) } else { None };
        let t = if l.targets() { Some(array(py, at, &[e, this.inner.n_targets(), 2])?) } else { None };
        Ok((w, t))
    }

    /// Every world's global state, float32 [E, state_dim] (layout: wolfpack_core::state).
    fn state<'py>(slf: &Bound<'py, Self>, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let this = shared(slf)?;
        let rows = this.inner.state().map_err(value_error)?;
        array(py, rows, &[this.inner.num_envs(), this.inner.state_dim()])
    }

    #[getter]
    fn state_dim(slf: &Bound<'_, Self>) -> PyResult<usize> {
        let this = shared(slf)?;
        Ok(this.inner.state_dim())
    }

    /// World `index`'s state: wolves [N, 5] and targets [M, 5] (x, y, θ, v, ω), energy [N+M],
    /// interaction [(N+M), (N+M)] uint8, wolf_mode [N] and target_mode [M] uint8 (the last step's law modes, codes into
    /// `LAW_MODES`; 0 where given commands drove), captured [M], cornered [M] (ever cornered), obstacles (list of dicts: kind, moving,
    /// center, radius, angle, vertices [world], local [at angle 0]), step,
    /// outcome, seed, episode.
    fn world_state<'py>(slf: &Bound<'py, Self>, py: Python<'py>, index: usize) -> PyResult<Bound<'py, PyDict>> {
        let mut this = exclusive(slf)?;
        let num_envs = this.inner.num_envs();
        let w = this.inner.world(index).ok_or_else(|| PyValueError::new_err(format!("world index {index} out of range (num_envs = {num_envs})")))?;
        let (n, m) = (w.n_wolves(), w.n_targets());
        let pose = |a: &wolfpack_core::world::AgentState| [a.pos.x, a.pos.y, a.theta, a.v, a.omega];
        let d = PyDict::new(py);
        d.set_item("wolves", array(py, w.wolves.iter().flat_map(pose).collect(), &[n, 5])?)?;
        d.set_item("targets", array(py, w.targets.iter().flat_map(pose).collect(), &[m, 5])?)?;
        d.set_item("energy", PyArray1::from_vec(py, w.wolves.iter().chain(&w.targets).map(|a| a.energy).collect()))?;
        d.set_item("interaction", array(py, w.interaction.clone(), &[n + m, n + m])?)?;
        d.set_item("wolf_mode", PyArray1::from_vec(py, w.wolf_mode.iter().map(|&x| x as u8).collect()))?;
        d.set_item("target_mode", PyArray1::from_vec(py, w.target_mode.iter().map(|&x| x as u8).collect()))?;
        d.set_item("captured", PyArray1::from_vec(py, w.target_captured.clone()))?;
        d.set_item("cornered", PyArray1::from_vec(py, w.target_cornered_step.iter().map(Option::is_some).collect()))?;
        let obstacles = PyList::empty(py);
        for o in &w.obstacles {
            let od = PyDict::new(py);
            od.set_item("kind", if o.is_polygon() { "polygon" } else { "circle" })?;
            od.set_item("moving", o.kind.is_moving())?;
            od.set_item("center", PyArray1::from_vec(py, vec![o.center.x, o.center.y]))?;
            od.set_item("radius", o.radius)?;
            od.set_item("angle", o.angle)?;
            let k = o.vertices.len();
            od.set_item("vertices", array(py, o.vertices.iter().flat_map(|v| [v.x, v.y]).collect(), &[k, 2])?)?;
            od.set_item("local", array(py, o.local.iter().flat_map(|v| [v.x, v.y]).collect(), &[k, 2])?)?;
            obstacles.append(od)?;
        }
        d.set_item("obstacles", obstacles)?;
        d.set_item("step", w.t)?;
        d.set_item("outcome", w.outcome.as_str())?;
        let (seed, episode) = this.inner.world_seed(index).unwrap_or_default();
        d.set_item("seed", seed)?;
        d.set_item("episode", episode)?;
        Ok(d)
    }
}

/// Renders a scene dict (the fields of `wolfpack_core::render::Scene`; built by
/// `wolfpack.render`) into a new uint8 array of shape (height, width, 3). ValueError on a bad
/// scene or size.
#[pyfunction]
fn render_frame<'py>(py: Python<'py>, scene: &Bound<'py, PyAny>, width: u32, height: u32) -> PyResult<Bound<'py, PyAny>> {
    let scene: Scene = pythonize::depythonize(scene).map_err(|e| PyValueError::new_err(format!("scene: {e}")))?;
    let frame = py.detach(|| guarded(|| render(&scene, width, height)))?.map_err(PyValueError::new_err)?;
    array(py, frame, &[height as usize, width as usize, 3])
}

#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    // Panics are caught at the border and reported as RuntimeError; keep their default
    // "thread panicked at" text off the user's terminal.
    std::panic::set_hook(Box::new(|_| {}));
    // Fetch NumPy's C API now, at import: fetched lazily, the first array built after a Ctrl-C
    // would fail to import it (KeyboardInterrupt pending) and rust-numpy would panic.
    let _ = PyArray1::<f64>::zeros(m.py(), 1, false);
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("MAX_THREADS", wolfpack_core::episode::MAX_THREADS)?;
    // The names Python shows and accepts, from the core's own lists.
    m.add("OUTCOMES", PyTuple::new(py, wolfpack_core::world::Outcome::ALL.map(|o| o.as_str()))?)?;
    m.add("WOLF_LAWS", PyTuple::new(py, wolfpack_core::config::WolfPolicy::ALL.map(|l| l.as_str()))?)?;
    m.add("TARGET_LAWS", PyTuple::new(py, wolfpack_core::config::TargetPolicy::ALL.map(|l| l.as_str()))?)?;
    // The laws' modes, indexed by the codes of the trajectories' wolf_mode / target_mode.
    m.add("LAW_MODES", PyTuple::new(py, wolfpack_core::world::LawMode::NAMES)?)?;
    m.add("ENTITY_FIELDS", PyTuple::new(py, wolfpack_core::observe::ENTITY_FIELDS)?)?;
    m.add("ENTITY_STATE_FIELDS", PyTuple::new(py, wolfpack_core::state::ENTITY_STATE_FIELDS)?)?;
    m.add("ENTITY_SCALE", wolfpack_core::observe::ENTITY_SCALE)?;
    m.add("ENTITY_WALLS", wolfpack_core::observe::ENTITY_WALLS)?;
    m.add("LEARNERS", PyTuple::new(py, Learners::ALL.map(Learners::as_str))?)?;
    // The renderer's colours, for the legends and figures drawn in Python.
    m.add("WOLF_COLOURS", PyTuple::new(py, wolfpack_core::render::WOLF_COLOURS.map(|c| PyTuple::new(py, c)).into_iter().collect::<PyResult<Vec<_>>>()?)?)?;
    m.add("TARGET_COLOUR", PyTuple::new(py, wolfpack_core::render::TARGET_COLOUR)?)?;
    m.add("STATIC_OBSTACLE_COLOUR", PyTuple::new(py, wolfpack_core::render::STATIC_OBSTACLE)?)?;
    m.add("MOVING_OBSTACLE_COLOUR", PyTuple::new(py, wolfpack_core::render::MOVING_OBSTACLE)?)?;
    m.add_function(wrap_pyfunction!(observation_layout, m)?)?;
    m.add_function(wrap_pyfunction!(default_params, m)?)?;
    m.add_function(wrap_pyfunction!(validate_params, m)?)?;
    m.add_function(wrap_pyfunction!(param_limits, m)?)?;
    m.add_function(wrap_pyfunction!(check_layout, m)?)?;
    m.add_function(wrap_pyfunction!(run_episodes, m)?)?;
    m.add_function(wrap_pyfunction!(render_frame, m)?)?;
    m.add_class::<PyBatchEnv>()?;
    Ok(())
}
