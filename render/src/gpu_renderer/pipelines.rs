//! The trace pipelines of a scene's methods: compiled in place, or on threads of their own
//! while the window shows the scene traced on the CPU.

use super::*;

/// The trace shader's `entry` pipeline of the WGSL `source`, counted in `compiled`, through
/// the persistent `cache` where there is one.
pub(super) fn trace_pipeline(
    device: &wgpu::Device,
    (compiled, cache): (&AtomicU64, Option<&crate::pipeline_cache::PersistentCache>),
    source: &str,
    entry: &str,
) -> wgpu::ComputePipeline {
    compiled.fetch_add(1, Ordering::Relaxed);
    cached_pipeline(device, source, entry, cache.map(|c| c.cache()))
}

impl PendingPipeline {
    pub(super) fn is_for(&self, scene: &PackedScene) -> bool {
        self.blend == scene.blend && self.kinds == scene.kinds
    }
}

impl GpuRenderer {
    /// The uploaded scene, after checking that `methods` and `view` apply to it
    /// ([`check_method`]: the scene, the settings' profile, the limits; the shading budget);
    /// builds the methods' pipelines.
    pub(super) fn ready_for(
        &mut self,
        methods: &[GpuMethod],
        view: View,
        settings: &TraceSettings,
    ) -> Result<Arc<Compiled>, BackendError> {
        let compiled = self
            .scene
            .as_ref()
            .map(|s| Arc::clone(&s.compiled))
            .ok_or_else(|| BackendError::Unsupported("no scene uploaded".to_owned()))?;
        for &m in methods {
            check_method(&compiled, m, settings).map_err(BackendError::Unsupported)?;
        }
        if let View::Shaded(shading) = view {
            self.check_shading_budget(&compiled, shading)
                .map_err(BackendError::Unsupported)?;
        }
        let mut new_pipelines = false;
        if let Some(scene) = &self.scene {
            for &m in methods {
                if self.trace_pipelines.contains_key(&m) {
                    continue;
                }
                // One compiled in the background for this scene is waited for, not compiled
                // again.
                let background = self
                    .pending_pipelines
                    .remove(&m)
                    .filter(|p| p.is_for(&scene.packed))
                    .and_then(|p| p.compiled.join().ok());
                let compiled = background.unwrap_or_else(|| {
                    trace_pipeline(
                        &self.device,
                        (&self.pipelines_compiled, self.pipeline_cache.as_deref()),
                        &m.source(&scene.packed.blend, scene.packed.kinds),
                        "trace_pixels",
                    )
                });
                self.trace_pipelines.insert(m, compiled);
                new_pipelines = true;
            }
        }
        if new_pipelines {
            self.save_pipeline_cache();
        }
        Ok(compiled)
    }

    /// Whether the trace pipelines of `methods` for the uploaded scene are still being
    /// compiled, each on a thread of its own: starts those not started (the driver takes
    /// seconds per pipeline, `bench`'s first frame, which the editor's window must not wait
    /// for) and keeps those done. A frame encoded before this answers `false` waits for the
    /// rest ([`GpuRenderer::encode_frame`]). One compiles per method at a time: a pipeline
    /// started for an earlier blend tree or set of primitive kinds (a driver's compilation
    /// cannot be cancelled) is left to finish and dropped before this scene's starts, so that
    /// a run of structural edits does not queue one compilation per edit.
    pub fn pipelines_compiling(&mut self, methods: &[GpuMethod]) -> bool {
        let Some(scene) = &self.scene else {
            return false;
        };
        let (mut compiling, mut done_now) = (false, false);
        for &m in methods {
            if self.trace_pipelines.contains_key(&m) {
                continue;
            }
            match self.pending_pipelines.remove(&m) {
                Some(p) if !p.compiled.is_finished() => {
                    self.pending_pipelines.insert(m, p);
                    compiling = true;
                }
                Some(p) if p.is_for(&scene.packed) => {
                    // A thread that panicked leaves the pipeline to the frame, which compiles
                    // it and reports the error as any other.
                    if let Ok(done) = p.compiled.join() {
                        self.trace_pipelines.insert(m, done);
                        done_now = true;
                    }
                }
                // None started, or one for an earlier scene, done: this scene's starts.
                _ => {
                    let device = self.device.clone();
                    let count = Arc::clone(&self.pipelines_compiled);
                    let cache = self.pipeline_cache.clone();
                    let source = m.source(&scene.packed.blend, scene.packed.kinds);
                    let compiled = std::thread::spawn(move || {
                        trace_pipeline(&device, (&count, cache.as_deref()), &source, "trace_pixels")
                    });
                    self.pending_pipelines.insert(
                        m,
                        PendingPipeline {
                            blend: scene.packed.blend.clone(),
                            kinds: scene.packed.kinds,
                            compiled,
                        },
                    );
                    compiling = true;
                }
            }
        }
        if done_now {
            self.save_pipeline_cache();
        }
        compiling
    }
}
