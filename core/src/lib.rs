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
//!
//! A scene read from text, compiled once, and one ray traced through it by segment tracing:
//!
//! ```
//! use glam::DVec3;
//! use skeletrace_core::methods::{Method, RayTracer, TraceMode, TraceSettings};
//! use skeletrace_core::{Interval, MethodId, Ray, Scene, compile};
//!
//! let scene = Scene::from_ron(
//!     "(version: 1, isovalue: 1.0, groups: [(name: \"ball\", \
//!       kernel: CompactPolynomial(degree: 6, scale: 2.0), \
//!       blobs: [(center: (0.0, 0.0, 0.0), radius: 1.0)])])",
//!     "ball.ron",
//! )?;
//! let compiled = compile(&scene);
//! let program = &compiled.program;
//! let tracer = MethodId::Segment
//!     .method()
//!     .prepare(program, TraceSettings::for_program(program));
//! let ray = Ray::new(DVec3::new(0.0, 0.0, -5.0), DVec3::Z);
//! let trace = tracer.trace(&ray, Interval::new(0.0, 10.0), TraceMode::Opaque);
//! // The blob's surface lies at its radius: the ray enters it 4 units from its origin.
//! let hit = trace.first().map(|c| c.t);
//! assert!(hit.is_some_and(|t| (t - 4.0).abs() < 1e-4), "{hit:?}");
//! # Ok::<(), skeletrace_core::SceneError>(())
//! ```

pub mod backend;
pub mod bounds;
pub mod compile;
pub mod cpu;
pub mod field;
pub mod frame;
pub mod isosurface;
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
