//! The one error type of the library: every failure names its file and, where
//! it has one, its line.

use std::path::PathBuf;

/// Result with the library's [`Error`].
pub type Result<T> = std::result::Result<T, Error>;

/// What can go wrong, with enough context for a one-line message.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The file could not be opened or read.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// What the system said.
        #[source]
        source: std::io::Error,
    },
    /// A line of the file could not be understood.
    #[error("{}:{line}: {message}", path.display())]
    Parse {
        /// The file.
        path: PathBuf,
        /// The line, counted from 1.
        line: usize,
        /// What is wrong with it.
        message: String,
    },
    /// The input is readable but cannot be used by the method.
    #[error("{source_name}: {message}")]
    Input {
        /// The trajectory's name (its file, or what the caller named it).
        source_name: String,
        /// What is wrong with it.
        message: String,
    },
}

impl Error {
    /// An [`Error::Input`] for the named trajectory.
    pub fn input(source_name: impl Into<String>, message: impl Into<String>) -> Self {
        Error::Input {
            source_name: source_name.into(),
            message: message.into(),
        }
    }
}
