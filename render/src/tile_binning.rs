//! Screen-tile binning of primitive supports (binning.wgsl; the analogue of the scalis 2021
//! A-buffer, §7): its pipelines, and per frame the tile lists each ray's support window is
//! filled from. The occluding depths and counts per tile go in a first submission, read back
//! for the host's prefix sum; the lists are filled in the trace submission.

use bytemuck::{Pod, Zeroable};
use skeletrace_core::frame::PinholeCamera;
use skeletrace_core::model::scene::Camera;
use wgpu::util::DeviceExt;

use crate::gpu_renderer::{entry, f3, pipeline, read_back, storage, timestamp_writes};
use crate::shaders::binning_source;

/// Tile edge in pixels.
pub const TILE: u32 = 4;

/// Twin of `Binning` in binning.wgsl (a layout test checks every field's offset).
#[repr(C)]
#[derive(Clone, Copy, Debug, Pod, Zeroable)]
pub struct GpuBinning {
    /// Eye.
    pub origin: [f32; 3],
    /// Padding.
    pub pad0: f32,
    /// Forward axis.
    pub forward: [f32; 3],
    /// `tan(fov/2)`.
    pub tan_half_fov: f32,
    /// Right axis.
    pub right: [f32; 3],
    /// Width / height.
    pub aspect: f32,
    /// Up axis.
    pub up: [f32; 3],
    /// Padding.
    pub pad1: f32,
    /// Tiles across.
    pub tiles_x: u32,
    /// Tiles down.
    pub tiles_y: u32,
    /// Tile edge in pixels.
    pub tile_size: u32,
    /// Primitives uploaded.
    pub primitive_count: u32,
    /// Frame width in pixels.
    pub width: u32,
    /// Frame height in pixels.
    pub height: u32,
    /// 1: occluders on.
    pub occluders: u32,
    /// Padding.
    pub pad2: u32,
}

/// The camera's frame of one render, shared by the binning and trace uniforms.
#[derive(Clone, Copy)]
pub struct FrameGeometry {
    pub(crate) camera: Camera,
    pub(crate) origin: glam::DVec3,
    pub(crate) forward: glam::DVec3,
    pub(crate) right: glam::DVec3,
    pub(crate) up: glam::DVec3,
    pub(crate) tan_half: f64,
    pub(crate) aspect: f64,
    pub(crate) width: u32,
    pub(crate) height: u32,
    pub(crate) tiles_x: u32,
    pub(crate) tiles_y: u32,
}

impl FrameGeometry {
    /// The frame of `camera` at `width × height` pixels.
    pub fn new(camera: &Camera, width: u32, height: u32) -> Self {
        let (forward, right, up) = PinholeCamera::new(camera).axes();
        Self {
            camera: *camera,
            origin: glam::DVec3::from_array(camera.position),
            forward,
            right,
            up,
            tan_half: (0.5 * camera.fov_degrees.to_radians()).tan(),
            aspect: f64::from(width) / f64::from(height.max(1)),
            width,
            height,
            tiles_x: width.div_ceil(TILE),
            tiles_y: height.div_ceil(TILE),
        }
    }
}

/// One frame's tile lists (binning.wgsl): per-tile ranges into `items`, filled by
/// `fill_group` in the trace submission.
pub struct TileLists {
    pub(crate) counts: wgpu::Buffer,
    pub(crate) ranges: wgpu::Buffer,
    pub(crate) items: wgpu::Buffer,
    pub(crate) fill_group: wgpu::BindGroup,
    /// Binning workgroups: columns of 64 primitives × slices of their (primitive, tile) pairs.
    pub(crate) workgroups: (u32, u32),
    /// (primitive, tile) pairs in all lists.
    pub(crate) total: u32,
}

/// The binning pipelines and how they are dispatched.
pub struct TileBinning {
    occlude: wgpu::ComputePipeline,
    count: wgpu::ComputePipeline,
    fill: wgpu::ComputePipeline,
    /// Workgroups the binning passes aim for in all: enough to fill a GPU; few on a CPU
    /// adapter, where each workgroup's shared prefix sum costs real time.
    workgroups: u32,
    /// Whether binning leaves out primitives behind occluders (binning.wgsl).
    pub occluders: bool,
}

impl TileBinning {
    /// Builds the pipelines on `device`.
    pub fn new(device: &wgpu::Device, cpu_adapter: bool) -> Self {
        let source = binning_source();
        Self {
            occlude: pipeline(device, &source, "occlude_tiles"),
            count: pipeline(device, &source, "count_tiles"),
            fill: pipeline(device, &source, "fill_tiles"),
            workgroups: if cpu_adapter { 64 } else { 4096 },
            occluders: true,
        }
    }

