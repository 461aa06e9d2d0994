//! The scene model: plain data the user edits and saves (`scene`), its validation and RON file
//! format, and the scene generators (`generate`) with their seeded random numbers (`rng`).

pub mod generate;
pub mod rng;
pub mod scene;
