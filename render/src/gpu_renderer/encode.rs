//! Encoding a frame: tile binning, one trace pass per method into the side-by-side output
//! buffers, suspended marches resumed dispatch after dispatch, and the statistics rays.

use super::*;

impl OutputBuffers {
    pub(super) fn new(device: &wgpu::Device, (panel_pixels, panels): (u64, u32)) -> Self {
        let pixels = panel_pixels * u64::from(panels);
        let buffer = |label: &str, usage: wgpu::BufferUsages| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: pixels * 4,
                usage,
                mapped_at_creation: false,
            })
        };
        let written = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC;
        let read = wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST;
        Self {
            written: [
                buffer("colour", written),
                buffer("depth", written),
                buffer("steps", written),
            ],
            read: [
                buffer("colour readback", read),
                buffer("depth readback", read),
                buffer("steps readback", read),
            ],
            suspensions: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("suspended marches"),
                size: panel_pixels * SUSPENSION_BYTES,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            paths: paths_buffer(device, 1),
            paths_per_pixel: false,
            unfinished: unfinished_flag(device),
            size: (panel_pixels, panels),
        }
    }

    /// Grows `paths` to one `Path` per pixel of a panel.
    ///
    /// # Errors
    /// When that exceeds what the device can bind.
    pub(super) fn paths_for_every_pixel(&mut self, device: &wgpu::Device) -> Result<(), String> {
        if self.paths_per_pixel {
            return Ok(());
        }
        let bytes = self.size.0 * PATH_BYTES;
        let limit = device.limits().max_storage_buffer_binding_size;
        if bytes > limit {
            return Err(format!(
                "shadow rays and transparency on the GPU keep {PATH_BYTES} bytes per pixel: \
                 {} pixels need {bytes} bytes, more than the device binds ({limit}); render \
                 smaller or on the CPU",
                self.size.0
            ));
        }
        self.paths = paths_buffer(device, self.size.0);
        self.paths_per_pixel = true;
        Ok(())
    }
}

/// A buffer of `n` `Path`s (main.wgsl).
pub(super) fn paths_buffer(device: &wgpu::Device, n: u64) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("secondary ray paths"),
        size: n * PATH_BYTES,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

/// The secondary rays of a frame ([`crate::shared::secondary`]) and the most rays one
/// pixel's path can trace: with transparent groups, every crossing up to [`MAX_BOUNCES`]
/// levels splits into a reflected and a refracted ray; with shadow rays, each of those rays'
/// hits adds one per light.
pub(super) fn secondary_rays(packed: &PackedScene, shadows: bool, view: View) -> (u32, u32) {
    let transparent = packed.materials.iter().any(GpuMaterial::transparent);
    let shadow_rays = shadows && matches!(view, View::Shaded(_)) && !packed.lights.is_empty();
    if !transparent && !shadow_rays {
        return (0, 1);
    }
    let traced = if transparent {
        (1 << (MAX_BOUNCES + 1)) - 1
    } else {
        1
    };
    let per_hit = 1 + if shadow_rays {
        packed.lights.len() as u32
    } else {
        0
    };
    let flags = secondary::PATHS
        | if shadow_rays {
            secondary::SHADOW_RAYS
        } else {
            0
        };
    (flags, traced * per_hit)
}

/// The flag a dispatch sets when it leaves a ray marching and the count of invocations past
/// lavapipe's loop limit (main.wgsl `unfinished_paths`), and their `MAP_READ` copy.
pub(super) fn unfinished_flag(device: &wgpu::Device) -> [wgpu::Buffer; 2] {
    [
        buffer_of(
            device,
            "unfinished paths",
            8,
            wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::COPY_SRC
                | wgpu::BufferUsages::COPY_DST,
        ),
        buffer_of(
            device,
            "unfinished paths readback",
            8,
            wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        ),
    ]
}

