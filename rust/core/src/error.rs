//! The one error type of the core. Every public function returns `Result<T, Error>`;
//! the Python bindings map each variant to a Python exception (`rust/python/src/error.rs`).

use std::fmt;

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
    /// The caller's progress callback asked to stop.
    Cancelled,
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
            Error::Cancelled => write!(f, "cancelled"),
        }
    }
}

impl std::error::Error for Error {}

/// Shorthand used by every module.
pub type Result<T> = std::result::Result<T, Error>;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_carry_one_prefix() {
        let e = Error::NoBones("no head: the body axis has a single bone".into());
        assert_eq!(e.to_string(), "no head: the body axis has a single bone");
        assert_eq!(Error::EmptyMesh("no faces".into()).to_string(), "empty mesh: no faces");
    }
}
