//! The Python module `miniskeleton_core`: thin pyo3 bindings over the pure-Rust core.
//! One file per core area (weights, posing, primitives); `error.rs` maps errors and stops panics.
//! Arrays in and out are numpy; any array-like is cast to the documented dtype.

mod convert;
mod error;
mod motion;
mod posing;
mod primitives;
mod skeleton;
mod weights;

use pyo3::prelude::*;

#[pymodule]
fn miniskeleton_core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("Cancelled", m.py().get_type::<error::Cancelled>())?;
    m.add_function(wrap_pyfunction!(weights::idw_weights, m)?)?;
    m.add_function(wrap_pyfunction!(weights::bilinear_weights, m)?)?;
    m.add_function(wrap_pyfunction!(weights::heat_weights, m)?)?;
    m.add_function(wrap_pyfunction!(weights::heat_weights_report, m)?)?;
    m.add_function(wrap_pyfunction!(weights::heat_weights_many, m)?)?;
    m.add_function(wrap_pyfunction!(weights::touching_meshes, m)?)?;
    m.add_function(wrap_pyfunction!(weights::catmull_clark_limit, m)?)?;
    m.add_function(wrap_pyfunction!(primitives::capped_cylinder, m)?)?;
    m.add_function(wrap_pyfunction!(primitives::bone_chain, m)?)?;
    m.add_function(wrap_pyfunction!(primitives::split_flat, m)?)?;
    posing::register(m)?;
    skeleton::register(m)?;
    motion::register(m)?;
    Ok(())
}