/// Records the `dispatches` dispatches of a march (`workgroups` each) of `pipeline` with
/// `group` into `encoder`, in one pass with `timestamps` (the query set and the pass's index).
///
/// With `batches` (their lengths, and the flag main.wgsl `unfinished_paths` sets with its
/// readback copy) it stops once every ray has finished: the dispatches go in batches, each
/// submitted and read back for whether its last dispatch left a ray (or a path of secondary
/// rays) unfinished, until none did, and the timestamps span the batches. The outputs are the
/// same: a finished ray's dispatches return at once. A software adapter's frames and
/// statistics take [`SOFTWARE_BATCHES`], where the host waits for them
/// anyway: a dispatch costs milliseconds there even once every ray has finished (lavapipe:
/// about 14 ms at 128 × 128), and a march's budget is many dispatches
/// ([`STEPS_PER_DISPATCH_CPU_ADAPTER`]).
///
/// With `batches`, the march is also checked for lavapipe's loop limit (main.wgsl
/// `note_loop_limit`), even when it takes a single batch.
///
/// # Errors
/// The readback's, and an invocation past lavapipe's loop limit, whose rays were cut short.
pub(super) fn dispatch_marches(
    (device, queue, encoder): (&wgpu::Device, &wgpu::Queue, &mut wgpu::CommandEncoder),
    (pipeline, group, label): (&wgpu::ComputePipeline, &wgpu::BindGroup, &str),
    (workgroups, dispatches): ((u32, u32), u32),
    batches: Option<(Batches, &[wgpu::Buffer; 2])>,
    timestamps: Option<(&wgpu::QuerySet, u32)>,
) -> Result<(), String> {
    let (queries, index) = timestamps.map_or((None, 0), |(q, index)| (Some(q), index));
    let pass = |encoder: &mut wgpu::CommandEncoder, count: u32, stamps: (bool, bool)| {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some(label),
            timestamp_writes: timestamps_at(queries, index, stamps),
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, group, &[]);
        for _ in 0..count {
            pass.dispatch_workgroups(workgroups.0, workgroups.1, 1);
        }
    };
    let Some((batches, [flag, read])) = batches else {
        pass(encoder, dispatches, (true, true));
        return Ok(());
    };
    encoder.clear_buffer(flag, 4, Some(4));
    let mut done = 0;
    let mut next = batches.first;
    while done < dispatches {
        let batch = next.min(dispatches - done);
        if batches.doubling {
            next = next.saturating_mul(2);
        }
        if batch > 1 {
            pass(encoder, batch - 1, (done == 0, false));
        }
        encoder.clear_buffer(flag, 0, Some(4));
        pass(encoder, 1, (done == 0 && batch == 1, true));
        done += batch;
        encoder.copy_buffer_to_buffer(flag, 0, read, 0, 8);
        let recorded = std::mem::replace(
            encoder,
            device.create_command_encoder(&wgpu::CommandEncoderDescriptor::default()),
        );
        queue.submit([recorded.finish()]);
        let flags = read_back::<u32>(device, read)?;
        if let Some(&passed) = flags.get(1).filter(|&&passed| passed != 0) {
            return Err(format!(
                "{label}: {passed} shader invocation(s) passed the software adapter's loop \
                 limit (Mesa's llvmpipe stops an invocation's loops after 65 535 iterations in \
                 all), so some rays were cut short; trace this scene on the CPU (--backend cpu)"
            ));
        }
        if flags.first() == Some(&0) {
            break;
        }
    }
    Ok(())
}

/// How a frame's passes are submitted: with timestamp queries where the device has them, and
/// whether the binning is submitted and waited for before the trace passes are recorded.
#[derive(Clone, Copy)]
pub(super) struct Submission<'a> {
    pub queries: Option<&'a wgpu::QuerySet>,
    pub wait: bool,
}

/// The camera's geometry of `request`'s frame, its depth bands over `compiled`'s supports.
fn frame_geometry(compiled: &Compiled, request: &FrameRequest) -> FrameGeometry {
    FrameGeometry::new(&request.camera, request.width as u32, request.height as u32)
        .with_depth_bands(&compiled.program.support_bounds())
}

impl GpuRenderer {
    /// Renders the methods of `request` side by side (`width × height` each) through its
    /// camera on the uploaded scene; one frame per method. With `shadows`, the shaded view
    /// casts exact shadow rays towards every light (core `RenderOptions::shadows`); transparent
    /// groups reflect and refract in either view (main.wgsl `trace_path`).
    ///
    /// # Errors
    /// [`BackendError::Unsupported`] when no scene is uploaded, or a method or the field shading
    /// does not apply to it; [`BackendError::DeviceFailed`] on a GPU error.
    pub fn render(&mut self, request: &FrameRequest) -> Result<Vec<Frame>, BackendError> {
        let methods = gpu_methods(&request.methods)?;
        let compiled = self.ready_for(&methods, request.view, &request.settings)?;
        let geometry = frame_geometry(&compiled, request);
        self.trace_frames(&compiled.program, &methods, &geometry, request)
            .map_err(BackendError::DeviceFailed)
    }

