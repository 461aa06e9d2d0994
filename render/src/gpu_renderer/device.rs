//! Opening the device (its limits, the adapter's kind) and the renderer's settings and
//! accessors; the shading budget a software adapter's loop limit sets.

use super::*;

/// What the renderer asks of a device: the adapter's own limits (the trace passes bind more
/// storage buffers than wgpu's defaults allow), pass timestamps and a pipeline cache
/// ([`crate::pipeline_cache`]) where the adapter has them. The editor opens eframe's device
/// with it, so that the viewport can trace on that device.
#[must_use]
pub fn device_descriptor(adapter: &wgpu::Adapter) -> wgpu::DeviceDescriptor<'static> {
    let wanted = wgpu::Features::TIMESTAMP_QUERY | wgpu::Features::PIPELINE_CACHE;
    wgpu::DeviceDescriptor {
        label: Some("skeletrace"),
        required_features: adapter.features() & wanted,
        required_limits: adapter.limits(),
        ..Default::default()
    }
}

/// `Err` when the field shading terms could take more than [`MAX_SHADING_VISITS`] loop
/// iterations at a pixel (on a software adapter): each soft-shadow and ambient-occlusion sample walks the scene's
/// hierarchy, `point_walk_bound()` iterations at most.
///
/// # Errors
/// The counts, and the advice to use the CPU.
pub(crate) fn check_shading_walks(
    compiled: &Compiled,
    shading: FieldShading,
    point_walk_bound: impl FnOnce() -> usize,
) -> Result<(), String> {
    let samples = if shading.soft_shadows {
        SOFT_SHADOW_STEPS as usize * compiled.lights.len()
    } else {
        0
    } + if shading.ambient_occlusion {
        AO_SAMPLES as usize
    } else {
        0
    };
    if samples == 0 {
        return Ok(());
    }
    let walk = point_walk_bound();
    if samples * walk > MAX_SHADING_VISITS {
        return Err(format!(
            "soft shadows and ambient occlusion on the GPU walk the scene's primitives at each \
             sample: up to {walk} loop iterations × {samples} samples is over the \
             {MAX_SHADING_VISITS} a pixel may take on a software adapter (lavapipe's loop \
             limit); use the CPU backend for this scene"
        ));
    }
    Ok(())
}

impl GpuRenderer {
    /// Opens the first GPU adapter (any backend wgpu was built with: Vulkan, including Mesa's
    /// lavapipe).
    ///
    /// # Errors
    /// No adapter, or no device.
    pub fn new() -> Result<Self, BackendError> {
        Self::on_instance(wgpu::InstanceDescriptor::new_without_display_handle_from_env())
    }

    /// Opens the first adapter of wgpu's OpenGL backend (Mesa's llvmpipe through EGL on a
    /// machine without a GPU): what wgpu falls back to where there is no Vulkan loader, and a
    /// second shader compiler (naga's GLSL, then the driver's) that the tests hold to the CPU
    /// too — it once dropped a store that Vulkan kept (docs/gpu.md).
    ///
    /// # Errors
    /// No OpenGL adapter, or no device.
    pub fn new_on_opengl() -> Result<Self, BackendError> {
        let mut descriptor = wgpu::InstanceDescriptor::new_without_display_handle();
        descriptor.backends = wgpu::Backends::GL;
        Self::on_instance(descriptor)
    }

