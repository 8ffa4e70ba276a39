//! The one place core errors become Python exceptions, and panics are stopped at the boundary.

use miniskeleton_core::error::panic_message;
use miniskeleton_core::Error;
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use std::panic::{catch_unwind, AssertUnwindSafe};

pyo3::create_exception!(
    miniskeleton_core,
    Cancelled,
    pyo3::exceptions::PyException,
    "Raised when a progress callback returned False."
);

/// Map a core error: bad input is `ValueError`, cancel `Cancelled`, a panic caught in the core
/// (`Error::Internal`) `RuntimeError`, as one caught here (a factorization that fails is not an
/// error: those pieces fall back to their nearest bones, see `HeatReport`).
pub fn to_py(err: Error) -> PyErr {
    match err {
        Error::Cancelled => Cancelled::new_err("cancelled by the progress callback"),
        Error::Internal(msg) => internal(&msg),
        _ => PyValueError::new_err(err.to_string()),
    }
}

fn internal(msg: &str) -> PyErr {
    PyRuntimeError::new_err(format!("internal error in miniskeleton_core (please report): {msg}"))
}

/// Run `f` without the GIL and turn a Rust panic into `RuntimeError` instead of letting it
/// unwind into Python (pyo3's own `PanicException` is a `BaseException`, which Blender
/// operators would not catch).
pub fn guarded<T: Send>(py: Python<'_>, f: impl FnOnce() -> Result<T, Error> + Send) -> PyResult<T> {
    let out = py.detach(|| catch_unwind(AssertUnwindSafe(f)));
    match out {
        Ok(Ok(v)) => Ok(v),
        Ok(Err(e)) => Err(to_py(e)),
        Err(panic) => Err(internal(&panic_message(&*panic))),
    }
}

/// Panic on purpose inside `guarded`: every platform's build must give `RuntimeError` back
/// (the release profile unwinds and each binary carries its unwinder), never abort the process
/// that loaded the module. Called by the Python API tests and the Blender tests.
#[pyfunction]
pub fn _raise_test_panic(py: Python<'_>) -> PyResult<()> {
    guarded(py, || -> Result<(), Error> { panic!("a test panic, raised on purpose") })
}