    /// Records the trace of `methods` (side by side) through `camera` into `encoder` without
    /// reading anything back or waiting for the GPU: the frame stays in the output buffers
    /// ([`GpuRenderer::output_buffers`]), which the editor's viewport draws from directly.
    /// Whether its tile lists fitted is known a frame or two later
    /// ([`GpuRenderer::poll_tile_lists`]).
    ///
    /// # Errors
    /// As [`GpuRenderer::render`].
    pub fn encode_frame(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        request: &FrameRequest,
    ) -> Result<(), BackendError> {
        let methods = gpu_methods(&request.methods)?;
        let compiled = self.ready_for(&methods, request.view, &request.settings)?;
        let geometry = frame_geometry(&compiled, request);
        let unwaited = Submission {
            queries: None,
            wait: false,
        };
        self.encode_trace(
            encoder,
            &compiled.program,
            &methods,
            &geometry,
            request,
            unwaited,
        )
        .map_err(BackendError::DeviceFailed)
    }

    /// Checks the tile lists of the frames encoded without waiting (call once per frame, after
    /// polling the device, with the frame's encoder); whether the latest frame's lists were cut
    /// short, so that it must be traced again (the items have grown).
    ///
    /// # Errors
    /// Lists larger than the device can bind.
    pub fn poll_tile_lists(&mut self, encoder: &mut wgpu::CommandEncoder) -> Result<bool, String> {
        self.binning.poll_overflow(&self.device, encoder)
    }

    /// Whether the tile lists of some frame encoded without waiting are still to be checked
    /// (keep polling).
    #[must_use]
    pub fn tile_lists_unchecked(&self) -> bool {
        self.binning.unchecked()
    }

    /// The colour output (packed sRGB8) and step counts of the last frame traced or encoded,
    /// panels side by side: pixel `x, y` of panel `p` of `n` is at `(y·n + p)·width + x`.
    #[must_use]
    pub fn output_buffers(&self) -> Option<(&wgpu::Buffer, &wgpu::Buffer)> {
        self.outputs
            .as_ref()
            .map(|o| (&o.written[0], &o.written[2]))
    }

