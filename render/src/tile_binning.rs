//! Screen-tile binning of primitive supports (binning.wgsl; the analogue of the scalis 2021
//! A-buffer, §7): its pipelines, and per frame the tile lists each ray's support window is
//! filled from. Occluding depths, counts, ranges (a prefix sum on the GPU) and lists are all
//! recorded into the frame's encoder. The items buffer keeps the size the largest frame so far
//! needed; a frame that needs more finds its lists cut short, and the host grows the buffer and
//! traces again: at once where the frame is read back anyway ([`TileBinning::encode_lists`]
//! with `wait`), a frame or two later on the editor's GPU viewport, which never waits
//! ([`TileBinning::poll_overflow`]). Lists too large for one storage binding are binned again
//! with wider tiles ([`MAX_TILE`]).

use bytemuck::{Pod, Zeroable};
use skeletrace_core::frame::PinholeCamera;
use skeletrace_core::model::scene::Camera;
use wgpu::util::DeviceExt;

use crate::async_readback::AsyncReadback;
use crate::shaders::binning_source;
use crate::shared::DEPTH_BANDS;
use crate::wgpu_util::{entry, f3, pipeline, read_back, timestamp_writes};

/// Tile edge in pixels, as long as the lists fit in one storage binding.
pub const TILE: u32 = 4;

/// The widest tile edge the binning falls back to, doubling from [`TILE`], when a frame's lists
/// do not fit in one storage binding (a dense scene at a large frame: the 500 000-segment foam
/// at 2048² needed 2.4 GB with 4-pixel tiles before the beam culling of binning.wgsl, which
/// keeps about a quarter of the pairs on smaller foams; wgpu binds at most 2 GB): wider tiles
/// make fewer (primitive, tile) pairs and longer lists per ray.
pub const MAX_TILE: u32 = 64;

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
    /// Where the first depth band ends ([`FrameGeometry::band_near`]).
    pub band_near: f32,
    /// Depth of each band past the first.
    pub band_width: f32,
    /// 1: a tile's lists leave out the supports its pixel rays' beam misses.
    pub hulls: u32,
    /// Padding.
    pub pad2: [u32; 2],
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
    /// Tile edge in pixels.
    pub(crate) tile: u32,
    /// The depth bands of the tile lists ([`DEPTH_BANDS`]): a primitive whose bounding sphere
    /// is nearer the eye than `band_near + band_width` is in the first band, one within the
    /// next `band_width` in the second, and so on, the last band taking the rest.
    pub(crate) band_near: f64,
    pub(crate) band_width: f64,
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
            tiles_x: 0,
            tiles_y: 0,
            tile: 0,
            band_near: 0.0,
            band_width: f64::from(f32::MAX),
        }
        .with_tile(TILE)
    }

    /// The same frame with depth bands spread evenly over the depths of `bounds` (the scene's
    /// bounded supports) as seen from the eye; one band holds everything where they are empty.
    #[must_use]
    pub fn with_depth_bands(self, bounds: &skeletrace_core::field::geometry::Aabb) -> Self {
        if bounds.is_empty() {
            return self;
        }
        let distance = (bounds.center() - self.origin).length();
        let radius = 0.5 * bounds.diagonal();
        let near = (distance - radius).max(0.0);
        let width = (distance + radius - near) / f64::from(DEPTH_BANDS);
        if !(width.is_finite() && width > 0.0) {
            return self;
        }
        Self {
            band_near: near + width,
            band_width: width,
            ..self
        }
    }

    /// The same frame cut into tiles of `tile` pixels.
    #[must_use]
    pub fn with_tile(self, tile: u32) -> Self {
        Self {
            tiles_x: self.width.div_ceil(tile),
            tiles_y: self.height.div_ceil(tile),
            tile,
            ..self
        }
    }
}

/// What [`TileBinning::hold`] did for a frame's lists.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Room {
    /// They fitted.
    Enough,
    /// The items grew to hold them.
    Grown,
    /// They cannot fit in one binding: the tiles widened (the frame must be binned again).
    Widened,
}

/// Items the lists of the first frame may hold before the buffer grows: few, for the first
/// frame sizes the buffer (waiting, or traced again on the GPU viewport) and later ones grow it
/// by a quarter more than they need.
const INITIAL_ITEMS: u64 = 1 << 10;

/// One frame's tile lists (binning.wgsl): per-tile ranges into the items, filled by
/// [`TileBinning::fill`] in the trace submission.
pub struct TileLists {
    binning: wgpu::Buffer,
    primitives: wgpu::Buffer,
    pub(crate) ranges: wgpu::Buffer,
    /// Binning workgroups: columns of 64 primitives × slices of their (primitive, tile) pairs.
    workgroups: (u32, u32),
}

