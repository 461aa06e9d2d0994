//! Step statistics of a comparison grid traced on the GPU: the frames stay where
//! they were traced; `shaders/step_statistics.wgsl` counts each panel's histogram of step
//! counts and the shared top of the colour scale next to them, the viewport's blit colours the
//! heat maps with that top, and only the histograms (a few kilobytes) and the hovered pixel's
//! counts are copied out, without waiting for the GPU ([`AsyncReadback`]). The statistics are those the CPU computes
//! from a read-back frame ([`StepHistogram`], [`skeletrace_core::frame::shared_step_top`]).

use skeletrace_core::frame::StepHistogram;

use crate::async_readback::AsyncReadback;
use crate::shaders::step_statistics_source;
use crate::wgpu_util::{entry, pipeline};

/// Threads of a `count_steps` workgroup (step_statistics.wgsl `COUNT_GROUP`).
const COUNT_GROUP: u32 = 256;
/// Workgroups in a row of the `count_steps` dispatch (below every device's 65 535).
const COUNT_ROW: u32 = 4096;

/// The shape of what is counted: panels of `width × height` side by side, step counts binned
/// from 0 to `bins − 1` (larger counts in the last bin).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StatisticsShape {
    /// Pixels of a panel's row.
    pub width: u32,
    /// Rows.
    pub height: u32,
    /// Panels side by side.
    pub panels: u32,
    /// Histogram bins per panel: the step budget plus one.
    pub bins: u32,
}

impl StatisticsShape {
    fn histogram_words(self) -> u64 {
        u64::from(self.panels) * u64::from(self.bins)
    }
}

/// Which frame (the painter's count of traced frames) and which hovered pixel a read-back
/// describes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StatisticsTag {
    /// The frame's number.
    pub frame: u64,
    /// The hovered pixel of a panel, whose counts in every panel are read back with the
    /// histograms.
    pub probe: Option<(u32, u32)>,
}

/// Statistics read back from the GPU.
#[derive(Clone, Debug, PartialEq)]
pub struct GridStatistics {
    /// What they describe.
    pub tag: StatisticsTag,
    /// The frames counted.
    pub shape: StatisticsShape,
    /// Each panel's histogram of step counts.
    pub histograms: Vec<StepHistogram>,
    /// The top of the shared colour scale the heat maps were drawn with.
    pub top: u32,
    /// Each panel's step count at the probed pixel (empty without a probe).
    pub probe_steps: Vec<u32>,
}

struct StatisticsBuffers {
    shape: StatisticsShape,
    shape_words: wgpu::Buffer,
    histogram: wgpu::Buffer,
    top: wgpu::Buffer,
    /// The histograms, the top, then one probed count per panel.
    readback: AsyncReadback<StatisticsTag>,
}

/// The statistics passes, their buffers and the read-back in flight.
pub struct StepStatistics {
    count: wgpu::ComputePipeline,
    top: wgpu::ComputePipeline,
    buffers: Option<StatisticsBuffers>,
    published: Option<GridStatistics>,
}

impl StepStatistics {
    /// The passes, built on `device`.
    #[must_use]
    pub fn new(device: &wgpu::Device) -> Self {
        let source = step_statistics_source();
        Self {
            count: pipeline(device, &source, "count_steps"),
            top: pipeline(device, &source, "shared_top"),
            buffers: None,
            published: None,
        }
    }