    /// Opens the first adapter of an instance made with `descriptor`.
    pub(super) fn on_instance(descriptor: wgpu::InstanceDescriptor) -> Result<Self, BackendError> {
        let instance = wgpu::Instance::new(descriptor);
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            force_fallback_adapter: false,
            compatible_surface: None,
            apply_limit_buckets: false,
        }))
        .map_err(|e| BackendError::DeviceFailed(format!("no GPU adapter: {e}")))?;
        let info = adapter.get_info();
        let (device, queue) = pollster::block_on(
            adapter.request_device(&device_descriptor(&adapter)),
        )
        .map_err(|e| {
            BackendError::DeviceFailed(format!("GPU adapter '{}' gave no device: {e}", info.name))
        })?;
        Self::with_device(device, queue, &info)
    }

    /// A renderer on a device opened elsewhere (the editor shares eframe's, opened with
    /// [`device_descriptor`]), with the adapter's
    /// `info` (name, and whether it is a software rasteriser).
    ///
    /// # Errors
    /// [`BackendError::DeviceFailed`] when the binning pipelines do not build.
    pub fn with_device(
        device: wgpu::Device,
        queue: wgpu::Queue,
        info: &wgpu::AdapterInfo,
    ) -> Result<Self, BackendError> {
        let cpu_adapter = info.device_type == wgpu::DeviceType::Cpu;
        let timestamps = device.features().contains(wgpu::Features::TIMESTAMP_QUERY);
        let errors = Arc::new(Mutex::new(Vec::new()));
        let sink = Arc::clone(&errors);
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            if let Ok(mut v) = sink.lock() {
                v.push(match e {
                    wgpu::Error::Validation {
                        description,
                        source,
                    } => {
                        format!("{description}: {source:?}")
                    }
                    other => other.to_string(),
                });
            }
        }));
        let lost = Arc::clone(&errors);
        device.set_device_lost_callback(move |reason, message| {
            if let Ok(mut v) = lost.lock() {
                v.push(format!("device lost ({reason:?}): {message}"));
            }
        });
        let binning = TileBinning::new(&device, cpu_adapter);
        let renderer = Self {
            device,
            queue,
            adapter: format!("{} ({:?}, {:?})", info.name, info.backend, info.device_type),
            graphics_api: info.backend,
            device_kind: if cpu_adapter {
                DeviceKind::SoftwareGpu
            } else {
                DeviceKind::HardwareGpu
            },
            errors,
            binning,
            trace_pipelines: HashMap::new(),
            pending_pipelines: HashMap::new(),
            ray_pipelines: HashMap::new(),
            scene: None,
            uploaded_bytes: 0,
            timestamps,
            last_pass_times: None,
            outputs: None,
            steps_per_dispatch: if cpu_adapter {
                STEPS_PER_DISPATCH_CPU_ADAPTER
            } else {
                STEPS_PER_DISPATCH
            },
            last_tile_items: 0,
            pipelines_compiled: Arc::new(AtomicU64::new(0)),
            adapter_info: info.clone(),
            pipeline_cache: None,
        };
        let mut renderer = renderer;
        renderer.set_pipeline_cache_dir(crate::pipeline_cache::default_dir().as_deref());
        renderer.check().map_err(BackendError::DeviceFailed)?;
        Ok(renderer)
    }

    /// Keeps the compiled pipelines in `dir` from now on (`None`: nowhere), starting from the
    /// cache file there for this adapter and driver where there is a valid one
    /// ([`crate::pipeline_cache`]). Pipelines compiled before keep working.
    pub fn set_pipeline_cache_dir(&mut self, dir: Option<&std::path::Path>) {
        self.pipeline_cache = dir.and_then(|dir| {
            crate::pipeline_cache::PersistentCache::open(&self.device, &self.adapter_info, dir)
                .map(Arc::new)
        });
    }

    /// The persistent pipeline cache, where the device has one.
    #[must_use]
    pub fn pipeline_cache(&self) -> Option<&crate::pipeline_cache::PersistentCache> {
        self.pipeline_cache.as_deref()
    }

    /// Writes the pipeline cache to its file after new pipelines compiled; a failure is
    /// reported on standard error (the pipelines themselves are fine).
    pub(super) fn save_pipeline_cache(&self) {
        if let Some(cache) = &self.pipeline_cache
            && let Err(why) = cache.save()
        {
            eprintln!(
                "skeletrace: cannot keep the pipeline cache {}: {why}",
                cache.path().display()
            );
        }
    }

    /// Adapter name, backend and type.
    #[must_use]
    pub fn adapter_name(&self) -> &str {
        &self.adapter
    }

    /// The graphics API the adapter runs on (Vulkan, OpenGL, Metal, DirectX 12).
    #[must_use]
    pub fn graphics_api(&self) -> wgpu::Backend {
        self.graphics_api
    }

    /// Whether the adapter is a hardware GPU or a software rasteriser (from the adapter's own
    /// device type, not its name).
    #[must_use]
    pub fn device_kind(&self) -> DeviceKind {
        self.device_kind
    }

    /// The device the renderer traces on.
    #[must_use]
    pub fn device(&self) -> &wgpu::Device {
        &self.device
    }

    /// The uploaded scene's primitives as packed for the GPU (group transforms and repetition
    /// applied); none without a scene.
    #[must_use]
    pub fn packed_primitives(&self) -> &[GpuPrimitive] {
        self.scene
            .as_ref()
            .map_or(&[], |s| s.packed.primitives.as_slice())
    }

    /// On a software adapter, `Err` when `shading` on `compiled` could take more loop
    /// iterations at a pixel than [`MAX_SHADING_VISITS`] (lavapipe's limit): with the uploaded
    /// scene's hierarchy when `compiled` is the scene uploaded (its bound computed once), else
    /// with one built for `compiled`. A hardware GPU has no such limit: always `Ok`.
    ///
    /// # Errors
    /// The counts, and the advice to use the CPU.
    pub fn check_shading_budget(
        &self,
        compiled: &Compiled,
        shading: FieldShading,
    ) -> Result<(), String> {
        if self.device_kind == DeviceKind::HardwareGpu {
            return Ok(());
        }
        match &self.scene {
            Some(s) if std::ptr::eq(Arc::as_ptr(&s.compiled), compiled) => {
                check_shading_walks(compiled, shading, || {
                    *s.point_walk_bound
                        .get_or_init(|| s.packed.bvh.point_walk_bound())
                })
            }
            _ => check_shading_walks(compiled, shading, || {
                RayBvh::new(&compiled.program).point_walk_bound()
            }),
        }
    }

    /// The compiled scene uploaded last, if any.
    #[must_use]
    pub fn scene(&self) -> Option<&Arc<Compiled>> {
        self.scene.as_ref().map(|s| &s.compiled)
    }

    /// The GPU's own time for the passes of the last frame; `None` where the adapter has no
    /// timestamp queries, or before the first frame.
    #[must_use]
    pub fn last_pass_times(&self) -> Option<&PassTimes> {
        self.last_pass_times.as_ref()
    }

    /// Steps a marching method takes per ray in one dispatch.
    #[must_use]
    pub fn steps_per_dispatch(&self) -> u32 {
        self.steps_per_dispatch
    }

    /// Sets the steps a marching method takes per ray in one dispatch (at least 1; by default
    /// [`STEPS_PER_DISPATCH`], or [`STEPS_PER_DISPATCH_CPU_ADAPTER`] on a CPU adapter). Frames
    /// do not depend on it where no dispatch runs into an adapter's loop limit; the tests
    /// check that they do not.
    pub fn set_steps_per_dispatch(&mut self, steps: u32) {
        self.steps_per_dispatch = steps.max(1);
    }

    /// Turns the occluders of the tile binning on (the default) or off. Frames have the same
    /// hits and depths either way; step counts may differ where a march's interval reaches
    /// past the occluding depth.
    pub fn set_occluders(&mut self, on: bool) {
        self.binning.occluders = on;
    }

    /// Turns on (the default) or off the tile binning's test of point blob and SCALIS segment
    /// supports against each tile's beam of pixel rays. Either way a ray's window holds the
    /// same supports (those left out are ones its ray misses), so the frames are the same.
    pub fn set_hull_culling(&mut self, on: bool) {
        self.binning.hulls = on;
    }

    /// Trace pipelines compiled since the renderer was opened, in place or in the background
    /// (counted when their compilation starts). A pipeline depends on a scene's structure only
    /// (blend tree shape and operators, group count, primitive kinds) and on the method: an
    /// edit of a parameter compiles none.
    #[must_use]
    pub fn pipelines_compiled(&self) -> u64 {
        self.pipelines_compiled.load(Ordering::Relaxed)
    }

    /// (primitive, tile) pairs in the tile lists of the last frame.
    #[must_use]
    pub fn last_tile_items(&self) -> u64 {
        self.last_tile_items
    }

    /// Tile edge in pixels of the next frames' binning: 4, doubled for good (up to 64) each
    /// time a frame's lists do not fit in one storage binding.
    #[must_use]
    pub fn tile_edge(&self) -> u32 {
        self.binning.tile()
    }

    /// Keeps the tile lists under `bytes` (at most the device's binding limit), as a device
    /// with less memory would; the tiles start again from 4 pixels (`u64::MAX`: the device's
    /// limit again).
    pub fn limit_tile_lists(&mut self, bytes: u64) {
        self.binning.limit_lists(&self.device, bytes);
    }

    /// Bytes of primitive data uploaded so far.
    #[must_use]
    pub fn uploaded_primitive_bytes(&self) -> u64 {
        self.uploaded_bytes
    }

    pub(super) fn check(&self) -> Result<(), String> {
        let mut errors = self.errors.lock().map_err(|e| e.to_string())?;
        if errors.is_empty() {
            Ok(())
        } else {
            Err(format!(
                "GPU error: {}",
                errors.drain(..).collect::<Vec<_>>().join("; ")
            ))
        }
    }
}
