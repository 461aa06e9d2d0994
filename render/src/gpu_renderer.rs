//! Headless GPU rendering: device set-up, scene upload (re-uploading only what changed), tile
//! binning, one trace pass per method into one side-by-side frame, readback into core
//! [`Frame`]s (through output buffers kept while the frame size holds), and each pass's GPU
//! time from timestamp queries where the adapter has them ([`PassTimes`]). wgpu errors and a
//! lost device are reported as `Err`, never as a panic; callers fall back to the CPU tracer.

use std::collections::HashMap;
use std::sync::{Arc, Mutex, OnceLock};

use bytemuck::{Pod, Zeroable};
use rayon::prelude::*;
use skeletrace_core::FieldProgram;
use skeletrace_core::backend::{BackendError, DeviceKind, PassTimes};
use skeletrace_core::compile::Compiled;
use skeletrace_core::field::primitives::Primitive;
use skeletrace_core::frame::MAX_BOUNCES;
use skeletrace_core::frame::{
    AO_SAMPLES, FieldShading, Frame, SOFT_SHADOW_STEPS, View, far_distance, shading_scale,
};
use skeletrace_core::methods::TraceSettings;
use skeletrace_core::model::scene::Camera;
use wgpu::util::DeviceExt;

use crate::blend_wgsl::BlendWgsl;
use crate::buffers::{GpuMaterial, GpuPrimitive, PackedScene};
use crate::ray_bvh::RayBvh;
use crate::ray_lists::{GpuStatsRay, RayCrossings, RayLists, UploadedRayLists};
use crate::shaders::GpuMethod;
use crate::shared::{DEPTH_BANDS, KindSet, PATH_BYTES, STATS_ROW, SUSPENSION_BYTES, secondary};
use crate::tile_binning::{FrameGeometry, TILE, TileBinning};
use crate::wgpu_util::{entry, f3, map_for_reading, pipeline, read_back, storage, timestamps_at};

/// Steps a marching method takes per ray in one dispatch on a GPU (parts.wgsl): the 2 048-step
/// budget in eight dispatches, none of them long (the scalis 2021 paper bounds sphere tracing
/// to 256 steps per subinterval too).
pub const STEPS_PER_DISPATCH: u32 = 256;

/// Steps per dispatch on a CPU adapter. Lavapipe stops an invocation's loops after 65 535
/// iterations in all; a step loops over a window of up to 64 supports, and a SCALIS segment's
/// value over its quadrature nodes, so 256 steps of sphere tracing on the tree run into the
/// limit, where 8 stay far below it.
pub const STEPS_PER_DISPATCH_CPU_ADAPTER: u32 = 8;

/// Iterations of the loop by which an invocation finds whether it passed lavapipe's loop limit
/// (main.wgsl `note_loop_limit`): a loop of 2 runs once past it.
pub const LOOP_PROBE: u32 = 2;

/// How a march's dispatches go between two checks of whether a ray is still marching
/// (`dispatch_marches`): batches of `first` dispatches, or with `doubling`, a first batch of
/// `first` and each later one twice the one before.
#[derive(Clone, Copy)]
struct Batches {
    first: u32,
    doubling: bool,
}

/// A CPU adapter's batches: 8 dispatches, then 16, 32, … Rays that finish early spare the rest
/// of the budget's dispatches; where some ray marches to the end of its budget (sphere tracing
/// along grazing rays), the checks are few (5 for the 256 dispatches of 2 048 steps), where one
/// every 8 dispatches made lavapipe's sphere-traced tree (40 × 40) twice as slow.
const SOFTWARE_BATCHES: Batches = Batches {
    first: 8,
    doubling: true,
};

/// Most loop iterations the field shading terms may take per pixel (every soft-shadow and
/// ambient-occlusion sample walks the scene's hierarchy, `RayBvh::point_walk_bound`): lavapipe
/// stops a shader invocation's loops after 65 535 iterations in all, and the march needs its
/// share.
pub const MAX_SHADING_VISITS: usize = 40_000;

