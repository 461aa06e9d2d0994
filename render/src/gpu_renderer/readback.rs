//! Reading frames back: the side-by-side outputs split into core `Frame`s, and the passes'
//! times from the timestamp queries.

use super::*;

/// Splits the mapped side-by-side outputs (packed sRGB8 colour, depth, steps; `panels` frames
/// of `width × height` in a row) into one [`Frame`] per panel, a row at a time in parallel.
pub(super) fn split_panels(
    mapped: [&[u8]; 3],
    (w, h): (usize, usize),
    panels: usize,
) -> Vec<Frame> {
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
pub(super) fn pass_times(stamps: &[u64], period_ns: f64) -> PassTimes {
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
pub(super) fn linear_from_packed(c: u32) -> [f32; 3] {
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
