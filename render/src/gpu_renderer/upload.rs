//! Uploading a compiled scene (only the primitives an edit changed), its globals and method
//! constants, and the statistics rays' candidate lists.

use super::*;

impl SceneBuffers {
    /// The trace constants of the scene and the settings; the camera, frame and shading fields
    /// are left for the caller.
    /// The buffer of a frame's constants (binding 0, `FrameConstants` in shared/scene.wgsl):
    /// `globals`, then the scene's blend parameters.
    pub(super) fn frame_constants(
        &self,
        device: &wgpu::Device,
        label: &str,
        globals: &GpuGlobals,
    ) -> wgpu::Buffer {
        let mut bytes = bytemuck::bytes_of(globals).to_vec();
        bytes.extend_from_slice(bytemuck::cast_slice(&self.packed.blend_parameters));
        // The struct's size rounds up to its alignment (Globals' 16 bytes), which wgpu asks of
        // the binding.
        bytes.resize(bytes.len().next_multiple_of(16), 0);
        device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents: &bytes,
            usage: wgpu::BufferUsages::STORAGE,
        })
    }

    pub(super) fn globals(&self, settings: &TraceSettings, steps_per_dispatch: u32) -> GpuGlobals {
        GpuGlobals {
            origin: [0.0; 3],
            far: 0.0,
            forward: [0.0; 3],
            tan_half_fov: 0.0,
            right: [0.0; 3],
            aspect: 1.0,
            up: [0.0; 3],
            isovalue: self.isovalue,
            width: 0,
            height: 1,
            tiles_x: 0,
            tiles_y: 0,
            primitive_count: self.packed.primitives.len() as u32,
            group_count: self.packed.kernels.len() as u32,
            max_steps: settings.max_steps,
            epsilon: settings.epsilon as f32,
            min_step: settings.min_step as f32,
            growth: settings.growth as f32,
            initial_interval: settings.initial_interval.min(f64::from(f32::MAX)) as f32,
            lipschitz: self.method.lipschitz,
            gauss_sigma: self.method.gauss_sigma,
            gauss_radius: self.method.gauss_radius,
            gauss_norm: self.method.gauss_norm,
            tile_size: TILE,
            light_count: self.packed.lights.len() as u32,
            panel_x: 0,
            output_width: 0,
            heat_max: 1.0,
            heat_view: 0,
            shading_flags: 0,
            shading_scale: 1.0,
            steps_per_dispatch,
            secondary: 0,
            stats_crossings: 0,
            bvh_unbounded: self.packed.bvh.unbounded,
            bvh_items: self.packed.bvh.items.len() as u32,
            band_near: 0.0,
            band_width: f32::MAX,
            list_bands: 1,
            loop_probe: LOOP_PROBE,
        }
    }
}

impl MethodConstants {
    pub(super) fn of(program: &FieldProgram) -> Self {
        let sigma = match program.common_kernel() {
            Some(skeletrace_core::model::kernel::Kernel::Gaussian { scale }) => scale,
            _ => 1.0,
        };
        let (mut radius, mut norm) = (f64::INFINITY, 1.0);
        for p in program.primitives() {
            if let Primitive::Point(b) = p {
                radius = radius.min(b.radius);
                norm = b.norm;
            }
        }
        Self {
            lipschitz: program.global_lipschitz() as f32,
            gauss_sigma: sigma as f32,
            gauss_radius: if radius.is_finite() {
                radius as f32
            } else {
                1.0
            },
            gauss_norm: norm as f32,
        }
    }
}

/// An uninitialised buffer of `size` bytes.
pub(super) fn buffer_of(
    device: &wgpu::Device,
    label: &str,
    size: u64,
    usage: wgpu::BufferUsages,
) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size,
        usage,
        mapped_at_creation: false,
    })
}

