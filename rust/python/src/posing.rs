//! Bindings for posing: linear blend skinning (`lbs.rs`) and planar IK (`ik2d.rs`).

use pyo3::prelude::*;

/// Add this area's functions to the module.
pub fn register(_m: &Bound<'_, PyModule>) -> PyResult<()> {
    Ok(())
}