/// Per-tile and per-primitive buffers of one frame shape, reused while it holds.
struct BinningBuffers {
    /// Tiles and primitives.
    shape: (u32, u32),
    counts: wgpu::Buffer,
    ranges: wgpu::Buffer,
    rects: wgpu::Buffer,
    occluded: wgpu::Buffer,
    nearest: wgpu::Buffer,
    /// The (primitive, tile) pairs of all lists (binning.wgsl `list_total`).
    total: wgpu::Buffer,
}

/// The binning pipelines, how they are dispatched, and the buffers they fill.
pub struct TileBinning {
    occlude: wgpu::ComputePipeline,
    count: wgpu::ComputePipeline,
    scan: wgpu::ComputePipeline,
    fill: wgpu::ComputePipeline,
    close: wgpu::ComputePipeline,
    /// Workgroups the binning passes aim for in all: enough to fill a GPU; few on a CPU
    /// adapter, where each workgroup's shared prefix sum costs real time.
    workgroups: u32,
    /// Whether binning leaves out primitives behind occluders (binning.wgsl).
    pub occluders: bool,
    /// Whether a tile's lists leave out the point blobs and SCALIS segments whose support
    /// its pixel rays' beam misses (binning.wgsl `beam_misses_hull`), not only those whose
    /// bounding sphere's screen rectangle misses it.
    pub hulls: bool,
    buffers: Option<BinningBuffers>,
    /// The items of every tile's list.
    items: wgpu::Buffer,
    /// Frames whose lists were recorded, the items' capacity when the last was, and the last
    /// frame whose total was checked.
    encoded: u64,
    encoded_capacity: u64,
    checked: u64,
    /// The total of frame `.0`, whose lists had room for `.1` items.
    total_readback: AsyncReadback<(u64, u64)>,
    /// The largest storage binding the lists may take, in bytes: the device's limit, or less
    /// ([`TileBinning::limit_lists`]).
    max_binding: u64,
    /// Tile edge of the next frames: [`TILE`], widened while lists do not fit.
    tile: u32,
}

impl TileBinning {
    /// Builds the pipelines on `device`.
    pub fn new(device: &wgpu::Device, cpu_adapter: bool) -> Self {
        let source = binning_source();
        Self {
            occlude: pipeline(device, &source, "occlude_tiles"),
            count: pipeline(device, &source, "count_tiles"),
            scan: pipeline(device, &source, "scan_tiles"),
            fill: pipeline(device, &source, "fill_tiles"),
            close: pipeline(device, &source, "close_tiles"),
            workgroups: if cpu_adapter { 64 } else { 4096 },
            occluders: true,
            hulls: true,
            buffers: None,
            items: items_buffer(device, INITIAL_ITEMS),
            encoded: 0,
            encoded_capacity: INITIAL_ITEMS,
            checked: 0,
            total_readback: AsyncReadback::new(device, "tile list total readback", 1),
            max_binding: device.limits().max_storage_buffer_binding_size,
            tile: TILE,
        }
    }

    /// The tile edge of the next frames, in pixels.
    pub fn tile(&self) -> u32 {
        self.tile
    }

    /// Keeps the lists under `bytes` (at most the device's binding limit), as a device with
    /// less memory would: frames whose lists need more are binned with wider tiles. The tiles
    /// start again from [`TILE`] and the items from their first size.
    pub fn limit_lists(&mut self, device: &wgpu::Device, bytes: u64) {
        self.max_binding = bytes.min(device.limits().max_storage_buffer_binding_size);
        self.tile = TILE;
        self.items = items_buffer(device, INITIAL_ITEMS);
        self.encoded_capacity = INITIAL_ITEMS;
    }

    /// Items the lists can hold now.
    fn capacity(&self) -> u64 {
        self.items.size() / 4
    }

    /// Grows the items to hold `total` with room to spare, or, where no binding can hold
    /// them, widens the tiles of the next frames.
    ///
    /// # Errors
    /// When the lists do not fit even with [`MAX_TILE`]-pixel tiles.
    fn hold(&mut self, device: &wgpu::Device, total: u64) -> Result<Room, String> {
        if total <= self.capacity() {
            return Ok(Room::Enough);
        }
        let words = (total + total / 4).min(self.max_binding / 4);
        if words < total {
            if self.tile < MAX_TILE {
                self.tile *= 2;
                return Ok(Room::Widened);
            }
            return Err(format!(
                "the tile lists need {} MB even with {MAX_TILE}-pixel tiles; the GPU binds at \
                 most {} MB (use a smaller frame or the CPU)",
                (total * 4) >> 20,
                self.max_binding >> 20
            ));
        }
        self.items = items_buffer(device, words);
        Ok(Room::Grown)
    }