impl GpuRenderer {
    /// Uploads a compiled scene; when only some primitives changed since the last upload (same
    /// count), only the changed range is written.
    ///
    /// # Errors
    /// [`BackendError::Unsupported`] for what the GPU backend does not handle in this scene,
    /// [`BackendError::DeviceFailed`] on a GPU error.
    pub fn set_scene(&mut self, compiled: &Arc<Compiled>) -> Result<(), BackendError> {
        let program = &compiled.program;
        let packed = PackedScene::new(compiled).map_err(BackendError::Unsupported)?;
        // The pipelines hold the blend tree's structure (blend_wgsl.rs; its parameters are
        // uploaded) and the code of the scene's primitive kinds (shared.rs KindSet): a tree of
        // another shape or a new kind needs new ones.
        if self
            .scene
            .as_ref()
            .is_some_and(|old| old.packed.blend != packed.blend || old.packed.kinds != packed.kinds)
        {
            self.trace_pipelines.clear();
            self.ray_pipelines.clear();
        }
        let method = MethodConstants::of(program);
        let isovalue = program.isovalue() as f32;
        if let Some(old) = &mut self.scene
            && old.packed.primitives.len() == packed.primitives.len()
            && old.packed.kernels.len() == packed.kernels.len()
            && old.packed.materials.len() == packed.materials.len()
            && old.packed.lights.len() == packed.lights.len()
            && old.packed.boxes.len() == packed.boxes.len()
            && old.packed.bvh.nodes.len() == packed.bvh.nodes.len()
            && old.packed.bvh.items.len() == packed.bvh.items.len()
            && old.packed.blend_parameters.len() == packed.blend_parameters.len()
        {
            let changed: Vec<usize> = (0..packed.primitives.len())
                .filter(|&i| old.packed.primitives[i] != packed.primitives[i])
                .collect();
            if let (Some(&first), Some(&last)) = (changed.first(), changed.last()) {
                let bytes = bytemuck::cast_slice(&packed.primitives[first..=last]);
                let offset = (first * std::mem::size_of::<GpuPrimitive>()) as u64;
                self.queue.write_buffer(&old.primitives, offset, bytes);
                self.uploaded_bytes += bytes.len() as u64;
            }
            self.queue
                .write_buffer(&old.kernels, 0, bytemuck::cast_slice(&packed.kernels));
            self.queue
                .write_buffer(&old.materials, 0, bytemuck::cast_slice(&packed.materials));
            self.queue
                .write_buffer(&old.lights, 0, bytemuck::cast_slice(&packed.lights));
            self.queue
                .write_buffer(&old.boxes, 0, bytemuck::cast_slice(&packed.boxes));
            if old.packed.bvh != packed.bvh {
                old.point_walk_bound = OnceLock::new();
                let (nodes, items) = (&packed.bvh.nodes, &packed.bvh.items);
                self.queue
                    .write_buffer(&old.bvh_nodes, 0, bytemuck::cast_slice(nodes));
                self.queue
                    .write_buffer(&old.bvh_items, 0, bytemuck::cast_slice(items));
            }
            old.packed = packed;
            old.method = method;
            old.isovalue = isovalue;
            old.compiled = Arc::clone(compiled);
            return self.check().map_err(BackendError::DeviceFailed);
        }
        let d = &self.device;
        let primitive_bytes: &[u8] = bytemuck::cast_slice(&packed.primitives);
        self.uploaded_bytes += primitive_bytes.len() as u64;
        self.scene = Some(SceneBuffers {
            primitives: storage(d, "primitives", primitive_bytes),
            kernels: storage(d, "kernels", bytemuck::cast_slice(&packed.kernels)),
            materials: storage(d, "materials", bytemuck::cast_slice(&packed.materials)),
            lights: storage(d, "lights", bytemuck::cast_slice(&packed.lights)),
            boxes: storage(d, "HRBF boxes", bytemuck::cast_slice(&packed.boxes)),
            bvh_nodes: storage(d, "BVH nodes", bytemuck::cast_slice(&packed.bvh.nodes)),
            bvh_items: storage(d, "BVH items", bytemuck::cast_slice(&packed.bvh.items)),
            point_walk_bound: OnceLock::new(),
            compiled: Arc::clone(compiled),
            packed,
            method,
            isovalue,
        });
        self.check().map_err(BackendError::DeviceFailed)
    }

    /// `lists` in storage buffers, for every batch of [`GpuRenderer::trace_rays`].
    #[must_use]
    pub fn upload_ray_lists(&self, lists: &RayLists) -> UploadedRayLists {
        let d = &self.device;
        UploadedRayLists {
            ranges: storage(d, "ray list ranges", bytemuck::cast_slice(&lists.ranges)),
            items: storage(d, "ray list items", bytemuck::cast_slice(&lists.items)),
        }
    }
}
