//! One error type over the library's stages, at the top: each stage returns its own error (the
//! scenario's, a log's, `identify`'s, a sweep's, the server's, the recording's) and no stage
//! returns this one, so nothing below depends on it. [`Error`] gathers them (`From` each, so `?`
//! converts) with the outputs that cannot be written, so that a program driving several stages
//! handles one type and still matches on the stage. Every message names the file, and the line
//! and column where the defect has them. The command line prints the message and exits with
//! [`Error::exit_code`].

use std::path::PathBuf;

/// Anything that stops a run, a sweep or an identification before it has a result.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A scenario that cannot be run.
    #[error(transparent)]
    Scenario(#[from] crate::scenario::ScenarioError),
    /// A flyarena flight log that does not read.
    #[error(transparent)]
    Log(#[from] crate::log::LogError),
    /// An identification that stopped: an input that cannot be used (a mapping, a log, a bag,
    /// a fragment) or data that does not pass the data-quality gate.
    #[error(transparent)]
    Identify(#[from] crate::identify::Error),
    /// A sweep that cannot run or merge.
    #[error(transparent)]
    Sweep(#[from] crate::sweep::SweepError),
    /// A served run whose network could not be set up (`flyarena serve`).
    #[error(transparent)]
    Serve(#[from] crate::serve::ServeError),
    /// A recording that cannot be encoded.
    #[cfg(feature = "record")]
    #[error(transparent)]
    Record(#[from] crate::record::RecordError),
    /// An output that cannot be written (nothing is left half written: see
    /// [`crate::output::write_atomic`]).
    #[error("cannot write {}: {source}", path.display())]
    Write {
        /// The output that was not written.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// A combination of inputs that does not make a job (what to give instead).
    #[error("{0}")]
    Usage(String),
}

impl Error {
    /// The exit code of the command line for this error: 2, bad input (1 is kept for a
    /// requirement that failed, 0 for a pass).
    pub fn exit_code(&self) -> i32 {
        2
    }
}

impl From<crate::identify::InputError> for Error {
    fn from(e: crate::identify::InputError) -> Self {
        Error::Identify(e.into())
    }
}

impl From<crate::identify::IdentifyError> for Error {
    fn from(e: crate::identify::IdentifyError) -> Self {
        Error::Identify(e.into())
    }
}

/// `Result` with [`Error`].
pub type Result<T> = std::result::Result<T, Error>;
