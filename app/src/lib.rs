//! skeletrace's editor and picture composition, shared by the `skeletrace` binary (editor and
//! command line) and the editor workflow tests in `tests/`.

pub mod backends;
pub mod editor;
pub mod export;
pub mod import;
pub mod mesh_formats;
pub mod picture;
pub mod ray_probe;

/// The scene opened when no file is given: a hand-made creature.
pub const DEFAULT_SCENE: &str = include_str!("../../assets/scenes/creature.ron");
/// How messages name the embedded scene.
pub const DEFAULT_SCENE_NAME: &str = "<embedded creature.ron>";
