//! Cross-crate tests of skeletrace; the tests themselves live in `tests/tests/`. This library
//! holds what they share: whether the GPU tests run here.
//!
//! GPU and window tests need a wgpu adapter (Mesa's lavapipe in CI). Without one, plain
//! `cargo test --workspace` prints that they were skipped and why; with
//! `SKELETRACE_REQUIRE_GPU=1` (set by `scripts/test`, hence CI) they fail instead.

use std::sync::{Mutex, MutexGuard, OnceLock, PoisonError};

use skeletrace_render::GpuRenderer;

/// Whether a missing adapter must fail the GPU tests (`SKELETRACE_REQUIRE_GPU=1`).
#[must_use]
pub fn gpu_required() -> bool {
    std::env::var("SKELETRACE_REQUIRE_GPU").is_ok_and(|v| v == "1")
}

/// One renderer per test binary: one device, and every pipeline built once for all the tests
/// (building them is most of a small test's time on lavapipe). Or why there is none.
fn shared_renderer() -> &'static Result<Mutex<GpuRenderer>, String> {
    static RENDERER: OnceLock<Result<Mutex<GpuRenderer>, String>> = OnceLock::new();
    RENDERER.get_or_init(|| {
        GpuRenderer::new()
            .map(Mutex::new)
            .map_err(|e| e.to_string())
    })
}

/// Why no adapter could be opened; `None` when there is one.
fn missing_adapter() -> Option<&'static str> {
    shared_renderer().as_ref().err().map(String::as_str)
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

/// The test binary's GPU renderer, held by test `name` until the guard drops (the tests that
/// use it run one at a time), or `None` (after printing why) when it must be skipped. A test
/// that changes the renderer's settings restores them.
///
/// # Panics
/// As [`skip_without_gpu`].
#[must_use]
pub fn gpu_or_skip(name: &str) -> Option<MutexGuard<'static, GpuRenderer>> {
    if skip_without_gpu(name) {
        return None;
    }
    let renderer = shared_renderer().as_ref().ok()?;
    // A test that panicked while holding it leaves a renderer that still works.
    Some(renderer.lock().unwrap_or_else(PoisonError::into_inner))
}
