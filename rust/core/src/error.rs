//! The one error type of the core. Every public function returns `Result<T, Error>`;
//! the Python bindings map each variant to a Python exception (`rust/python/src/error.rs`).

use std::any::Any;
use std::fmt;
use std::panic::{catch_unwind, AssertUnwindSafe};

/// What went wrong, in words a rigger can act on.
#[derive(Debug, Clone, PartialEq)]
pub enum Error {
    /// The mesh has no vertices (or, where faces are required, no usable faces).
    EmptyMesh(String),
    /// `count` inputs of kind `what` (vertices, bones, matrices...) hold NaN or infinity.
    NonFinite { what: &'static str, count: usize },
    /// A triangle refers to a vertex that does not exist.
    BadIndex { triangle: usize, index: i64, vertex_count: usize },
    /// No bones were given, or none usable for the task; the text is the whole message
    /// ("the armature has no bones", "no legs: ..."), so it reads without a generic prefix.
    NoBones(String),
    /// Array lengths or shapes disagree.
    Shape(String),
    /// An argument is out of its range.
    InvalidArgument(String),
    /// The mesh is not a shape the task can take (Auto Rig: no ground contact, not upright);
    /// the text says what was found.
    Unsuitable(String),
    /// The caller's progress callback asked to stop.
    Cancelled,
    /// A panic in the core (a bug, never bad input), caught where one piece of work must not
    /// take the others down with it ([`caught`]); the text is the panic's message.
    Internal(String),
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::EmptyMesh(s) => write!(f, "empty mesh: {s}"),
            Error::NonFinite { what, count } => {
                write!(f, "{count} {what}(s) have NaN or infinite values")
            }
            Error::BadIndex { triangle, index, vertex_count } => {
                write!(f, "triangle {triangle} refers to vertex {index}, but the mesh has {vertex_count} vertices")
            }
            Error::NoBones(s) => write!(f, "{s}"),
            Error::Shape(s) => write!(f, "shape mismatch: {s}"),
            Error::InvalidArgument(s) => write!(f, "invalid argument: {s}"),
            Error::Unsuitable(s) => write!(f, "{s}"),
            Error::Cancelled => write!(f, "cancelled"),
            Error::Internal(s) => write!(f, "internal error (please report): {s}"),
        }
    }
}

impl std::error::Error for Error {}

/// Shorthand used by every module.
pub type Result<T> = std::result::Result<T, Error>;

/// The message of a caught panic's payload (`panic!` with a literal gives a `&str`, with
/// arguments a `String`); `"unknown panic"` for any other payload.
pub fn panic_message(payload: &(dyn Any + Send)) -> String {
    payload
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "unknown panic".into())
}

/// Run `f`, turning a panic into [`Error::Internal`] with its message instead of unwinding
/// further: used per item where one item's bug must fail that item alone (one mesh of
/// [`crate::weights::heat_weights_many`]). `f` must leave nothing half-changed that the
/// caller reads after a panic (the callers here only read their inputs).
pub fn caught<T>(f: impl FnOnce() -> Result<T>) -> Result<T> {
    catch_unwind(AssertUnwindSafe(f)).unwrap_or_else(|payload| Err(Error::Internal(panic_message(&*payload))))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_carry_one_prefix() {
        let e = Error::NoBones("no head: the body axis has a single bone".into());
        assert_eq!(e.to_string(), "no head: the body axis has a single bone");
        assert_eq!(Error::EmptyMesh("no faces".into()).to_string(), "empty mesh: no faces");
    }

    #[test]
    fn a_caught_panic_is_an_internal_error_with_its_message() {
        assert_eq!(caught(|| Ok(3)), Ok(3));
        assert_eq!(caught::<()>(|| Err(Error::Cancelled)), Err(Error::Cancelled));
        assert_eq!(caught::<()>(|| panic!("plain")), Err(Error::Internal("plain".into())));
        let i = 7;
        assert_eq!(caught::<()>(|| panic!("index {i}")), Err(Error::Internal("index 7".into())));
        assert_eq!(caught::<()>(|| std::panic::panic_any(5u8)), Err(Error::Internal("unknown panic".into())));
        let v: Vec<u32> = vec![];
        let err = caught(|| Ok(v[i])).unwrap_err();
        assert!(err.to_string().starts_with("internal error (please report): index out of bounds"), "{err}");
    }
}