    /// Records the passes that bin the `n_prims` primitives' supports into the tiles of
    /// `geometry` (binning.wgsl: occluding depths, counts, ranges); the lists are filled by
    /// [`TileBinning::fill`]. Without an encoder, the passes are submitted on their own and the
    /// total read back, so that the items hold every list (returns the total then), the tiles
    /// widening until they fit in one binding; with one, they are recorded into it, nothing
    /// waits, and the total is copied back later and checked by
    /// [`TileBinning::poll_overflow`]. Returns the frame cut into the tiles the lists use.
    ///
    /// # Errors
    /// A failed readback, or lists larger than the device can bind with the widest tiles.
    #[expect(
        clippy::too_many_arguments,
        reason = "the device, queue, encoder, primitives, geometry and queries are each the caller's"
    )]
    pub fn encode_lists(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        encoder: Option<&mut wgpu::CommandEncoder>,
        primitives: &wgpu::Buffer,
        n_prims: u32,
        geometry: &FrameGeometry,
        queries: Option<&wgpu::QuerySet>,
    ) -> Result<(TileLists, Option<u64>, FrameGeometry), String> {
        if let Some(encoder) = encoder {
            let geometry = geometry.with_tile(self.tile);
            let lists =
                self.record_counts(device, encoder, primitives, n_prims, &geometry, queries)?;
            return Ok((lists, None, geometry));
        }
        loop {
            let geometry = geometry.with_tile(self.tile);
            let mut encoder =
                device.create_command_encoder(&wgpu::CommandEncoderDescriptor::default());
            let lists = self.record_counts(
                device,
                &mut encoder,
                primitives,
                n_prims,
                &geometry,
                queries,
            )?;
            let b = self.buffers.as_ref().ok_or("no binning buffers")?;
            let total_read = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("tile list total readback"),
                size: 4,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            encoder.copy_buffer_to_buffer(&b.total, 0, &total_read, 0, 4);
            queue.submit([encoder.finish()]);
            let total = u64::from(read_back::<u32>(device, &total_read)?[0]);
            if self.hold(device, total)? != Room::Widened {
                self.checked = self.encoded;
                return Ok((lists, Some(total), geometry));
            }
        }
    }

    /// Records the occluding depths, counts and ranges of `geometry`'s tiles into `encoder`.
    fn record_counts(
        &mut self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
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
            tile,
            band_near,
            band_width,
            ..
        } = *geometry;
        let tiles = tiles_x * tiles_y;
        // Binning workgroups: one column per 64 primitives, as many slices of each column's
        // (primitive, tile) pairs as fill `binning_workgroups` (binning.wgsl).
        let columns = n_prims.div_ceil(64).max(1);
        let slices = (self.workgroups / columns).clamp(1, tiles);
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
                tile_size: tile,
                primitive_count: n_prims,
                width,
                height,
                occluders: u32::from(self.occluders),
                band_near: band_near as f32,
                band_width: band_width as f32,
                hulls: u32::from(self.hulls),
                pad2: [0; 2],
            }),
            usage: wgpu::BufferUsages::STORAGE,
        });
        if self
            .buffers
            .as_ref()
            .is_none_or(|b| b.shape != (tiles, n_prims))
        {
            self.buffers = Some(BinningBuffers::new(d, tiles, n_prims));
        }
        let b = self.buffers.as_ref().ok_or("no binning buffers")?;
        let group = |pipeline: &wgpu::ComputePipeline, label: &str, bindings: &[u32]| {
            let entries: Vec<_> = bindings
                .iter()
                .map(|&k| match k {
                    0 => entry(0, &binning),
                    1 => entry(1, primitives),
                    2 => entry(2, &b.counts),
                    3 => entry(3, &b.ranges),
                    5 => entry(5, &b.rects),
                    6 => entry(6, &b.occluded),
                    7 => entry(7, &b.nearest),
                    _ => entry(8, &b.total),
                })
                .collect();
            d.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some(label),
                layout: &pipeline.get_bind_group_layout(0),
                entries: &entries,
            })
        };
        let occlude_group = group(&self.occlude, "occlude tiles", &[0, 1, 6]);
        let count_group = group(&self.count, "count tiles", &[0, 1, 2, 5, 6, 7]);
        let scan_group = group(&self.scan, "scan tiles", &[0, 2, 3, 8]);
        encoder.clear_buffer(&b.occluded, 0, None);
        encoder.clear_buffer(&b.counts, 0, None);
        {
            // The occluding depths, the counts, then the ranges (binning.wgsl).
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
            pass.set_pipeline(&self.scan);
            pass.set_bind_group(0, &scan_group, &[]);
            pass.dispatch_workgroups(1, 1, 1);
        }
        self.encoded += 1;
        self.encoded_capacity = self.capacity();
        Ok(TileLists {
            binning,
            primitives: primitives.clone(),
            ranges: b.ranges.clone(),
            workgroups: (columns, slices),
        })
    }

    /// Records the pass that fills `lists`, then closes each list's range at what the fill
    /// wrote (timestamps at index 1 of `queries`).
    pub fn fill(
        &self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
        lists: &TileLists,
        queries: Option<&wgpu::QuerySet>,
    ) -> Result<(), String> {
        let b = self.buffers.as_ref().ok_or("no binning buffers")?;
        let fill_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("fill tiles"),
            layout: &self.fill.get_bind_group_layout(0),
            entries: &[
                entry(0, &lists.binning),
                entry(1, &lists.primitives),
                entry(2, &b.counts),
                entry(3, &lists.ranges),
                entry(4, &self.items),
                entry(5, &b.rects),
                entry(6, &b.occluded),
                entry(7, &b.nearest),
            ],
        });
        encoder.clear_buffer(&b.counts, 0, None);
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("fill tiles"),
            timestamp_writes: timestamp_writes(queries, 1),
        });
        pass.set_pipeline(&self.fill);
        pass.set_bind_group(0, &fill_group, &[]);
        pass.dispatch_workgroups(lists.workgroups.0, lists.workgroups.1, 1);
        // The fill leaves out pairs the count kept (binning.wgsl `close_tiles`): each range
        // ends where its list's cursor stopped.
        let close_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("close tiles"),
            layout: &self.close.get_bind_group_layout(0),
            entries: &[
                entry(0, &lists.binning),
                entry(2, &b.counts),
                entry(3, &lists.ranges),
            ],
        });
        let lists_count = b.shape.0 * DEPTH_BANDS;
        pass.set_pipeline(&self.close);
        pass.set_bind_group(0, &close_group, &[]);
        pass.dispatch_workgroups(lists_count.div_ceil(64).clamp(1, self.workgroups), 1, 1);
        Ok(())
    }

    /// The items of every tile's list, as the last fill wrote them.
    pub fn items(&self) -> &wgpu::Buffer {
        &self.items
    }

    /// Checks the lists recorded without waiting (call once per frame, after polling the
    /// device, with the frame's encoder): copies back the total of the latest frame when none
    /// is in flight, and when a copy has come back showing that the lists did not fit, grows
    /// the items. Returns whether the latest frame must be traced again.
    ///
    /// # Errors
    /// Lists larger than the device can bind.
    pub fn poll_overflow(
        &mut self,
        device: &wgpu::Device,
        encoder: &mut wgpu::CommandEncoder,
    ) -> Result<bool, String> {
        let mut again = false;
        if let Some(((frame, capacity), words)) = self.total_readback.poll() {
            let total = u64::from(words[0]);
            if total > capacity {
                // Grown, or widened for the next frames.
                self.hold(device, total)?;
                // Cut short: traced again if it is the latest (a later frame is checked in
                // its turn).
                again = frame == self.encoded;
            }
        }
        if self.checked < self.encoded
            && let Some(b) = &self.buffers
            && self.total_readback.record(
                encoder,
                &[(&b.total, 0, 0, 4)],
                (self.encoded, self.encoded_capacity),
            )
        {
            self.checked = self.encoded;
        }
        Ok(again)
    }

    /// Whether the lists of some frame recorded without waiting have yet to be checked.
    pub fn unchecked(&self) -> bool {
        self.checked < self.encoded || !self.total_readback.is_idle()
    }
}

impl BinningBuffers {
    fn new(device: &wgpu::Device, tiles: u32, n_prims: u32) -> Self {
        let buffer = |label: &str, size: u64, usage: wgpu::BufferUsages| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage,
                mapped_at_creation: false,
            })
        };
        let tiles = u64::from(tiles);
        // One list per band of every tile.
        let lists = tiles * u64::from(DEPTH_BANDS);
        let prims = u64::from(n_prims.max(1));
        let cleared = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST;
        Self {
            shape: (tiles as u32, n_prims),
            counts: buffer("tile counts", lists * 4, cleared),
            ranges: buffer("tile ranges", lists * 8, wgpu::BufferUsages::STORAGE),
            rects: buffer("tile rectangles", prims * 16, wgpu::BufferUsages::STORAGE),
            occluded: buffer("occluding depths", tiles * 4, cleared),
            nearest: buffer("nearest reaches", prims * 4, wgpu::BufferUsages::STORAGE),
            total: buffer(
                "tile list total",
                4,
                wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            ),
        }
    }
}

fn items_buffer(device: &wgpu::Device, words: u64) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("tile items"),
        size: words.max(1) * 4,
        usage: wgpu::BufferUsages::STORAGE,
        mapped_at_creation: false,
    })
}
