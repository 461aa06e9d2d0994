//! Cross-crate tests of skeletrace; the tests themselves live in `tests/tests/`. This library
//! holds what they share: whether the GPU tests run here.
//!
//! GPU and window tests need a wgpu adapter (Mesa's lavapipe in CI). Without one, plain
//! `cargo test --workspace` prints that they were skipped and why; with
//! `SKELETRACE_REQUIRE_GPU=1` (set by `scripts/test`, hence CI) they fail instead.

use std::sync::OnceLock;

use skeletrace_render::GpuRenderer;

/// Whether a missing adapter must fail the GPU tests (`SKELETRACE_REQUIRE_GPU=1`).
#[must_use]
pub fn gpu_required() -> bool {
    std::env::var("SKELETRACE_REQUIRE_GPU").is_ok_and(|v| v == "1")
}

/// Why no adapter could be opened, found once per test binary; `None` when there is one.
fn missing_adapter() -> Option<&'static str> {
    static MISSING: OnceLock<Option<String>> = OnceLock::new();
    MISSING
        .get_or_init(|| GpuRenderer::new().err().map(|e| e.to_string()))
        .as_deref()
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

/// A GPU renderer for test `name`, or `None` (after printing why) when it must be skipped.
///
/// # Panics
/// When the adapter exists but the renderer fails, or as [`skip_without_gpu`].
#[must_use]
pub fn gpu_or_skip(name: &str) -> Option<GpuRenderer> {
    if skip_without_gpu(name) {
        return None;
    }
    Some(GpuRenderer::new().unwrap_or_else(|e| panic!("{name}: {e}")))
}
