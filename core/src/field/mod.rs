//! The field engine: kernels (`kernel`, MATH.md §1–3), primitives and their supports
//! (`primitives`), blend operators (`blend`), the BVH over supports (`bvh`), HRBF weights
//! (`hrbf_solve`, 2023 eq. 9), quadrature (`quadrature`) and the compiled, read-only
//! [`program::FieldProgram`], which tracers query through one ray at a time
//! ([`ray_field::RayField`]: the ray's candidate primitives gathered once).

pub mod blend;
pub mod bvh;
pub mod geometry;
pub mod hrbf_solve;
pub mod kernel;
pub mod primitives;
pub mod program;
pub mod quadrature;
pub mod ray_field;
