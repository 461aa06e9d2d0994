// Screen-tile binning of primitive supports (the analogue of the scalis 2021 A-buffer, §7):
// each primitive's support bounding sphere is projected to a rectangle of tiles; a first pass
// counts the primitives per tile and stores each rectangle, the host turns counts into ranges
// (exclusive prefix sum), a second pass writes the primitive indices into the stored
// rectangles. Storing them matters: the two entry points are compiled separately and may round
// the projection differently, and a rectangle one tile larger in the second pass would write
// past its tile's range. Unbounded supports (planes) go to every tile.

struct Binning {
    origin: vec4<f32>,
    forward: vec4<f32>,  // w: tan(fov/2)
    right: vec4<f32>,    // w: aspect
    up: vec4<f32>,
    tiles: vec4<u32>,    // tiles_x, tiles_y, tile size, primitive count
    size: vec4<u32>,     // width, height
};

// Twin of `GpuPrimitive` (only the bounding sphere is read here).
struct Primitive {
    kind: u32,
    group: u32,
    pad0: u32,
    pad1: u32,
    a: vec4<f32>,
    b: vec4<f32>,
    c: vec4<f32>,
    bound: vec4<f32>,
};

@group(0) @binding(0) var<uniform> binning: Binning;
@group(0) @binding(1) var<storage, read> primitives: array<Primitive>;
@group(0) @binding(2) var<storage, read_write> tile_counts: array<atomic<u32>>;
@group(0) @binding(3) var<storage, read> tile_ranges: array<vec2<u32>>;
@group(0) @binding(4) var<storage, read_write> tile_items: array<u32>;
@group(0) @binding(5) var<storage, read_write> rects: array<vec4<i32>>;

// Inclusive tile rectangle (x0, y0, x1, y1) covered by primitive i; x0 > x1 when off screen.
fn tile_rect(i: u32) -> vec4<i32> {
    let all_tiles = vec4<i32>(0, 0, i32(binning.tiles.x) - 1, i32(binning.tiles.y) - 1);
    let bound = primitives[i].bound;
    if bound.w < 0.0 {
        return all_tiles;
    }
    let rel = bound.xyz - binning.origin.xyz;
    let z = dot(rel, binning.forward.xyz);
    let r = bound.w;
    if z <= r * 1.0001 {
        // The sphere reaches the eye plane: it may cover any pixel.
        return all_tiles;
    }
    // Conservative extent in the image plane: the view-space box around the sphere, whose
    // corners project to the extreme tangents x/z and y/z.
    let x = dot(rel, binning.right.xyz);
    let y = dot(rel, binning.up.xyz);
    let near = z - r;
    let far = z + r;
    let sx = binning.forward.w * binning.right.w;
    let sy = binning.forward.w;
    let u0 = min((x - r) / near, (x - r) / far) / sx;
    let u1 = max((x + r) / near, (x + r) / far) / sx;
    let v0 = min((y - r) / near, (y - r) / far) / sy;
    let v1 = max((y + r) / near, (y + r) / far) / sy;
    let w = f32(binning.size.x);
    let h = f32(binning.size.y);
    let ts = f32(binning.tiles.z);
    let px0 = (u0 + 1.0) * 0.5 * w - 1.0;
    let px1 = (u1 + 1.0) * 0.5 * w + 1.0;
    let py0 = (1.0 - v1) * 0.5 * h - 1.0;
    let py1 = (1.0 - v0) * 0.5 * h + 1.0;
    return vec4<i32>(
        max(i32(floor(px0 / ts)), 0),
        max(i32(floor(py0 / ts)), 0),
        min(i32(floor(px1 / ts)), i32(binning.tiles.x) - 1),
        min(i32(floor(py1 / ts)), i32(binning.tiles.y) - 1));
}

// Both passes share out the work of each 64 primitives evenly: the rectangles' areas are
// prefix-summed in workgroup memory, and the threads of `num_workgroups.y` workgroups (slices)
// stride over all of those primitives' (primitive, tile) pairs. One thread per primitive would
// leave a primitive covering much of the screen to a single thread: at 2048² (262 144 tiles)
// that took tens of milliseconds on an H100, and one workgroup per 64 primitives still 45 ms
// for a scene of a few dozen primitives.
const GROUP: u32 = 64u;
var<workgroup> group_rects: array<vec4<i32>, GROUP>;
// Inclusive prefix sum of the rectangles' areas in tiles.
var<workgroup> area_ends: array<u32, GROUP>;

fn rect_area(rect: vec4<i32>) -> u32 {
    if rect.x > rect.z || rect.y > rect.w {
        return 0u;
    }
    return u32(rect.z - rect.x + 1) * u32(rect.w - rect.y + 1);
}

// Shares `rect` (thread `lid`'s primitive) with the workgroup; returns the workgroup's total
// area. Called from uniform control flow by every thread.
fn share_rects(lid: u32, rect: vec4<i32>) -> u32 {
    group_rects[lid] = rect;
    area_ends[lid] = rect_area(rect);
    workgroupBarrier();
    for (var offset = 1u; offset < GROUP; offset *= 2u) {
        var before = 0u;
        if lid >= offset {
            before = area_ends[lid - offset];
        }
        workgroupBarrier();
        area_ends[lid] += before;
        workgroupBarrier();
    }
    return area_ends[GROUP - 1u];
}

// The `k`-th (primitive, tile) pair of the workgroup: (primitive slot in the group, tile index).
fn pair(k: u32) -> vec2<u32> {
    var lo = 0u;
    var hi = GROUP - 1u;
    while lo < hi {
        let mid = (lo + hi) / 2u;
        if area_ends[mid] > k {
            hi = mid;
        } else {
            lo = mid + 1u;
        }
    }
    let rect = group_rects[lo];
    let local = k - (area_ends[lo] - rect_area(rect));
    let width = u32(rect.z - rect.x + 1);
    let tx = u32(rect.x) + local % width;
    let ty = u32(rect.y) + local / width;
    return vec2<u32>(lo, ty * binning.tiles.x + tx);
}

@compute @workgroup_size(64, 1, 1)
fn count_tiles(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
    @builtin(num_workgroups) slices: vec3<u32>,
) {
    let i = id.x;
    var rect = vec4<i32>(1, 1, 0, 0);
    if i < binning.tiles.w {
        rect = tile_rect(i);
        if id.y == 0u {
            rects[i] = rect;
        }
    }
    let total = share_rects(lid, rect);
    for (var k = id.y * GROUP + lid; k < total; k += GROUP * slices.y) {
        atomicAdd(&tile_counts[pair(k).y], 1u);
    }
}

// Second pass: tile_counts has been reset to 0 and is used as each tile's cursor.
@compute @workgroup_size(64, 1, 1)
fn fill_tiles(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
    @builtin(num_workgroups) slices: vec3<u32>,
) {
    let i = id.x;
    var rect = vec4<i32>(1, 1, 0, 0);
    if i < binning.tiles.w {
        rect = rects[i];
    }
    let total = share_rects(lid, rect);
    let first = id.x - lid;
    for (var k = id.y * GROUP + lid; k < total; k += GROUP * slices.y) {
        let p = pair(k);
        let slot = atomicAdd(&tile_counts[p.y], 1u);
        let range = tile_ranges[p.y];
        if range.x + slot < range.y {
            tile_items[range.x + slot] = first + p.x;
        }
    }
}
