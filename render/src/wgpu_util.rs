//! Small wgpu helpers every pass uses: storage buffers, compute pipelines from WGSL, bind-group
//! entries, timestamp writes, and blocking readback of `MAP_READ` buffers.

use bytemuck::Pod;
use wgpu::util::DeviceExt;

/// A storage buffer holding `bytes` (16 zero bytes when empty: bindings may not be empty).
pub(crate) fn storage(device: &wgpu::Device, label: &str, bytes: &[u8]) -> wgpu::Buffer {
    // Storage buffers may not be empty.
    let padded;
    let contents = if bytes.is_empty() {
        padded = [0u8; 16];
        &padded[..]
    } else {
        bytes
    };
    device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some(label),
        contents,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
    })
}

/// The compute pipeline of `entry` in the WGSL `source`.
pub(crate) fn pipeline(device: &wgpu::Device, source: &str, entry: &str) -> wgpu::ComputePipeline {
    cached_pipeline(device, source, entry, None)
}

/// [`pipeline`] through a pipeline cache, where there is one.
pub(crate) fn cached_pipeline(
    device: &wgpu::Device,
    source: &str,
    entry: &str,
    cache: Option<&wgpu::PipelineCache>,
) -> wgpu::ComputePipeline {
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(entry),
        source: wgpu::ShaderSource::Wgsl(source.into()),
    });
    device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(entry),
        layout: None,
        module: &module,
        entry_point: Some(entry),
        compilation_options: wgpu::PipelineCompilationOptions::default(),
        cache,
    })
}

/// A vector in `f32`, as the shaders take it.
pub(crate) fn f3(v: glam::DVec3) -> [f32; 3] {
    [v.x as f32, v.y as f32, v.z as f32]
}

/// Timestamp writes of pass `pass` (its begin and end), where the device has timestamps.
pub(crate) fn timestamp_writes(
    queries: Option<&wgpu::QuerySet>,
    pass: u32,
) -> Option<wgpu::ComputePassTimestampWrites<'_>> {
    timestamps_at(queries, pass, (true, true))
}

/// Timestamp writes of pass `pass` at its `begin`, its `end`, or both, where the device has
/// timestamps (a pass recorded in pieces stamps its first piece's begin and its last's end).
pub(crate) fn timestamps_at(
    queries: Option<&wgpu::QuerySet>,
    pass: u32,
    (begin, end): (bool, bool),
) -> Option<wgpu::ComputePassTimestampWrites<'_>> {
    queries
        .filter(|_| begin || end)
        .map(|query_set| wgpu::ComputePassTimestampWrites {
            query_set,
            beginning_of_pass_write_index: begin.then_some(2 * pass),
            end_of_pass_write_index: end.then_some(2 * pass + 1),
        })
}

/// The bind-group entry of `buffer` at `binding`.
pub(crate) fn entry(binding: u32, buffer: &wgpu::Buffer) -> wgpu::BindGroupEntry<'_> {
    wgpu::BindGroupEntry {
        binding,
        resource: buffer.as_entire_binding(),
    }
}

/// Maps `MAP_READ` buffers, waiting once for the queue.
pub(crate) fn map_for_reading(
    device: &wgpu::Device,
    buffers: &[&wgpu::Buffer],
) -> Result<(), String> {
    let (sender, receiver) = std::sync::mpsc::channel();
    for buffer in buffers {
        let sender = sender.clone();
        buffer.slice(..).map_async(wgpu::MapMode::Read, move |r| {
            let _ = sender.send(r);
        });
    }
    device
        .poll(wgpu::PollType::wait_indefinitely())
        .map_err(|e| format!("GPU poll failed: {e}"))?;
    for _ in buffers {
        receiver
            .recv()
            .map_err(|e| e.to_string())?
            .map_err(|e| format!("GPU readback failed: {e}"))?;
    }
    Ok(())
}

/// Maps a `MAP_READ` buffer and copies it out.
pub(crate) fn read_back<T: Pod>(
    device: &wgpu::Device,
    buffer: &wgpu::Buffer,
) -> Result<Vec<T>, String> {
    map_for_reading(device, &[buffer])?;
    let slice = buffer.slice(..);
    let view = slice
        .get_mapped_range()
        .map_err(|e| format!("GPU readback failed: {e}"))?;
    let data = bytemuck::cast_slice(&view).to_vec();
    drop(view);
    buffer.unmap();
    Ok(data)
}
