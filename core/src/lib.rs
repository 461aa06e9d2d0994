//! skeletrace-core: the scene model, the field engine with its bounds, the root-finding methods
//! and the CPU tracer. Pure Rust, no GPU and no UI (DESIGN.md, `docs/architecture.md`).
//!
//! Data flows one way: a [`model::scene::Scene`] (what the user edits and saves) is compiled by
//! [`compile::compile`] into an `Arc<`[`compile::Compiled`]`>` once per edit; a
//! [`backend::FrameBackend`] (the CPU tracer in [`cpu`], the GPU in `skeletrace-render`) traces
//! it through a camera into [`frame::Frame`]s. Methods are named by [`methods::MethodId`].
//!
//! - [`model`]: scene data, validation, file format, generators.
//! - [`field`]: kernels, primitives, blends, the BVH and the compiled [`field::program::FieldProgram`].
//! - [`bounds`]: intervals, Taylor and bottom-up inclusions, affine forms (2023 paper §4–6).
//! - [`methods`]: one file per root-finding method.
//! - [`output`]: the one writer of every output file (atomic, never over an input).
//! - [`cpu`]: the CPU renderer, field shading, the CPU backend.
//! - [`frame`], [`backend`], [`stats`]: what both backends share (frames, cameras, views,
//!   the bounce limit, the trait and the one backend decision, the statistics protocol and
//!   its records).

pub mod backend;
pub mod bounds;
pub mod compile;
pub mod cpu;
pub mod field;
pub mod frame;
pub mod methods;
pub mod model;
pub mod output;
mod scratch;
pub mod stats;

pub use bounds::interval::{Interval, Jet};
pub use compile::{Compiled, compile};
pub use field::geometry::{Aabb, Ray};
pub use field::program::FieldProgram;
pub use methods::MethodId;
pub use model::scene::{Scene, SceneError};