    /// Fills the tile lists, runs one trace pass per method (each marching method in
    /// dispatches of `steps_per_dispatch` steps) and reads the panels back as frames.
    pub(super) fn trace_frames(
        &mut self,
        program: &FieldProgram,
        methods: &[GpuMethod],
        geometry: &FrameGeometry,
        request: &FrameRequest,
    ) -> Result<Vec<Frame>, String> {
        // Timestamps: count pass, fill pass, then one trace pass per method (begin and end each);
        // none for frames with secondary rays, whose passes are submitted in batches.
        let passes = 2 + methods.len() as u32;
        let secondary = self.scene.as_ref().is_some_and(|scene| {
            secondary_rays(&scene.packed, request.shadows, request.view).0 != 0
        });
        let queries = (self.timestamps && !secondary).then(|| {
            self.device.create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("pass timestamps"),
                ty: wgpu::QueryType::Timestamp,
                count: 2 * passes,
            })
        });
        let mut encoder = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor::default());
        let waited = Submission {
            queries: queries.as_ref(),
            wait: true,
        };
        self.encode_trace(&mut encoder, program, methods, geometry, request, waited)?;
        let d = &self.device;
        let (width, height) = (geometry.width, geometry.height);
        let pixels = u64::from(width * methods.len() as u32) * u64::from(height);
        let outputs = self.outputs.as_ref().ok_or("no output buffers")?;
        for (source, target) in outputs.written.iter().zip(&outputs.read) {
            encoder.copy_buffer_to_buffer(source, 0, target, 0, pixels * 4);
        }
        let stamps_read = queries.as_ref().map(|query_set| {
            let bytes = u64::from(2 * passes) * wgpu::QUERY_SIZE as u64;
            let resolved = d.create_buffer(&wgpu::BufferDescriptor {
                label: Some("pass timestamps"),
                size: bytes,
                usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            });
            encoder.resolve_query_set(query_set, 0..2 * passes, &resolved, 0);
            let target = d.create_buffer(&wgpu::BufferDescriptor {
                label: Some("pass timestamps readback"),
                size: bytes,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            encoder.copy_buffer_to_buffer(&resolved, 0, &target, 0, bytes);
            target
        });
        self.queue.submit([encoder.finish()]);
        // Mapped, then unmapped on every path, the failing ones included.
        let frames = map_for_reading(d, &outputs.read.iter().collect::<Vec<_>>())
            .and_then(|()| {
                outputs
                    .read
                    .iter()
                    .map(|b| b.slice(..).get_mapped_range())
                    .collect::<Result<Vec<_>, _>>()
                    .map_err(|e| format!("GPU readback failed: {e}"))
            })
            .map(|views| {
                split_panels(
                    [&views[0], &views[1], &views[2]],
                    (width as usize, height as usize),
                    methods.len(),
                )
            });
        for buffer in &outputs.read {
            buffer.unmap();
        }
        let frames = frames?;
        let period_ns = f64::from(self.queue.get_timestamp_period());
        self.last_pass_times = stamps_read
            .map(|buffer| read_back::<u64>(d, &buffer).map(|t| pass_times(&t, period_ns)))
            .transpose()?;
        self.check()?;
        Ok(frames)
    }

    /// Bins the primitives into the tile lists and records one trace pass per method into
    /// `encoder`, writing the output buffers (panels side by side). With `wait`, the binning is
    /// submitted first and its total read back, so the lists are whole (a frame read back
    /// waits anyway); without, nothing waits ([`GpuRenderer::poll_tile_lists`]).
    pub(super) fn encode_trace(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        program: &FieldProgram,
        methods: &[GpuMethod],
        geometry: &FrameGeometry,
        request: &FrameRequest,
        Submission { queries, wait }: Submission<'_>,
    ) -> Result<(), String> {
        let (settings, view, shadows) = (&request.settings, request.view, request.shadows);
        let scene = self.scene.as_ref().ok_or("no scene uploaded")?;
        let n_prims = scene.packed.primitives.len() as u32;
        let (tile_lists, total, geometry) = self.binning.encode_lists(
            &self.device,
            &self.queue,
            (!wait).then_some(&mut *encoder),
            &scene.primitives,
            n_prims,
            geometry,
            queries,
        )?;
        self.check()?;
        if let Some(total) = total {
            self.last_tile_items = total;
        }
        // Borrowed again: `check` and the tile count above needed `self` in between.
        let scene = self.scene.as_ref().ok_or("no scene uploaded")?;
        let FrameGeometry {
            origin,
            forward,
            right,
            up,
            tan_half,
            aspect,
            width,
            height,
            tiles_x,
            tiles_y,
            tile,
            camera,
            band_near,
            band_width,
        } = geometry;
        let d = &self.device;
        let panels = methods.len() as u32;
        let out_width = width * panels;
        let size = (u64::from(width) * u64::from(height), panels);
        if self.outputs.as_ref().is_none_or(|o| o.size != size) {
            self.outputs = Some(OutputBuffers::new(d, size));
        }
        let (secondary, rays_per_path) = secondary_rays(&scene.packed, shadows, view);
        let outputs = self.outputs.as_mut().ok_or("no output buffers")?;
        if secondary != 0 {
            outputs.paths_for_every_pixel(d)?;
        }
        let outputs = &*outputs;
        let [colour, depth, steps] = &outputs.written;
        let far = far_distance(program, &camera);
        let (heat_max, heat_view, shading) = match view {
            View::Shaded(shading) => (1.0, 0, shading),
            View::Steps { steps_max } => (steps_max as f32, 1, FieldShading::default()),
        };
        let shading_flags =
            u32::from(shading.soft_shadows) | (u32::from(shading.ambient_occlusion) << 1);
        self.binning.fill(d, encoder, &tile_lists, queries)?;
        let items = self.binning.items();
        for (panel, method) in methods.iter().enumerate() {
            let globals = GpuGlobals {
                origin: f3(origin),
                far: far as f32,
                forward: f3(forward),
                tan_half_fov: tan_half as f32,
                right: f3(right),
                aspect: aspect as f32,
                up: f3(up),
                width,
                height,
                tiles_x,
                tiles_y,
                tile_size: tile,
                panel_x: width * panel as u32,
                output_width: out_width,
                heat_max,
                heat_view,
                shading_flags,
                shading_scale: shading_scale(program) as f32,
                secondary,
                band_near: band_near as f32,
                band_width: band_width as f32,
                list_bands: DEPTH_BANDS,
                ..scene.globals(settings, self.steps_per_dispatch)
            };
            let globals = scene.frame_constants(d, "frame constants", &globals);
            let pipeline = &self.trace_pipelines[method];
            let group = d.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some(method.name()),
                layout: &pipeline.get_bind_group_layout(0),
                entries: &[
                    entry(0, &globals),
                    entry(1, &scene.primitives),
                    entry(2, &scene.kernels),
                    entry(3, &scene.materials),
                    entry(4, &scene.lights),
                    entry(5, &tile_lists.ranges),
                    entry(6, items),
                    entry(7, colour),
                    entry(8, depth),
                    entry(9, steps),
                    entry(10, &outputs.suspensions),
                    entry(12, &scene.boxes),
                    entry(13, &outputs.paths),
                    entry(14, &outputs.unfinished[0]),
                    entry(15, &scene.bvh_nodes),
                    entry(16, &scene.bvh_items),
                ],
            });
            // A marching method goes on from where each ray stopped until every budget is spent;
            // a path of secondary rays finishes at most one ray per dispatch, each ray taking
            // one dispatch more than its steps need (the one that ends it).
            let per_ray = if method.resumable() {
                settings.max_steps.div_ceil(self.steps_per_dispatch).max(1)
            } else {
                1
            };
            let dispatches = if secondary == 0 {
                per_ray
            } else {
                rays_per_path * (per_ray + 1)
            };
            encoder.clear_buffer(&outputs.suspensions, 0, None);
            let workgroups = (width.div_ceil(8), height.div_ceil(8));
            // Without secondary rays, a software adapter's frames stop dispatching once every
            // ray has finished; with them, every frame that is waited for stops once every path
            // has, checked after each ray's dispatches.
            let batches = if secondary == 0 {
                (self.device_kind == DeviceKind::SoftwareGpu && wait).then_some(SOFTWARE_BATCHES)
            } else {
                encoder.clear_buffer(&outputs.paths, 0, None);
                wait.then_some(Batches {
                    first: per_ray + 1,
                    doubling: false,
                })
            };
            dispatch_marches(
                (d, &self.queue, encoder),
                (pipeline, &group, method.name()),
                (workgroups, dispatches),
                batches.map(|batch| (batch, &outputs.unfinished)),
                queries.map(|q| (q, 2 + panel as u32)),
            )?;
        }
        Ok(())
    }

    /// Traces a batch of statistics rays with `method` on the uploaded scene
    /// (`stats --backend gpu`, [`crate::gpu_stats`]): each ray over `[0, far]` among the
    /// primitives of its list in `lists`. Returns each ray's steps and the parameter of its first
    /// crossing (infinite when it has none).
    ///
    /// # Errors
    /// As [`GpuRenderer::render`].
    pub fn trace_rays(
        &mut self,
        method: GpuMethod,
        rays: &[GpuStatsRay],
        lists: &UploadedRayLists,
        settings: &TraceSettings,
    ) -> Result<Vec<(u32, f64)>, BackendError> {
        let (steps, depth) = self.dispatch_rays(method, rays, lists, settings, 0)?;
        Ok(steps
            .into_iter()
            .zip(depth)
            .take(rays.len())
            .map(|(s, t)| {
                let t = if t >= 3.0e38 {
                    f64::INFINITY
                } else {
                    f64::from(t)
                };
                (s, t)
            })
            .collect())
    }

    /// [`GpuRenderer::trace_rays`] in transparent mode: every crossing of each ray, up to
    /// `slots` of them.
    ///
    /// # Errors
    /// As [`GpuRenderer::render`].
    pub fn trace_rays_through(
        &mut self,
        method: GpuMethod,
        rays: &[GpuStatsRay],
        lists: &UploadedRayLists,
        (settings, slots): (&TraceSettings, u32),
    ) -> Result<Vec<RayCrossings>, BackendError> {
        debug_assert!((1..=32).contains(&slots));
        let (words, depth) = self.dispatch_rays(method, rays, lists, settings, slots)?;
        Ok(words
            .chunks_exact(4)
            .zip(depth.chunks_exact(slots as usize))
            .take(rays.len())
            .map(|(w, t)| {
                let found = w[2];
                RayCrossings {
                    steps: w[0],
                    steps_to_last: w[1],
                    found,
                    kept: t
                        .iter()
                        .take(found.min(slots) as usize)
                        .enumerate()
                        .map(|(i, &t)| (f64::from(t), (w[3] >> i) & 1 == 1))
                        .collect(),
                }
            })
            .collect())
    }

    /// Dispatches `trace_rays` until every ray's budget is spent; returns the steps and depth
    /// buffers (one word and one depth per ray, or with `slots` crossing slots per ray the
    /// layout of main.wgsl `crossing_ends_march`).
    pub(super) fn dispatch_rays(
        &mut self,
        method: GpuMethod,
        rays: &[GpuStatsRay],
        lists: &UploadedRayLists,
        settings: &TraceSettings,
        slots: u32,
    ) -> Result<(Vec<u32>, Vec<f32>), BackendError> {
        self.ready_for(&[method], View::Steps { steps_max: 1 }, settings)?;
        let device = self.device.clone();
        let d = &device;
        let scene = self
            .scene
            .as_ref()
            .ok_or_else(|| BackendError::Unsupported("no scene uploaded".to_owned()))?;
        let new_pipeline = !self.ray_pipelines.contains_key(&method);
        let counted = (&*self.pipelines_compiled, self.pipeline_cache.as_deref());
        let pipeline = self
            .ray_pipelines
            .entry(method)
            .or_insert_with(|| {
                trace_pipeline(
                    d,
                    counted,
                    &method.source(&scene.packed.blend, scene.packed.kinds),
                    "trace_rays",
                )
            })
            .clone();
        if new_pipeline {
            self.save_pipeline_cache();
        }
        let n = rays.len() as u32;
        let globals = GpuGlobals {
            width: n,
            stats_crossings: slots,
            ..scene.globals(settings, self.steps_per_dispatch)
        };
        let globals = scene.frame_constants(d, "ray frame constants", &globals);
        let ray_buffer = storage(d, "statistics rays", bytemuck::cast_slice(rays));
        let output = |label: &str, per_ray: u32, usage: wgpu::BufferUsages| {
            d.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: u64::from(n.max(1)) * u64::from(per_ray) * 4,
                usage,
                mapped_at_creation: false,
            })
        };
        let written = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC;
        let read = wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST;
        let (step_words, depth_slots) = if slots == 0 { (1, 1) } else { (4, slots) };
        let (depth, steps) = (
            output("ray depth", depth_slots, written),
            output("ray steps", step_words, written),
        );
        let (depth_read, steps_read) = (
            output("ray depth readback", depth_slots, read),
            output("ray steps readback", step_words, read),
        );
        let suspensions = d.create_buffer(&wgpu::BufferDescriptor {
            label: Some("suspended rays"),
            size: u64::from(n.max(1)) * SUSPENSION_BYTES,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let unfinished = unfinished_flag(d);
        let group = d.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("statistics rays"),
            layout: &pipeline.get_bind_group_layout(0),
            entries: &[
                entry(0, &globals),
                entry(1, &scene.primitives),
                entry(2, &scene.kernels),
                entry(5, &lists.ranges),
                entry(6, &lists.items),
                entry(8, &depth),
                entry(9, &steps),
                entry(10, &suspensions),
                entry(11, &ray_buffer),
                entry(12, &scene.boxes),
                entry(14, &unfinished[0]),
                entry(15, &scene.bvh_nodes),
                entry(16, &scene.bvh_items),
            ],
        });
        let dispatches = if method.resumable() {
            settings.max_steps.div_ceil(self.steps_per_dispatch).max(1)
        } else {
            1
        };
        let groups = n.div_ceil(64).max(1);
        let mut encoder = d.create_command_encoder(&wgpu::CommandEncoderDescriptor::default());
        dispatch_marches(
            (d, &self.queue, &mut encoder),
            (&pipeline, &group, "statistics rays"),
            (
                (groups.min(STATS_ROW), groups.div_ceil(STATS_ROW)),
                dispatches,
            ),
            (self.device_kind == DeviceKind::SoftwareGpu)
                .then_some((SOFTWARE_BATCHES, &unfinished)),
            None,
        )
        .map_err(BackendError::DeviceFailed)?;
        encoder.copy_buffer_to_buffer(&depth, 0, &depth_read, 0, depth.size());
        encoder.copy_buffer_to_buffer(&steps, 0, &steps_read, 0, steps.size());
        self.queue.submit([encoder.finish()]);
        let depth: Vec<f32> = read_back(d, &depth_read).map_err(BackendError::DeviceFailed)?;
        let steps: Vec<u32> = read_back(d, &steps_read).map_err(BackendError::DeviceFailed)?;
        self.check().map_err(BackendError::DeviceFailed)?;
        Ok((steps, depth))
    }
}
