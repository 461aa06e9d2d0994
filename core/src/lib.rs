//! skeletrace-core: the scene model, kernels, primitives, the field engine with its bounds, and
//! the scene generators. Pure Rust, no GPU and no UI (DESIGN.md).
//!
//! Objects by lifetime: a [`scene::Scene`] is what the user edits and saves; a
//! [`program::FieldProgram`] is compiled from it after each edit and queried by the tracers;
//! [`interval::Jet`]s are per-query enclosures along rays.

pub mod affine;
pub mod blend;
pub mod bottom_up;
pub mod bvh;
pub mod generate;
pub mod geometry;
pub mod hrbf;
pub mod inclusion;
pub mod interval;
pub mod kernel;
pub mod methods;
pub mod primitives;
pub mod program;
pub mod quadrature;
pub mod render;
pub mod rng;
pub mod scene;
pub mod shading;
pub mod stats;

pub use geometry::{Aabb, Ray};
pub use interval::{Interval, Jet};
pub use program::FieldProgram;
pub use scene::{Scene, SceneError};