    /// Bins the `n_prims` primitives' supports into the tiles of `geometry` (binning.wgsl): the
    /// occluding depths and counts per tile in a first submission, read back for the host's
    /// prefix sum; the lists are filled by the returned `fill_group` in the trace submission.
    pub fn bin(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        primitives: &wgpu::Buffer,
        n_prims: u32,
        geometry: &FrameGeometry,
        queries: Option<&wgpu::QuerySet>,
    ) -> Result<TileLists, String> {
        let d = device;
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
            ..
        } = *geometry;
        let tiles = (tiles_x * tiles_y) as usize;
        // Binning workgroups: one column per 64 primitives, as many slices of each column's
        // (primitive, tile) pairs as fill `binning_workgroups` (binning.wgsl).
        let columns = n_prims.div_ceil(64).max(1);
        let slices = (self.workgroups / columns).clamp(1, tiles as u32);
        // Pass 1: count supports per tile.
        let binning = d.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("binning"),
            contents: bytemuck::bytes_of(&GpuBinning {
                origin: f3(origin),
                pad0: 0.0,
                forward: f3(forward),
                tan_half_fov: tan_half as f32,
                right: f3(right),
                aspect: aspect as f32,
                up: f3(up),
                pad1: 0.0,
                tiles_x,
                tiles_y,
                tile_size: TILE,
                primitive_count: n_prims,
                width,
                height,
                occluders: u32::from(self.occluders),
                pad2: 0,
            }),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let counts = d.create_buffer(&wgpu::BufferDescriptor {
            label: Some("tile counts"),
            size: (tiles * 4) as u64,
            usage: wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::COPY_SRC
                | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let counts_read = d.create_buffer(&wgpu::BufferDescriptor {
            label: Some("tile counts readback"),
            size: (tiles * 4) as u64,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let rects = d.create_buffer(&wgpu::BufferDescriptor {
            label: Some("tile rectangles"),
            size: u64::from(n_prims.max(1)) * 16,
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        let occluded = d.create_buffer(&wgpu::BufferDescriptor {
            label: Some("occluding depths"),
            size: (tiles * 4) as u64,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let nearest = d.create_buffer(&wgpu::BufferDescriptor {
            label: Some("nearest reaches"),
            size: u64::from(n_prims.max(1)) * 4,
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        let occlude_group = d.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("occlude tiles"),
            layout: &self.occlude.get_bind_group_layout(0),
            entries: &[
                entry(0, &binning),
                entry(1, primitives),
                entry(6, &occluded),
            ],
        });
        let count_group = d.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("count tiles"),
            layout: &self.count.get_bind_group_layout(0),
            entries: &[
                entry(0, &binning),
                entry(1, primitives),
                entry(2, &counts),
                entry(5, &rects),
                entry(6, &occluded),
                entry(7, &nearest),
            ],
        });
        let mut encoder = d.create_command_encoder(&wgpu::CommandEncoderDescriptor::default());
        encoder.clear_buffer(&occluded, 0, None);
        {
            // The occluding depths, then the counts (binning.wgsl).
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("count tiles"),
                timestamp_writes: timestamp_writes(queries, 0),
            });
            pass.set_pipeline(&self.occlude);
            pass.set_bind_group(0, &occlude_group, &[]);
            pass.dispatch_workgroups(columns, slices, 1);
            pass.set_pipeline(&self.count);
            pass.set_bind_group(0, &count_group, &[]);
            pass.dispatch_workgroups(columns, slices, 1);
        }
        encoder.copy_buffer_to_buffer(&counts, 0, &counts_read, 0, (tiles * 4) as u64);
        queue.submit([encoder.finish()]);
        let tile_counts: Vec<u32> = read_back(d, &counts_read)?;
        let mut ranges = Vec::with_capacity(tiles);
        let mut total = 0u32;
        for &c in &tile_counts {
            ranges.push([total, total + c]);
            total += c;
        }

        // Pass 2: fill the tile lists, then trace every method.
        let ranges_buffer = storage(d, "tile ranges", bytemuck::cast_slice(&ranges));
        let items = d.create_buffer(&wgpu::BufferDescriptor {
            label: Some("tile items"),
            size: u64::from(total.max(1)) * 4,
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        let fill_group = d.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("fill tiles"),
            layout: &self.fill.get_bind_group_layout(0),
            entries: &[
                entry(0, &binning),
                entry(2, &counts),
                entry(3, &ranges_buffer),
                entry(4, &items),
                entry(5, &rects),
                entry(6, &occluded),
                entry(7, &nearest),
            ],
        });
        Ok(TileLists {
            counts,
            ranges: ranges_buffer,
            items,
            fill_group,
            workgroups: (columns, slices),
            total,
        })
    }

    /// Records the pass that fills `lists` (timestamps at index 1 of `queries`).
    pub fn fill(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        lists: &TileLists,
        queries: Option<&wgpu::QuerySet>,
    ) {
        encoder.clear_buffer(&lists.counts, 0, None);
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("fill tiles"),
            timestamp_writes: timestamp_writes(queries, 1),
        });
        pass.set_pipeline(&self.fill);
        pass.set_bind_group(0, &lists.fill_group, &[]);
        pass.dispatch_workgroups(lists.workgroups.0, lists.workgroups.1, 1);
    }
}