/// Twin of `Globals` in prelude.wgsl (a layout test checks every field's offset).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct GpuGlobals {
    /// Eye.
    pub origin: [f32; 3],
    /// Length of the primary rays.
    pub far: f32,
    /// Camera axes and frustum.
    pub forward: [f32; 3],
    /// `tan(fov/2)`.
    pub tan_half_fov: f32,
    /// Right axis.
    pub right: [f32; 3],
    /// Width / height.
    pub aspect: f32,
    /// Up axis.
    pub up: [f32; 3],
    /// Isovalue `c`.
    pub isovalue: f32,
    /// Panel width in pixels.
    pub width: u32,
    /// Panel height in pixels.
    pub height: u32,
    /// Tiles across.
    pub tiles_x: u32,
    /// Tiles down.
    pub tiles_y: u32,
    /// Primitives uploaded.
    pub primitive_count: u32,
    /// Groups.
    pub group_count: u32,
    /// Step budget per ray.
    pub max_steps: u32,
    /// Trace settings (`TraceSettings`).
    pub epsilon: f32,
    /// Minimum step.
    pub min_step: f32,
    /// Interval growth factor.
    pub growth: f32,
    /// First interval of each support part.
    pub initial_interval: f32,
    /// Global Lipschitz bound (sphere tracing).
    pub lipschitz: f32,
    /// Field inversion: Gaussian σ.
    pub gauss_sigma: f32,
    /// Field inversion: smallest blob radius.
    pub gauss_radius: f32,
    /// Field inversion: point normalisation.
    pub gauss_norm: f32,
    /// Tile edge in pixels.
    pub tile_size: u32,
    /// Lights uploaded.
    pub light_count: u32,
    /// x offset of this method's panel in the output.
    pub panel_x: u32,
    /// Output width (all panels).
    pub output_width: u32,
    /// Top of the step scale of the heat view.
    pub heat_max: f32,
    /// 0 shaded, 1 step heat map.
    pub heat_view: u32,
    /// 1 soft shadows, 2 ambient occlusion.
    pub shading_flags: u32,
    /// Scale of the field shading distances.
    pub shading_scale: f32,
    /// Steps a marching method takes per ray in one dispatch.
    pub steps_per_dispatch: u32,
    /// Secondary rays of the frame ([`crate::shared::secondary`]).
    pub secondary: u32,
    /// Transparent statistics: crossing slots per ray (0 in frames and opaque statistics).
    pub stats_crossings: u32,
    /// Where the unbounded primitives start in the hierarchy's items ([`RayBvh::unbounded`]).
    pub bvh_unbounded: u32,
    /// The hierarchy's items.
    pub bvh_items: u32,
    /// Depth bands of the tile lists ([`FrameGeometry::band_near`]).
    pub band_near: f32,
    /// Depth of each band past the first.
    pub band_width: f32,
    /// Lists per tile in `tile_ranges`: [`DEPTH_BANDS`] in frames, 1 for the statistics
    /// rays' lists.
    pub list_bands: u32,
    /// [`LOOP_PROBE`].
    pub loop_probe: u32,
}

/// The uploaded scene.
struct SceneBuffers {
    /// The compiled scene the buffers were packed from.
    compiled: Arc<Compiled>,
    packed: PackedScene,
    primitives: wgpu::Buffer,
    kernels: wgpu::Buffer,
    materials: wgpu::Buffer,
    lights: wgpu::Buffer,
    boxes: wgpu::Buffer,
    bvh_nodes: wgpu::Buffer,
    bvh_items: wgpu::Buffer,
    /// [`RayBvh::point_walk_bound`] of `packed.bvh`, computed when a frame's field shading
    /// first needs it.
    point_walk_bound: OnceLock<usize>,
    /// Per-method constants of the scene.
    method: MethodConstants,
    isovalue: f32,
}

