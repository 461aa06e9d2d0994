//! Small GPU buffers read back without waiting for the GPU: the copy is recorded into a frame's
//! encoder, the staging buffer is mapped once that frame was submitted (the next
//! [`AsyncReadback::poll`]), and its words are handed out when the map completes, a frame or
//! two later. The editor's GPU viewport reads its statistics and its tile-list sizes this
//! way, so that no frame waits on the GPU.

use std::sync::{Arc, Mutex};

type MapResult = Arc<Mutex<Option<Result<(), wgpu::BufferAsyncError>>>>;

/// Where the copy is.
enum State<T> {
    Idle,
    /// Recorded into an encoder that is submitted with the frame.
    Recorded(T),
    /// Submitted and asked to map.
    Mapping(T, MapResult),
}

/// A staging buffer of 32-bit words and the copy in flight into it, tagged with what it
/// describes.
pub struct AsyncReadback<T> {
    staging: wgpu::Buffer,
    state: State<T>,
}

impl<T> AsyncReadback<T> {
    /// A staging buffer of `words` words on `device`.
    #[must_use]
    pub fn new(device: &wgpu::Device, label: &str, words: u64) -> Self {
        Self {
            staging: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: words.max(1) * 4,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            state: State::Idle,
        }
    }

    /// No copy is in flight.
    #[must_use]
    pub fn is_idle(&self) -> bool {
        matches!(self.state, State::Idle)
    }

    /// Records the copies `(source, source offset, staging offset, bytes)` into `encoder`,
    /// tagged `tag`, when no copy is in flight; returns whether it did.
    pub fn record(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        copies: &[(&wgpu::Buffer, u64, u64, u64)],
        tag: T,
    ) -> bool {
        if !self.is_idle() {
            return false;
        }
        for &(source, from, to, bytes) in copies {
            encoder.copy_buffer_to_buffer(source, from, &self.staging, to, bytes);
        }
        self.state = State::Recorded(tag);
        true
    }

    /// Advances the copy: maps it when it was recorded before (its encoder has been submitted
    /// since), and returns its tag and words once the map is complete. The owner polls the
    /// device once per frame, which completes the maps.
    pub fn poll(&mut self) -> Option<(T, Vec<u32>)> {
        match std::mem::replace(&mut self.state, State::Idle) {
            State::Idle => None,
            State::Recorded(tag) => {
                let result: MapResult = Arc::default();
                let done = Arc::clone(&result);
                self.staging
                    .slice(..)
                    .map_async(wgpu::MapMode::Read, move |r| {
                        if let Ok(mut slot) = done.lock() {
                            *slot = Some(r);
                        }
                    });
                self.state = State::Mapping(tag, result);
                None
            }
            State::Mapping(tag, result) => {
                let finished = result.lock().ok().and_then(|mut r| r.take());
                match finished {
                    None => {
                        self.state = State::Mapping(tag, result);
                        None
                    }
                    Some(Ok(())) => {
                        let words = self
                            .staging
                            .slice(..)
                            .get_mapped_range()
                            .ok()
                            .map(|view| bytemuck::cast_slice(&view).to_vec());
                        self.staging.unmap();
                        words.map(|w| (tag, w))
                    }
                    // A lost map (a device reset): the owner records again.
                    Some(Err(_)) => None,
                }
            }
        }
    }
}
