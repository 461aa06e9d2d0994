//! The scene model: plain data the user edits and saves (`scene`, its kernels in `kernel`), its
//! validation and RON file
//! format, the scene generators (`generate`) with their seeded random numbers (`rng`), SWC
//! morphology files read as skeletons (`swc`), and the nearest-name suggestions of error
//! messages (`names`).

pub mod generate;
pub mod kernel;
pub mod names;
pub mod rng;
pub mod scene;
pub mod swc;
