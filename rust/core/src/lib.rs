//! wolfpack-core: a 2-D wolf-pack pursuit–evasion world and its analytic laws, in pure Rust.
//!
//! The layout follows docs/world-and-laws.md: [`world`] (§1), [`policies`] (§2–§7),
//! [`episode`] (§1.7, outcomes and logs). Python bindings live in a separate crate; nothing here
//! knows of Python.

pub mod batch;
pub mod config;
pub mod crew;
pub mod episode;
pub mod error;
pub mod geometry;
pub mod limits;
pub mod math;
pub mod normal;
pub mod observe;
pub mod pipeline;
pub mod policies;
pub mod render;
pub mod reward;
pub mod scene;
pub mod state;
pub mod world;

pub use config::Params;
pub use error::{Error, Result};
pub use world::World;