impl SceneBuffers {
    /// The trace uniforms of the scene and the settings; the camera, frame and shading fields
    /// are left for the caller.
    fn globals(&self, settings: &TraceSettings, steps_per_dispatch: u32) -> GpuGlobals {
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

/// Constants some methods need of a scene, computed once per upload.
#[derive(Clone, Copy, Debug)]
struct MethodConstants {
    /// Global Lipschitz bound (sphere tracing).
    lipschitz: f32,
    /// Field inversion: Gaussian σ, smallest blob radius, point normalisation.
    gauss_sigma: f32,
    gauss_radius: f32,
    gauss_norm: f32,
}

/// A trace pipeline compiled on a thread of its own, for the blend tree and primitive kinds
/// of the scene it was asked for.
struct PendingPipeline {
    blend: BlendWgsl,
    kinds: KindSet,
    compiled: std::thread::JoinHandle<wgpu::ComputePipeline>,
}

impl PendingPipeline {
    fn is_for(&self, scene: &PackedScene) -> bool {
        self.blend == scene.blend && self.kinds == scene.kinds
    }
}

/// A GPU device with the pipelines built so far and the current scene.
pub struct GpuRenderer {
    device: wgpu::Device,
    queue: wgpu::Queue,
    adapter: String,
    graphics_api: wgpu::Backend,
    device_kind: DeviceKind,
    errors: Arc<Mutex<Vec<String>>>,
    binning: TileBinning,
    trace_pipelines: HashMap<GpuMethod, wgpu::ComputePipeline>,
    /// Trace pipelines being compiled on threads of their own
    /// ([`GpuRenderer::pipelines_compiling`]).
    pending_pipelines: HashMap<GpuMethod, PendingPipeline>,
    /// The same shaders' `trace_rays` entry (`stats --backend gpu`).
    ray_pipelines: HashMap<GpuMethod, wgpu::ComputePipeline>,
    scene: Option<SceneBuffers>,
    /// Primitive uploads in bytes, for the tests of partial re-upload.
    uploaded_bytes: u64,
    /// Whether the device writes pass timestamps (`Features::TIMESTAMP_QUERY`).
    timestamps: bool,
    /// The GPU's own time for the passes of the last [`GpuRenderer::render`].
    last_pass_times: Option<PassTimes>,
    /// Output and readback buffers of the last frame size, reused while the size holds.
    outputs: Option<OutputBuffers>,
    /// Steps a marching method takes per ray in one dispatch ([`STEPS_PER_DISPATCH`],
    /// [`STEPS_PER_DISPATCH_CPU_ADAPTER`]).
    steps_per_dispatch: u32,
    /// (primitive, tile) pairs in the tile lists of the last frame.
    last_tile_items: u64,
}

/// Per-pixel outputs of the trace passes and their `MAP_READ` copies.
struct OutputBuffers {
    /// Pixels of one panel, and panels side by side.
    size: (u64, u32),
    /// Written by the trace passes: packed sRGB8 colour, depth, steps.
    written: [wgpu::Buffer; 3],
    /// Mapped after each frame.
    read: [wgpu::Buffer; 3],
    /// One `Suspension` per pixel of a panel, cleared before each method.
    suspensions: wgpu::Buffer,
    /// One `Path` per pixel of a panel once a frame of this size had secondary rays (one
    /// `Path` before: the trace pass binds it either way), cleared before each method.
    paths: wgpu::Buffer,
    /// Whether `paths` holds one `Path` per pixel.
    paths_per_pixel: bool,
    /// The paths a dispatch left unfinished (main.wgsl `unfinished_paths`) and its `MAP_READ`
    /// copy.
    unfinished: [wgpu::Buffer; 2],
}

impl OutputBuffers {
    fn new(device: &wgpu::Device, (panel_pixels, panels): (u64, u32)) -> Self {
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
    fn paths_for_every_pixel(&mut self, device: &wgpu::Device) -> Result<(), String> {
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

/// An uninitialised buffer of `size` bytes.
fn buffer_of(
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

/// A buffer of `n` `Path`s (main.wgsl).
fn paths_buffer(device: &wgpu::Device, n: u64) -> wgpu::Buffer {
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
fn secondary_rays(packed: &PackedScene, shadows: bool, view: View) -> (u32, u32) {
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

impl MethodConstants {
    fn of(program: &FieldProgram) -> Self {
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

/// What the renderer asks of a device: the adapter's own limits (the trace passes bind more
/// storage buffers than wgpu's defaults allow) and pass timestamps where the adapter has them.
/// The editor opens eframe's device with it, so that the viewport can trace on that device.
#[must_use]
pub fn device_descriptor(adapter: &wgpu::Adapter) -> wgpu::DeviceDescriptor<'static> {
    let timestamps = adapter.features().contains(wgpu::Features::TIMESTAMP_QUERY);
    wgpu::DeviceDescriptor {
        label: Some("skeletrace"),
        required_features: if timestamps {
            wgpu::Features::TIMESTAMP_QUERY
        } else {
            wgpu::Features::empty()
        },
        required_limits: adapter.limits(),
        ..Default::default()
    }
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
    fn on_instance(descriptor: wgpu::InstanceDescriptor) -> Result<Self, BackendError> {
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
        };
        renderer.check().map_err(BackendError::DeviceFailed)?;
        Ok(renderer)
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

    fn check(&self) -> Result<(), String> {
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

    /// Uploads a compiled scene; when only some primitives changed since the last upload (same
    /// count), only the changed range is written.
    ///
    /// # Errors
    /// [`BackendError::Unsupported`] for what the GPU backend does not handle in this scene,
    /// [`BackendError::DeviceFailed`] on a GPU error.
    pub fn set_scene(&mut self, compiled: &Arc<Compiled>) -> Result<(), BackendError> {
        let program = &compiled.program;
        let packed = PackedScene::new(compiled).map_err(BackendError::Unsupported)?;
        // The pipelines hold the blend tree's code (blend_wgsl.rs) and the code of the scene's
        // primitive kinds (shared.rs KindSet): a new tree or a new kind needs new ones.
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
    fn dispatch_rays(
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
        let pipeline = self
            .ray_pipelines
            .entry(method)
            .or_insert_with(|| {
                pipeline(
                    d,
                    &method.source(&scene.packed.blend, scene.packed.kinds),
                    "trace_rays",
                )
            })
            .clone();
        let n = rays.len() as u32;
        let globals = GpuGlobals {
            width: n,
            stats_crossings: slots,
            ..scene.globals(settings, self.steps_per_dispatch)
        };
        let globals = d.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("ray globals"),
            contents: bytemuck::bytes_of(&globals),
            usage: wgpu::BufferUsages::UNIFORM,
        });
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

    /// Renders `methods` side by side (`width × height` each) through `camera` on the uploaded
    /// scene; one frame per method. With `shadows`, the shaded view casts exact shadow rays
    /// towards every light (core `RenderOptions::shadows`); transparent groups reflect and
    /// refract in either view (main.wgsl `trace_path`).
    ///
    /// # Errors
    /// [`BackendError::Unsupported`] when no scene is uploaded, or a method or the field shading
    /// does not apply to it; [`BackendError::DeviceFailed`] on a GPU error.
    pub fn render(
        &mut self,
        methods: &[GpuMethod],
        camera: &Camera,
        settings: &TraceSettings,
        (width, height): (u32, u32),
        (view, shadows): (View, bool),
    ) -> Result<Vec<Frame>, BackendError> {
        let compiled = self.ready_for(methods, view, settings)?;
        let geometry = FrameGeometry::new(camera, width, height)
            .with_depth_bands(&compiled.program.support_bounds());
        self.trace_frames(
            &compiled.program,
            methods,
            &geometry,
            settings,
            (view, shadows),
        )
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
        methods: &[GpuMethod],
        camera: &Camera,
        settings: &TraceSettings,
        (width, height): (u32, u32),
        (view, shadows): (View, bool),
    ) -> Result<(), BackendError> {
        let compiled = self.ready_for(methods, view, settings)?;
        let geometry = FrameGeometry::new(camera, width, height)
            .with_depth_bands(&compiled.program.support_bounds());
        self.encode_trace(
            encoder,
            &compiled.program,
            methods,
            &geometry,
            settings,
            (view, shadows),
            (None, false),
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

    /// The device the renderer traces on.
    #[must_use]
    pub fn device(&self) -> &wgpu::Device {
        &self.device
    }

    /// The uploaded scene, after checking that `methods` and `view` apply to it and that the
    /// methods follow the settings' profile ([`GpuMethod::follows`]); builds the
    /// methods' pipelines.
    fn ready_for(
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
        let program = &compiled.program;
        for m in methods {
            m.follows(settings.protocol)
                .map_err(BackendError::Unsupported)?;
        }
        for m in methods {
            m.supports(program).map_err(BackendError::Unsupported)?;
        }
        if let View::Shaded(shading) = view {
            self.check_shading_budget(&compiled, shading)
                .map_err(BackendError::Unsupported)?;
        }
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
                    pipeline(
                        &self.device,
                        &m.source(&scene.packed.blend, scene.packed.kinds),
                        "trace_pixels",
                    )
                });
                self.trace_pipelines.insert(m, compiled);
            }
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
    /// a slider dragged over a blend's width or Ricci exponent, which are in the shader's code,
    /// does not start one compilation per value it passes.
    pub fn pipelines_compiling(&mut self, methods: &[GpuMethod]) -> bool {
        let Some(scene) = &self.scene else {
            return false;
        };
        let mut compiling = false;
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
                    }
                }
                // None started, or one for an earlier scene, done: this scene's starts.
                _ => {
                    let device = self.device.clone();
                    let source = m.source(&scene.packed.blend, scene.packed.kinds);
                    let compiled =
                        std::thread::spawn(move || pipeline(&device, &source, "trace_pixels"));
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
        compiling
    }

    /// Fills the tile lists, runs one trace pass per method (each marching method in
    /// dispatches of `steps_per_dispatch` steps) and reads the panels back as frames.
    fn trace_frames(
        &mut self,
        program: &FieldProgram,
        methods: &[GpuMethod],
        geometry: &FrameGeometry,
        settings: &TraceSettings,
        look: (View, bool),
    ) -> Result<Vec<Frame>, String> {
        // Timestamps: count pass, fill pass, then one trace pass per method (begin and end each);
        // none for frames with secondary rays, whose passes are submitted in batches.
        let passes = 2 + methods.len() as u32;
        let secondary = self
            .scene
            .as_ref()
            .is_some_and(|scene| secondary_rays(&scene.packed, look.1, look.0).0 != 0);
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
        self.encode_trace(
            &mut encoder,
            program,
            methods,
            geometry,
            settings,
            look,
            (queries.as_ref(), true),
        )?;
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
    #[expect(
        clippy::too_many_arguments,
        reason = "the frame's encoder, scene, methods, geometry, settings and options all differ per call"
    )]
    fn encode_trace(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        program: &FieldProgram,
        methods: &[GpuMethod],
        geometry: &FrameGeometry,
        settings: &TraceSettings,
        (view, shadows): (View, bool),
        (queries, wait): (Option<&wgpu::QuerySet>, bool),
    ) -> Result<(), String> {
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
            let globals = d.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("globals"),
                contents: bytemuck::bytes_of(&globals),
                usage: wgpu::BufferUsages::UNIFORM,
            });
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

/// The flag a dispatch sets when it leaves a ray marching and the count of invocations past
/// lavapipe's loop limit (main.wgsl `unfinished_paths`), and their `MAP_READ` copy.
fn unfinished_flag(device: &wgpu::Device) -> [wgpu::Buffer; 2] {
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
fn dispatch_marches(
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

/// Splits the mapped side-by-side outputs (packed sRGB8 colour, depth, steps; `panels` frames
/// of `width × height` in a row) into one [`Frame`] per panel, a row at a time in parallel.
fn split_panels(mapped: [&[u8]; 3], (w, h): (usize, usize), panels: usize) -> Vec<Frame> {
    let colour: &[u32] = bytemuck::cast_slice(mapped[0]);
    let depth: &[f32] = bytemuck::cast_slice(mapped[1]);
    let steps: &[u32] = bytemuck::cast_slice(mapped[2]);
    (0..panels)
        .map(|panel| {
            let row = |y: usize| (y * panels + panel) * w..;
            let mut frame = Frame {
                width: w,
                height: h,
                colour: vec![[0.0; 3]; w * h],
                depth: vec![0.0; w * h],
                steps: vec![0; w * h],
            };
            frame
                .colour
                .par_chunks_mut(w)
                .zip(frame.depth.par_chunks_mut(w))
                .zip(frame.steps.par_chunks_mut(w))
                .enumerate()
                .for_each(|(y, ((c, z), s))| {
                    let at = row(y);
                    for (to, &from) in c.iter_mut().zip(&colour[at.clone()]) {
                        *to = linear_from_packed(from);
                    }
                    for (to, &from) in z.iter_mut().zip(&depth[at.clone()]) {
                        *to = if from >= 3.0e38 {
                            f64::INFINITY
                        } else {
                            f64::from(from)
                        };
                    }
                    s.copy_from_slice(&steps[at][..w]);
                });
            frame
        })
        .collect()
}

/// Pass durations from `[begin, end]` timestamp pairs (count, fill, then one per trace pass) in
/// ticks of `period_ns` nanoseconds.
fn pass_times(stamps: &[u64], period_ns: f64) -> PassTimes {
    let ms = |pass: usize| {
        let (begin, end) = (stamps[2 * pass], stamps[2 * pass + 1]);
        end.saturating_sub(begin) as f64 * period_ns * 1e-6
    };
    PassTimes {
        binning_ms: ms(0) + ms(1),
        trace_ms: (2..stamps.len() / 2).map(ms).collect(),
    }
}

/// sRGB8 packed colour to linear RGB (the inverse of the shader's encoding), through a table
/// of the 256 channel values: a 2048² frame has 12 million channels.
fn linear_from_packed(c: u32) -> [f32; 3] {
    static LINEAR: std::sync::LazyLock<[f32; 256]> = std::sync::LazyLock::new(|| {
        std::array::from_fn(|i| {
            let s = i as f32 / 255.0;
            if s <= 0.04045 {
                s / 12.92
            } else {
                ((s + 0.055) / 1.055).powf(2.4)
            }
        })
    });
    let channel = |shift: u32| LINEAR[((c >> shift) & 0xff) as usize];
    [channel(0), channel(8), channel(16)]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pass_times_pair_the_timestamps_count_fill_then_one_per_method() {
        // Ticks of 2 ns: count 0→5, fill 5→15, two trace passes 20→520 and 600→1600.
        let times = pass_times(&[0, 5, 5, 15, 20, 520, 600, 1600], 2.0);
        assert!((times.binning_ms - 30e-6).abs() < 1e-12, "{times:?}");
        assert_eq!(times.trace_ms.len(), 2);
        assert!((times.trace_ms[0] - 1e-3).abs() < 1e-12, "{times:?}");
        assert!((times.trace_ms[1] - 2e-3).abs() < 1e-12, "{times:?}");
        // A timestamp that went backwards (some drivers reset the counter) reads as 0.
        assert_eq!(pass_times(&[0, 0, 0, 0, 9, 3], 1.0).trace_ms, vec![0.0]);
    }
}
