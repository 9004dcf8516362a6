//! `deformesh._deformesh`: the library's jobs for the Python package
//! (`python/deformesh`), which wraps them in the API a Python user calls.
//!
//! Every long job runs on a thread of its own while the caller's thread,
//! the GIL released between polls, hands the progress to Python and
//! checks for Ctrl-C: then the job's own stop request is set
//! ([`deformesh::app::driver::stop_on`]), it ends at its next progress
//! report or before it writes anything, and the caller gets
//! `KeyboardInterrupt` with files and model as they were. (A signal
//! handler of ours would replace Python's.)

use std::panic::AssertUnwindSafe;
use std::path::PathBuf;
use std::sync::mpsc::{channel, RecvTimeoutError};
use std::time::Duration;

use deformesh::app::driver::{exit, stop_on, stop_requested, CurveJob, Progress, RunError, Sink};
use deformesh::geometry::cad::{live, CadModel};
use pyo3::create_exception;
use pyo3::exceptions::{PyException, PyRuntimeError};
use pyo3::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

create_exception!(_deformesh, Failure, PyException, "A job of deformesh failed: args are (exit code, message), the command line's.");

/// The payload a job unwinds with when asked to stop.
struct Stopped;

/// An error of a job, as the command line would say it, with its exit code.
fn failure(code: i32, e: &anyhow::Error) -> PyErr {
    Failure::new_err((code, format!("{e:#}")))
}

fn run_error(e: RunError, job: Option<&CurveJob>) -> PyErr {
    let code = e.exit_code();
    let e = match job {
        Some(j) => deformesh::app::cli::curve_error(e, j),
        None => anyhow::Error::from(e),
    };
    failure(code, &e)
}

/// Runs `work` on a thread of its own (8× the usual stack: the method's
/// recursion is the command line's), handing each progress report to
/// `progress(algorithm, t, steps, halved)` and ending it on Ctrl-C.
fn detached<T: Send + 'static>(py: Python<'_>, progress: Option<Py<PyAny>>, work: impl FnOnce(&mut dyn FnMut(Progress)) -> Result<T, PyErr> + Send + 'static) -> PyResult<T> {
    let stop = Arc::new(AtomicBool::new(false));
    let token = stop.clone();
    let (tx, rx) = channel::<Progress>();
    let worker = std::thread::Builder::new()
        .name("deformesh".into())
        .stack_size(64 << 20)
        .spawn(move || {
            stop_on(Some(token));
            let mut report = |p: Progress| {
                if stop_requested() {
                    std::panic::resume_unwind(Box::new(Stopped));
                }
                let _ = tx.send(p);
            };
            std::panic::catch_unwind(AssertUnwindSafe(|| work(&mut report)))
        })
        .map_err(|e| PyRuntimeError::new_err(format!("could not start the job's thread: {e}")))?;
    let end = |py: Python<'_>, worker: std::thread::JoinHandle<_>, e: PyErr| -> PyResult<T> {
        stop.store(true, Ordering::SeqCst);
        let _ = py.detach(|| worker.join());
        Err(e)
    };
    let mut rx = rx;
    loop {
        // the receiver goes with the wait and comes back (it is not Sync)
        let (next, back) = py.detach(move || (rx.recv_timeout(Duration::from_millis(50)), rx));
        rx = back;
        match next {
            Ok(p) => {
                if let Some(f) = &progress {
                    if let Err(e) = f.call1(py, (p.algorithm, p.t, p.steps, p.halved)) {
                        return end(py, worker, e);
                    }
                }
            }
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => break,
        }
        if let Err(e) = py.check_signals() {
            return end(py, worker, e);
        }
    }
    let outcome = py.detach(|| worker.join()).map_err(|_| PyRuntimeError::new_err("the job's thread ended abnormally"))?;
    match outcome {
        Ok(r) => r,
        Err(payload) if payload.is::<Stopped>() => Err(pyo3::exceptions::PyKeyboardInterrupt::new_err("")),
        Err(payload) => {
            let what = payload
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| payload.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_default();
            Err(PyRuntimeError::new_err(format!("deformesh panicked (a bug: please report it with the input): {what}")))
        }
    }
}

