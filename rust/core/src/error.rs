//! The core's errors: each one line, naming what is wrong, mapped to `ValueError` in Python.

use thiserror::Error;

#[derive(Debug, Error, Clone, PartialEq)]
pub enum Error {
    /// A parameter is missing, of the wrong type, unknown or out of range. Names the key.
    #[error("{0}")]
    Params(String),
    /// An explicit layout is malformed or infeasible.
    #[error("layout: {0}")]
    Layout(String),
    /// Random spawning could not place everything within its bounded number of attempts.
    #[error("spawn: {0}")]
    Spawn(String),
    /// A step produced a non-finite number (a law's arithmetic overflowed inside the allowed
    /// parameter ranges). Names the law, the agent and the step; the episode ends there.
    #[error("{0}")]
    NonFinite(String),
    /// The caller asked the work to stop (Ctrl-C in Python); nothing was returned.
    #[error("interrupted")]
    Interrupted,
    /// Anything else the caller did wrong (shapes, actions, unimplemented policies).
    #[error("{0}")]
    Invalid(String),
}

pub type Result<T> = std::result::Result<T, Error>;
