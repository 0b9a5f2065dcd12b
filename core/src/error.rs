//! Error and warning types: import errors and warnings carry the JSON pointer of the
//! offending element; job errors describe what a job's inputs got wrong.

use std::fmt;

/// A glTF document was refused. `pointer` names the offending element as a JSON pointer
/// into the document (e.g. `/accessors/3`), or `""` for the file as a whole (GLB container).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{pointer}: {message}")]
pub struct ImportError {
    /// JSON pointer of the offending element.
    pub pointer: String,
    /// What is wrong with it.
    pub message: String,
}

impl ImportError {
    /// An error at `pointer`.
    pub fn new(pointer: impl Into<String>, message: impl Into<String>) -> Self {
        Self { pointer: pointer.into(), message: message.into() }
    }
}

/// A defect the importer repaired (or an element it skipped); the document still loaded.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Warning {
    /// JSON pointer of the repaired element.
    pub pointer: String,
    /// What was wrong and what was done about it.
    pub message: String,
}

impl Warning {
    /// A warning at `pointer`.
    pub fn new(pointer: impl Into<String>, message: impl Into<String>) -> Self {
        Self { pointer: pointer.into(), message: message.into() }
    }
}

impl fmt::Display for Warning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.pointer, self.message)
    }
}

/// A job's inputs are inconsistent; the job wrote nothing (from `validate`) or stopped early.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum JobError {
    /// An output (or input) slice is shorter than the job needs.
    #[error("{what}: buffer too small, needs {needed} elements, got {got}")]
    BufferTooSmall {
        /// Which buffer.
        what: &'static str,
        /// Elements needed.
        needed: usize,
        /// Elements available.
        got: usize,
    },
    /// An index stored in an input points outside the slice it indexes.
    #[error("{what}: index {index} out of range (length {len})")]
    IndexOutOfRange {
        /// Which index.
        what: &'static str,
        /// The index.
        index: usize,
        /// Length of the indexed slice.
        len: usize,
    },
    /// Lengths that must match do not.
    #[error("{what}: length {got} does not match expected {expected}")]
    LengthMismatch {
        /// Which slice.
        what: &'static str,
        /// Expected length.
        expected: usize,
        /// Actual length.
        got: usize,
    },
    /// Anything else wrong with the inputs.
    #[error("invalid input: {0}")]
    InvalidInput(String),
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn display_names_the_pointer() {
        assert_eq!(ImportError::new("/accessors/3", "bad").to_string(), "/accessors/3: bad");
        assert_eq!(Warning::new("/nodes/0", "fixed").to_string(), "/nodes/0: fixed");
        let e = JobError::BufferTooSmall { what: "worlds", needed: 3, got: 1 };
        assert_eq!(e.to_string(), "worlds: buffer too small, needs 3 elements, got 1");
    }
}
