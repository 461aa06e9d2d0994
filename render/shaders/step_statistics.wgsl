// Step-count statistics of a comparison traced on the GPU (viewport.rs): each
// panel's histogram of step counts, and the shared top of the colour scale, the largest over
// the panels of the 99th percentile of the pixels that took a step (core frame.rs
// StepHistogram::worked_p99 and shared_step_top). The blit colours the grid with the top where
// it lies; only the histograms are copied out, for the labels and the small histograms.

struct Statistics {
    width: u32,    // pixels of a panel's row
    height: u32,
    panels: u32,   // side by side in the steps buffer
    bins: u32,     // counts 0 to bins - 1; larger counts fall in the last bin
};

// Storage, not uniform, as the trace shaders' globals (shared/scene.wgsl).
@group(0) @binding(0) var<storage, read> stats: Statistics;
@group(0) @binding(1) var<storage, read> steps: array<u32>;
@group(0) @binding(2) var<storage, read_write> histogram: array<atomic<u32>>;
@group(0) @binding(3) var<storage, read_write> top: atomic<u32>;

const COUNT_GROUP: u32 = 256u;

// One thread per pixel, in as many rows of workgroups as the dispatch has.
@compute @workgroup_size(256)
fn count_steps(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let i = id.x + id.y * groups.x * COUNT_GROUP;
    let row = stats.width * stats.panels;
    if i >= row * stats.height {
        return;
    }
    let panel = (i % row) / stats.width;
    let s = min(steps[i], stats.bins - 1u);
    atomicAdd(&histogram[panel * stats.bins + s], 1u);
}

// One workgroup per panel: its 99th percentile of the pixels that took a step, or 1.
@compute @workgroup_size(1)
fn shared_top(@builtin(workgroup_id) id: vec3<u32>) {
    let base = id.x * stats.bins;
    var worked = 0u;
    for (var s = 1u; s < stats.bins; s++) {
        worked += atomicLoad(&histogram[base + s]);
    }
    var p99 = 1u;
    if worked > 0u {
        let rank = worked / 100u * 99u + (worked % 100u) * 99u / 100u;
        var seen = 0u;
        for (var s = 1u; s < stats.bins; s++) {
            seen += atomicLoad(&histogram[base + s]);
            if seen > rank {
                p99 = s;
                break;
            }
        }
    }
    atomicMax(&top, p99);
}