    /// Records the passes that count the step histograms of `steps` (panels side by side, as
    /// the trace writes them) and the shared top of the colour scale.
    pub fn encode(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        steps: &wgpu::Buffer,
        shape: StatisticsShape,
    ) {
        if self.buffers.as_ref().is_none_or(|b| b.shape != shape) {
            // A read-back of the old buffers still in flight is dropped with them.
            self.buffers = Some(StatisticsBuffers::new(device, shape));
        }
        let Some(b) = &self.buffers else { return };
        let shape_words = [shape.width, shape.height, shape.panels, shape.bins];
        queue.write_buffer(&b.shape_words, 0, bytemuck::cast_slice(&shape_words));
        encoder.clear_buffer(&b.histogram, 0, None);
        encoder.clear_buffer(&b.top, 0, None);
        let count_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("count steps"),
            layout: &self.count.get_bind_group_layout(0),
            entries: &[
                entry(0, &b.shape_words),
                entry(1, steps),
                entry(2, &b.histogram),
            ],
        });
        let top_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("shared top"),
            layout: &self.top.get_bind_group_layout(0),
            entries: &[
                entry(0, &b.shape_words),
                entry(2, &b.histogram),
                entry(3, &b.top),
            ],
        });
        let pixels = shape.width * shape.height * shape.panels;
        let groups = pixels.div_ceil(COUNT_GROUP);
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("step statistics"),
            timestamp_writes: None,
        });
        pass.set_pipeline(&self.count);
        pass.set_bind_group(0, &count_group, &[]);
        pass.dispatch_workgroups(groups.min(COUNT_ROW), groups.div_ceil(COUNT_ROW), 1);
        pass.set_pipeline(&self.top);
        pass.set_bind_group(0, &top_group, &[]);
        pass.dispatch_workgroups(shape.panels, 1, 1);
    }

    /// The buffer holding the shared top of the colour scale of the last frame counted.
    #[must_use]
    pub fn top_buffer(&self) -> Option<&wgpu::Buffer> {
        self.buffers.as_ref().map(|b| &b.top)
    }

    /// Advances the read-back (the caller polls the device once per frame): publishes the
    /// statistics whose copy has completed. Call before [`StepStatistics::request`].
    pub fn poll(&mut self) {
        let Some(b) = &mut self.buffers else { return };
        if let Some((tag, words)) = b.readback.poll() {
            self.published = Some(unpack(tag, b.shape, &words));
        }
    }

    /// Records the copy of the statistics of frame `tag.frame` (and of the probed pixel's
    /// counts in `steps`) unless they are published or on their way already, or another copy is
    /// still in flight (then a later call records it).
    pub fn request(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        steps: &wgpu::Buffer,
        tag: StatisticsTag,
    ) {
        if self.published.as_ref().is_some_and(|p| p.tag == tag) {
            return;
        }
        let Some(b) = &mut self.buffers else { return };
        let shape = b.shape;
        let words = shape.histogram_words();
        let mut copies = vec![(&b.histogram, 0, 0, words * 4), (&b.top, 0, words * 4, 4)];
        if let Some((x, y)) = tag
            .probe
            .filter(|&(x, y)| x < shape.width && y < shape.height)
        {
            for panel in 0..shape.panels {
                let pixel = (u64::from(y) * u64::from(shape.panels) + u64::from(panel))
                    * u64::from(shape.width)
                    + u64::from(x);
                copies.push((steps, pixel * 4, (words + 1 + u64::from(panel)) * 4, 4));
            }
        }
        b.readback.record(encoder, &copies, tag);
    }

    /// The latest statistics read back.
    #[must_use]
    pub fn published(&self) -> Option<&GridStatistics> {
        self.published.as_ref()
    }
}

impl StatisticsBuffers {
    fn new(device: &wgpu::Device, shape: StatisticsShape) -> Self {
        let buffer = |label: &str, size: u64, usage: wgpu::BufferUsages| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage,
                mapped_at_creation: false,
            })
        };
        let words = shape.histogram_words();
        let counted = wgpu::BufferUsages::STORAGE
            | wgpu::BufferUsages::COPY_SRC
            | wgpu::BufferUsages::COPY_DST;
        Self {
            shape,
            shape_words: buffer(
                "step statistics",
                16,
                wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            ),
            histogram: buffer("step histograms", words * 4, counted),
            top: buffer("shared step top", 4, counted),
            readback: AsyncReadback::new(
                device,
                "step statistics readback",
                words + 1 + u64::from(shape.panels),
            ),
        }
    }
}

/// The statistics in a mapped staging buffer.
fn unpack(tag: StatisticsTag, shape: StatisticsShape, words: &[u32]) -> GridStatistics {
    let bins = shape.bins as usize;
    let panels = shape.panels as usize;
    let histograms = words
        .chunks(bins)
        .take(panels)
        .map(|c| StepHistogram::from_counts(c.iter().map(|&n| u64::from(n)).collect()))
        .collect();
    let top = words.get(panels * bins).copied().unwrap_or(1).max(1);
    let probed = tag
        .probe
        .is_some_and(|(x, y)| x < shape.width && y < shape.height);
    let probe_steps = if probed {
        words[panels * bins + 1..].to_vec()
    } else {
        Vec::new()
    };
    GridStatistics {
        tag,
        shape,
        histograms,
        top,
        probe_steps,
    }
}