/// The command line: `deformesh ARGS` (argv[0] the program's name), its
/// output on the process's stdout and stderr; returns the exit code.
/// The process is then the command: its Ctrl-C is the command line's
/// (staged outputs removed, exit 130), not Python's.
#[pyfunction]
fn main(py: Python<'_>, argv: Vec<String>) -> i32 {
    deformesh::io::folder::install_interrupt_handler();
    py.detach(|| deformesh::app::cli::main(argv))
}

/// `deformesh curve ARGS` (argv[0] the program's name, then "curve"),
/// the report as JSON.
/// `library`: Gmsh's, for `--cad` (the Python `gmsh` module's); `attach`:
/// the process has initialised it already (its models are the user's: it
/// is not initialised again).
#[pyfunction]
#[pyo3(signature = (argv, progress=None, library=None, attach=false))]
fn curve(py: Python<'_>, argv: Vec<String>, progress: Option<Py<PyAny>>, library: Option<PathBuf>, attach: bool) -> PyResult<String> {
    let mut job = deformesh::app::cli::parse_curve(argv).map_err(|e| failure(deformesh::app::cli::exit_code(&e), &e))?;
    if let (Some(cad), Some(lib)) = (job.cad.as_mut(), library) {
        if attach {
            live::attach(&lib).map_err(|e| run_error(e.into(), None))?;
        }
        cad.library = Some(lib);
    }
    detached(py, progress, move |report| {
        let r = deformesh::app::driver::curve_file(&job, report).map_err(|e| run_error(e, Some(&job)))?;
        Ok(serde_json::to_string(&r).expect("the report serialises"))
    })
}

/// `deformesh.gmsh.curve`: the live model of the process's Gmsh (loaded
/// from `library`) curved in place. `argv`: the method's options as on
/// the command line (and `--geometry FILE`). Returns the report as JSON
/// and what was written back.
#[pyfunction]
#[pyo3(signature = (library, argv, cad=true, progress=None))]
fn curve_live(py: Python<'_>, library: PathBuf, argv: Vec<String>, cad: bool, progress: Option<Py<PyAny>>) -> PyResult<String> {
    let lib = library.clone();
    let (report, curved, p) = detached(py, progress, move |report| {
        let (options, geometry) = deformesh::app::cli::live_options(argv).map_err(|e| failure(deformesh::app::cli::exit_code(&e), &e))?;
        let to_err = |e: deformesh::geometry::cad::CadError| run_error(e.into(), None);
        let clock = std::time::Instant::now();
        let (name, text) = live::live_msh(&lib).map_err(to_err)?;
        tracing::info!("the live model's mesh read: {:.3}s", clock.elapsed().as_secs_f64());
        let model = if cad { Some(CadModel::live(&lib).map_err(to_err)?) } else { None };
        let job = CurveJob {
            input: format!("the Gmsh model `{name}`").into(),
            geometry,
            cad: None,
            output: PathBuf::from("live.msh"),
            format: deformesh::app::driver::OutputFormat::Msh41,
            options,
            width: 0,
            force: false,
        };
        let p = job.options.order;
        let clock = std::time::Instant::now();
        let mut r = deformesh::app::driver::curve_bytes(&job, text.into_bytes(), model.as_ref(), Sink::Memory, report).map_err(|e| run_error(e, Some(&job)))?;
        tracing::info!("curved: {:.3}s", clock.elapsed().as_secs_f64());
        if stop_requested() {
            std::panic::resume_unwind(Box::new(Stopped));
        }
        let curved = r.curved.take().expect("a run into memory returns its mesh");
        Ok((serde_json::to_value(&r).expect("the report serialises"), curved, p))
    })?;
    // a Ctrl-C after the job's last poll: the model stays as it was
    py.check_signals()?;
    // not interruptible: the model is written whole
    let clock = std::time::Instant::now();
    let written = py.detach(|| live::write_back(&library, &curved, p)).map_err(|e| run_error(e.into(), None))?;
    tracing::info!("written back: {:.3}s", clock.elapsed().as_secs_f64());
    let mut report = report;
    report["written_back"] = serde_json::to_value(&written).expect("serialises");
    Ok(report.to_string())
}

