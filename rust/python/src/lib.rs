//! The Python module `miniskeleton_core`: thin pyo3 bindings over the pure-Rust core.
//! One file per core area (mesh, weights, skeleton, autorig, motion, posing, and the generated test
//! meshes of primitives), each registering its own functions; `error.rs` maps errors and stops
//! panics; `convert.rs` checks and converts numpy inputs; `options.rs` reads keyword options into
//! the core's option structs. Arrays in and out are numpy; any
//! array-like is cast to the documented dtype.

mod autorig;
mod convert;
mod error;
mod mesh;
mod motion;
mod options;
mod posing;
mod primitives;
mod skeleton;
mod weights;

use pyo3::prelude::*;

#[pymodule]
fn miniskeleton_core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("Cancelled", m.py().get_type::<error::Cancelled>())?;
    m.add_function(wrap_pyfunction!(error::_raise_test_panic, m)?)?;
    mesh::register(m)?;
    weights::register(m)?;
    skeleton::register(m)?;
    autorig::register(m)?;
    motion::register(m)?;
    posing::register(m)?;
    primitives::register(m)?;
    Ok(())
}
