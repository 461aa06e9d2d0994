//! Cross-crate tests of skeletrace; the tests themselves live in `tests/tests/`. This library
//! holds what they share: whether the GPU tests run here.
//!
//! GPU and window tests need a wgpu adapter (Mesa's lavapipe in CI). Without one, plain
//! `cargo test --workspace` prints that they were skipped and why; with
//! `SKELETRACE_REQUIRE_GPU=1` (set by `scripts/test`, hence CI) they fail instead.

use std::sync::{Mutex, MutexGuard, OnceLock, TryLockError};

use skeletrace_render::GpuRenderer;

/// Whether a missing adapter must fail the GPU tests (`SKELETRACE_REQUIRE_GPU=1`).
#[must_use]
pub fn gpu_required() -> bool {
    std::env::var("SKELETRACE_REQUIRE_GPU").is_ok_and(|v| v == "1")
}

/// The test binary's first GPU renderer, or why there is none.
fn first_renderer() -> &'static Result<Mutex<GpuRenderer>, String> {
    static RENDERER: OnceLock<Result<Mutex<GpuRenderer>, String>> = OnceLock::new();
    RENDERER.get_or_init(|| {
        GpuRenderer::new()
            .map(Mutex::new)
            .map_err(|e| e.to_string())
    })
}

/// Most renderers a test binary opens besides the first.
const MORE_RENDERERS: usize = 3;

/// The renderers opened when every other one was held: up to one per core in all, each on its
/// own device. Building pipelines is most of a GPU test's time on lavapipe, which compiles each
/// on one thread: with a renderer per core, tests compile theirs at once, and Mesa's shader
/// cache hands a pipeline one renderer built to the others.
fn more_renderers() -> impl Iterator<Item = &'static Mutex<GpuRenderer>> {
    static MORE: [OnceLock<Option<Mutex<GpuRenderer>>>; MORE_RENDERERS] =
        [const { OnceLock::new() }; MORE_RENDERERS];
    let cores = std::thread::available_parallelism().map_or(1, std::num::NonZero::get);
    MORE[..(cores - 1).min(MORE_RENDERERS)]
        .iter()
        .filter_map(|slot| {
            slot.get_or_init(|| GpuRenderer::new().ok().map(Mutex::new))
                .as_ref()
        })
}

/// Why no adapter could be opened; `None` when there is one.
fn missing_adapter() -> Option<&'static str> {
    first_renderer().as_ref().err().map(String::as_str)
}

/// `true` (after printing why) when test `name` must be skipped for want of a GPU adapter;
/// panics instead where the GPU is required.
///
/// # Panics
/// Without an adapter when [`gpu_required`].
#[must_use]
pub fn skip_without_gpu(name: &str) -> bool {
    let Some(why) = missing_adapter() else {
        return false;
    };
    assert!(
        !gpu_required(),
        "{name}: SKELETRACE_REQUIRE_GPU=1 but there is no GPU adapter: {why} \
         (install mesa-vulkan-drivers for lavapipe)"
    );
    eprintln!(
        "SKIPPED {name}: no GPU adapter ({why}); set SKELETRACE_REQUIRE_GPU=1 to make this a failure"
    );
    true
}

/// A GPU renderer of the test binary, held by test `name` until the guard drops (at most one
/// test per renderer at a time: the first free one, waiting for one to be freed), or `None`
/// (after printing why) when it must be skipped. A test that changes the renderer's settings
/// restores them.
///
/// # Panics
/// As [`skip_without_gpu`].
#[must_use]
pub fn gpu_or_skip(name: &str) -> Option<MutexGuard<'static, GpuRenderer>> {
    if skip_without_gpu(name) {
        return None;
    }
    let first = first_renderer().as_ref().ok()?;
    loop {
        // Lazily: a renderer is opened only when those before it are held.
        for renderer in std::iter::once(first).chain(more_renderers()) {
            match renderer.try_lock() {
                Ok(guard) => return Some(guard),
                // A test that panicked while holding it leaves a renderer that still works.
                Err(TryLockError::Poisoned(poisoned)) => return Some(poisoned.into_inner()),
                Err(TryLockError::WouldBlock) => {}
            }
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
}

/// A renderer on wgpu's OpenGL backend (Mesa's llvmpipe through EGL here and in CI) for test
/// `name`, or `None` (after printing why) when it must be skipped: where the GPU is required,
/// a machine without an OpenGL adapter fails the test.
///
/// # Panics
/// Without an OpenGL adapter when [`gpu_required`].
#[must_use]
pub fn opengl_or_skip(name: &str) -> Option<GpuRenderer> {
    let why = match GpuRenderer::new_on_opengl() {
        Ok(renderer) if renderer.graphics_api() == skeletrace_render::wgpu::Backend::Gl => {
            return Some(renderer);
        }
        Ok(renderer) => format!("the adapter '{}' is not OpenGL", renderer.adapter_name()),
        Err(e) => e.to_string(),
    };
    assert!(
        !gpu_required(),
        "{name}: SKELETRACE_REQUIRE_GPU=1 but there is no OpenGL adapter: {why} \
         (install libegl1 and libgl1-mesa-dri for llvmpipe)"
    );
    eprintln!(
        "SKIPPED {name}: no OpenGL adapter ({why}); set SKELETRACE_REQUIRE_GPU=1 to make this a failure"
    );
    None
}
