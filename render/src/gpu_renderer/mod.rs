//! Headless GPU rendering: device set-up, scene upload (re-uploading only what changed), tile
//! binning, one trace pass per method into one side-by-side frame, readback into core
//! [`Frame`]s (through output buffers kept while the frame size holds), and each pass's GPU
//! time from timestamp queries where the adapter has them ([`PassTimes`]). wgpu errors and a
//! lost device are reported as `Err`, never as a panic; callers fall back to the CPU tracer.
//!
//! The renderer's state and GPU structs are here; its work is split by role: `device` (opening
//! the device, limits, settings), `upload` (scene and ray lists), `pipelines` (trace pipelines,
//! compiled in place or in the background), `encode` (binning and trace passes of a frame, the
//! statistics rays) and `readback` (frames and pass times back from the GPU).

use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, OnceLock};

use bytemuck::{Pod, Zeroable};
use rayon::prelude::*;
use skeletrace_core::FieldProgram;
use skeletrace_core::backend::{BackendError, DeviceKind, FrameRequest, PassTimes};
use skeletrace_core::compile::Compiled;
use skeletrace_core::field::primitives::Primitive;
use skeletrace_core::frame::MAX_BOUNCES;
use skeletrace_core::frame::{
    AO_SAMPLES, FieldShading, Frame, SOFT_SHADOW_STEPS, View, far_distance, shading_scale,
};
use skeletrace_core::methods::TraceSettings;
use wgpu::util::DeviceExt;

use crate::blend_wgsl::BlendWgsl;
use crate::buffers::{GpuMaterial, GpuPrimitive, PackedScene};
use crate::gpu_support::{check_method, gpu_methods};
use crate::ray_bvh::RayBvh;
use crate::ray_lists::{GpuStatsRay, RayCrossings, RayLists, UploadedRayLists};
use crate::shaders::GpuMethod;
use crate::shared::{DEPTH_BANDS, KindSet, PATH_BYTES, STATS_ROW, SUSPENSION_BYTES, secondary};
use crate::tile_binning::{FrameGeometry, TILE, TileBinning};
use crate::wgpu_util::{
    cached_pipeline, entry, f3, map_for_reading, read_back, storage, timestamps_at,
};

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

/// Twin of `Globals` in shared/scene.wgsl (a layout test checks every field's offset).
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
    /// [`GpuRenderer::pipelines_compiled`], shared with the background compilations.
    pipelines_compiled: Arc<AtomicU64>,
    /// The adapter, whose driver keys the pipeline cache's file.
    adapter_info: wgpu::AdapterInfo,
    /// Pipelines kept across runs ([`crate::pipeline_cache`]), where the device has a cache.
    pipeline_cache: Option<Arc<crate::pipeline_cache::PersistentCache>>,
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

mod device;
mod encode;
mod pipelines;
mod readback;
mod upload;

pub(crate) use device::check_shading_walks;
pub use device::device_descriptor;
use pipelines::trace_pipeline;
use readback::{pass_times, split_panels};
use upload::buffer_of;