/// The certificates of every element of the MSH file at `path`, linear
/// or high order: (element tags, certified lower bound of min det J,
/// min scaled Jacobian, valid, dimension, order).
#[pyfunction]
#[allow(clippy::type_complexity)]
fn certify(py: Python<'_>, path: PathBuf) -> PyResult<(Vec<u64>, Vec<f64>, Vec<f64>, Vec<bool>, usize, usize)> {
    py.detach(|| {
        let bad = |e: anyhow::Error| failure(exit::BAD_INPUT, &e.context(path.display().to_string()));
        let bytes = std::fs::read(&path).map_err(|e| failure(exit::BAD_INPUT, &anyhow::anyhow!("cannot read `{}`: {e}", path.display())))?;
        let read = deformesh::io::msh::parse_any(&bytes, false).map_err(|e| bad(e.into()))?;
        let (certs, dim, order) = match &read.mesh {
            deformesh::io::msh::AnyMesh::Plane(m) => (deformesh::highorder::curve::certify_mesh(m).map_err(|e| bad(e.into()))?.0, 2, m.p),
            deformesh::io::msh::AnyMesh::Solid(m) => (deformesh::highorder::curve::certify_mesh(m).map_err(|e| bad(e.into()))?.0, 3, m.p),
        };
        Ok((
            read.cell_tags,
            certs.iter().map(|c| c.min_det_lower).collect(),
            certs.iter().map(|c| c.min_scaled_jacobian).collect(),
            certs.iter().map(|c| c.valid).collect(),
            dim,
            order,
        ))
    })
}

/// `deformesh run`: the case given as TOML text (`name` for messages,
/// its relative paths from `base`) into the folder `out` (by default the
/// command line's, out/<case name>); the report as JSON.
#[pyfunction]
#[pyo3(signature = (text, name, base, out=None, force=false, progress=None))]
fn run(py: Python<'_>, text: String, name: String, base: PathBuf, out: Option<PathBuf>, force: bool, progress: Option<Py<PyAny>>) -> PyResult<String> {
    detached(py, progress, move |report| {
        let bad = |e: RunError| {
            let code = e.exit_code();
            failure(code, &anyhow::Error::from(e).context(name.clone()))
        };
        let case = deformesh::app::case::Case::parse(&text, &name).map_err(|e| bad(e.into()))?;
        let setup = case.setup_any(&name, &base).map_err(|e| bad(e.into()))?;
        let out = out.unwrap_or_else(|| std::path::Path::new("out").join(deformesh::app::cli::folder_name(setup.name())));
        deformesh::io::folder::check_run_folder(&out, deformesh::app::driver::REPORT, force).map_err(|e| bad(e.into()))?;
        let r = deformesh::app::driver::run_any_with(setup, &out, force, report).map_err(bad)?;
        Ok(serde_json::to_string(&r).expect("the report serialises"))
    })
}

/// Turns a JSON object into TOML text (a case given as a dict).
#[pyfunction]
fn toml_of_json(json: &str) -> PyResult<String> {
    let value: toml::Value = serde_json::from_str(json).map_err(|e| pyo3::exceptions::PyValueError::new_err(format!("the case is not a table TOML can hold: {e}")))?;
    toml::to_string(&value).map_err(|e| pyo3::exceptions::PyValueError::new_err(format!("the case is not a table TOML can hold: {e}")))
}

#[pymodule]
fn _deformesh(m: &Bound<'_, PyModule>) -> PyResult<()> {
    // warnings of the library on stderr, as the command line's (RUST_LOG)
    let _ = tracing_subscriber::fmt()
        .with_env_filter(tracing_subscriber::EnvFilter::try_from_default_env().unwrap_or_else(|_| "warn".into()))
        .with_writer(std::io::stderr)
        .try_init();
    m.add("Failure", m.py().get_type::<Failure>())?;
    m.add_function(wrap_pyfunction!(main, m)?)?;
    m.add_function(wrap_pyfunction!(curve, m)?)?;
    m.add_function(wrap_pyfunction!(curve_live, m)?)?;
    m.add_function(wrap_pyfunction!(certify, m)?)?;
    m.add_function(wrap_pyfunction!(run, m)?)?;
    m.add_function(wrap_pyfunction!(toml_of_json, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
