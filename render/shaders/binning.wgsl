// Screen-tile binning of primitive supports (the analogue of the scalis 2021 A-buffer, §7):
// each primitive's support bounding sphere is projected to a rectangle of tiles; a first pass
// counts the primitives per tile and stores each rectangle, a one-workgroup pass turns the
// counts into ranges (exclusive prefix sum) and the total, a fourth pass writes the primitive
// indices into the stored rectangles (less the tiles whose beam misses the support, below) and
// a last one ends each range where its list's writes stopped. Nothing is read back in between: the items buffer is as
// large as the host last needed (tile_binning.rs); lists past its end are cut short, and the
// host, reading the total later, grows it and traces again. Storing them matters: the two entry points are compiled separately and may round
// the projection differently, and a rectangle one tile larger in the second pass would write
// past its tile's range. Unbounded supports (planes) go to every tile.
//
// Occluders (scalis 2021 §7, "toward output sensitivity"): before counting, every primitive
// with an occluder sphere (a ball inside the surface, buffers.rs occluder_radius) marks the
// tiles whose rays all pass through it with the distance from the eye to its centre, which no
// such ray's entry into the ball exceeds. Along those rays the field reaches the isovalue by
// that depth, so a primitive whose support lies wholly beyond it (nearest point of its
// bounding sphere farther away) cannot change the first crossing and is left out of the tile.
// The blends for which this holds are decided in buffers.rs (sum, max, smooth union).
//
// Beams (the twin of the CPU's tile lists, core bvh.rs `Beam::misses_hull`): the rectangle of a
// long, thin segment's bounding sphere holds many tiles its support never reaches. With
// `hulls`, a primitive's rectangle is that of its support's hull — two balls, a point blob's
// ball or a SCALIS segment's end balls; other primitives' bounding sphere — and a pair is left
// out where the hull lies beyond one side of the pyramid of the tile's pixel rays (from the eye,
// through its corner pixels' centres). Such a support meets none of the tile's rays, so every
// ray's window holds the same supports (docs/gpu.md "Beam culling"). The count keeps pairs within a wider margin than the fill
// (COUNT_SLACK > FILL_SLACK, both far above f32 rounding), so that two separately compiled
// entry points never fill more than they counted; `close_tiles` then ends each range where its
// fill stopped.

// Margins of the beam test, relative to a ball's distance from the eye plus its radius.
const FILL_SLACK: f32 = 1e-4;
const COUNT_SLACK: f32 = 2e-4;

// Twin of core `Primitive::support_hull`: two balls whose convex hull holds the support.
struct Hull {
    a: vec4<f32>,
    b: vec4<f32>,
};

// Twin of `GpuBinning` (renderer.rs).
struct Binning {
    origin: vec3<f32>,
    pad0: f32,
    forward: vec3<f32>,
    tan_half_fov: f32,
    right: vec3<f32>,
    aspect: f32,
    up: vec3<f32>,
    pad1: f32,
    tiles_x: u32,
    tiles_y: u32,
    tile_size: u32,            // pixels
    primitive_count: u32,
    width: u32,
    height: u32,
    occluders: u32,            // 1 on, 0 off
    band_near: f32,            // depth bands (tile_binning.rs FrameGeometry): the first ends here,
    band_width: f32,           // the next ones are this deep
    hulls: u32,                // 1: lists leave out the supports a tile's beam misses
    pad2: u32,
    pad3: u32,
};

// Twin of `GpuPrimitive` (only the bounding sphere is read here).
struct Primitive {
    kind: u32,
    group: u32,
    occluder: f32,     // radius of a ball inside the surface (0: none; buffers.rs occluder_radius)
    extra: u32,
    a: vec4<f32>,
    b: vec4<f32>,
    c: vec4<f32>,
    d: vec4<f32>,
    bound: vec4<f32>,
};

// Storage, not uniform, as the trace shaders' globals (shared/scene.wgsl).
@group(0) @binding(0) var<storage, read> binning: Binning;
@group(0) @binding(1) var<storage, read> primitives: array<Primitive>;
@group(0) @binding(2) var<storage, read_write> tile_counts: array<atomic<u32>>;
@group(0) @binding(3) var<storage, read_write> tile_ranges: array<vec2<u32>>;
@group(0) @binding(4) var<storage, read_write> tile_items: array<u32>;
@group(0) @binding(5) var<storage, read_write> rects: array<vec4<i32>>;
// Per tile: the least occluding depth d as !bitcast<u32>(d), so that zeroed means none and
// atomicMax keeps the least.
@group(0) @binding(6) var<storage, read_write> occluded: array<atomic<u32>>;
// Per primitive: the distance from the eye to its bounding sphere (−INF when unbounded or
// around the eye), written by the count pass and read by the fill pass, so that both passes
// leave out the same primitives.
@group(0) @binding(7) var<storage, read_write> nearest: array<f32>;
// The (primitive, tile) pairs of all lists, for the host to size the items buffer.
@group(0) @binding(8) var<storage, read_write> list_total: array<u32>;

const INF: f32 = 3.0e38;

// Inclusive tile rectangle (x0, y0, x1, y1) covered by primitive i; x0 > x1 when off screen.
// A point blob's or SCALIS segment's is that of its support's hull (the rectangles of its two
// balls: the projection of their convex hull is the convex hull of theirs).
fn tile_rect(i: u32) -> vec4<i32> {
    let bound = primitives[i].bound;
    if bound.w < 0.0 {
        return vec4<i32>(0, 0, i32(binning.tiles_x) - 1, i32(binning.tiles_y) - 1);
    }
    let kind = primitives[i].kind;
    if binning.hulls != 0u && (kind == KIND_POINT || kind == KIND_SCALIS_SEGMENT) {
        let hull = support_hull(i);
        let a = sphere_rect(hull.a);
        let b = sphere_rect(hull.b);
        return vec4<i32>(min(a.xy, b.xy), max(a.zw, b.zw));
    }
    return sphere_rect(bound);
}

// Inclusive tile rectangle covered by the projection of a sphere (centre, radius).
fn sphere_rect(sphere: vec4<f32>) -> vec4<i32> {
    let all_tiles = vec4<i32>(0, 0, i32(binning.tiles_x) - 1, i32(binning.tiles_y) - 1);
    let rel = sphere.xyz - binning.origin;
    let z = dot(rel, binning.forward);
    let r = sphere.w;
    if z <= r * 1.0001 {
        // The sphere reaches the eye plane: it may cover any pixel.
        return all_tiles;
    }
    // Conservative extent in the image plane: the view-space box around the sphere, whose
    // corners project to the extreme tangents x/z and y/z.
    let x = dot(rel, binning.right);
    let y = dot(rel, binning.up);
    let near = z - r;
    let far = z + r;
    let sx = binning.tan_half_fov * binning.aspect;
    let sy = binning.tan_half_fov;
    let u0 = min((x - r) / near, (x - r) / far) / sx;
    let u1 = max((x + r) / near, (x + r) / far) / sx;
    let v0 = min((y - r) / near, (y - r) / far) / sy;
    let v1 = max((y + r) / near, (y + r) / far) / sy;
    let w = f32(binning.width);
    let h = f32(binning.height);
    let ts = f32(binning.tile_size);
    let px0 = (u0 + 1.0) * 0.5 * w - 1.0;
    let px1 = (u1 + 1.0) * 0.5 * w + 1.0;
    let py0 = (1.0 - v1) * 0.5 * h - 1.0;
    let py1 = (1.0 - v0) * 0.5 * h + 1.0;
    return vec4<i32>(
        max(i32(floor(px0 / ts)), 0),
        max(i32(floor(py0 / ts)), 0),
        min(i32(floor(px1 / ts)), i32(binning.tiles_x) - 1),
        min(i32(floor(py1 / ts)), i32(binning.tiles_y) - 1));
}

// The occluder ball of primitive i (centre, radius); radius 0 when it has none.
fn occluder_of(i: u32) -> vec4<f32> {
    let p = primitives[i];
    if p.kind == KIND_POINT {
        return vec4<f32>(p.a.xyz, p.occluder);
    } else if p.kind == KIND_DISTANCE_SEGMENT {
        return vec4<f32>(p.a.xyz + p.b.w * p.b.xyz, p.occluder);
    }
    return vec4<f32>(0.0);
}

// The support's hull (buffers.rs packs the support radius in `c.z`); the bounding sphere twice
// for the other kinds, which is tested against the beams the same way.
fn support_hull(i: u32) -> Hull {
    let p = primitives[i];
    if p.kind == KIND_POINT {
        let ball = vec4<f32>(p.a.xyz, p.a.w * p.c.z);
        return Hull(ball, ball);
    } else if p.kind == KIND_SCALIS_SEGMENT {
        let end = p.a.xyz + p.b.w * p.b.xyz;
        let end_radius = p.a.w + p.c.y * p.b.w;
        return Hull(vec4<f32>(p.a.xyz, p.a.w * p.c.z), vec4<f32>(end, end_radius * p.c.z));
    }
    return Hull(p.bound, p.bound);
}

// Image-plane coordinate of a pixel centre's column or row, as shared/supports.wgsl pixel_ray.
fn pixel_u(px: u32) -> f32 {
    return (2.0 * (f32(px) + 0.5) / f32(binning.width) - 1.0) * binning.tan_half_fov * binning.aspect;
}

fn pixel_v(py: u32) -> f32 {
    return (1.0 - 2.0 * (f32(py) + 0.5) / f32(binning.height)) * binning.tan_half_fov;
}

// `hull` in view coordinates (right, up, forward from the eye), once per primitive.
fn view_hull(hull: Hull) -> Hull {
    let view = mat3x3<f32>(binning.right, binning.up, binning.forward);
    return Hull(
        vec4<f32>((hull.a.xyz - binning.origin) * view, hull.a.w),
        vec4<f32>((hull.b.xyz - binning.origin) * view, hull.b.w));
}

// Whether `hull` (in view coordinates) lies beyond one side of the pyramid of `tile`'s pixel
// rays by more than `slack` of each ball's distance and size: the rays through pixel centres
// (u, v) reach the points (u·z, v·z, z), z ≥ 0, of view space, so the sides are x = u₀z,
// x = u₁z, y = v₀z and y = v₁z of the corner pixels.
fn beam_misses_hull(tile: u32, hull: Hull, slack: f32) -> bool {
    if binning.hulls == 0u || hull.a.w < 0.0 {
        return false;
    }
    let ts = binning.tile_size;
    let x0 = (tile % binning.tiles_x) * ts;
    let y0 = (tile / binning.tiles_x) * ts;
    let x1 = min(x0 + ts, binning.width) - 1u;
    let y1 = min(y0 + ts, binning.height) - 1u;
    let a = hull.a.xyz;
    let b = hull.b.xyz;
    // Each ball grown by `slack` of its distance and size.
    let reach_a = hull.a.w + slack * (length(a) + hull.a.w);
    let reach_b = hull.b.w + slack * (length(b) + hull.b.w);
    let sides = array<vec3<f32>, 4>(
        vec3<f32>(1.0, 0.0, -pixel_u(x0)),
        vec3<f32>(-1.0, 0.0, pixel_u(x1)),
        vec3<f32>(0.0, 1.0, -pixel_v(y1)),
        vec3<f32>(0.0, -1.0, pixel_v(y0)),
    );
    // A ball is beyond the side n·p = 0 (the beam on n·p ≥ 0) where n·c < −reach·|n|.
    for (var k = 0u; k < 4u; k++) {
        let n = sides[k];
        let limit = -length(n);
        if dot(n, a) < reach_a * limit && dot(n, b) < reach_b * limit {
            return true;
        }
    }
    return false;
}

// Direction of the ray through the centre of pixel (px, py), as shared/supports.wgsl pixel_ray.
fn pixel_direction(px: u32, py: u32) -> vec3<f32> {
    let u = (2.0 * (f32(px) + 0.5) / f32(binning.width) - 1.0) * binning.tan_half_fov * binning.aspect;
    let v = (1.0 - 2.0 * (f32(py) + 0.5) / f32(binning.height)) * binning.tan_half_fov;
    return normalize(binning.forward + u * binning.right + v * binning.up);
}

fn ray_meets_ball(dir: vec3<f32>, ball: vec4<f32>) -> bool {
    let m = ball.xyz - binning.origin;
    let along = dot(m, dir);
    let off = m - along * dir;
    return along > 0.0 && dot(off, off) < ball.w * ball.w;
}

// Whether every pixel ray of `tile` passes through `ball`: the rays that meet a ball form a
// convex cone, so the rays of the tile's corner pixels decide.
fn ball_covers(ball: vec4<f32>, tile: u32) -> bool {
    let ts = binning.tile_size;
    let tx = tile % binning.tiles_x;
    let ty = tile / binning.tiles_x;
    let x0 = tx * ts;
    let y0 = ty * ts;
    let x1 = min(x0 + ts, binning.width) - 1u;
    let y1 = min(y0 + ts, binning.height) - 1u;
    return ray_meets_ball(pixel_direction(x0, y0), ball) && ray_meets_ball(pixel_direction(x1, y0), ball)
        && ray_meets_ball(pixel_direction(x0, y1), ball) && ray_meets_ball(pixel_direction(x1, y1), ball);
}

fn occluding_depth(tile: u32) -> f32 {
    let marked = atomicLoad(&occluded[tile]);
    if marked == 0u {
        return INF;
    }
    return bitcast<f32>(~marked);
}

// Distance from the eye to primitive i's bounding sphere; −INF when unbounded or around the eye.
fn nearest_reach(i: u32) -> f32 {
    let bound = primitives[i].bound;
    if bound.w < 0.0 {
        return -INF;
    }
    let d = length(bound.xyz - binning.origin) - bound.w;
    return select(-INF, d, d > 0.0);
}

// The list of primitive i in `tile`: one per depth band (tile_binning.rs DEPTH_BANDS) of each
// tile, tile-major, so that a tile's lists follow one another and its primitives are listed
// band by band, nearest first: the first band holds the unbounded supports and those whose
// bounding sphere comes nearer the eye than band_near, each next band the next band_width.
fn band_list(tile: u32, reach: f32) -> u32 {
    var band = 0u;
    if reach >= binning.band_near {
        band = u32(min(1.0 + floor((reach - binning.band_near) / binning.band_width),
                       f32(DEPTH_BANDS - 1u)));
    }
    return tile * DEPTH_BANDS + band;
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
// Per primitive of the group: its occluder ball (occlude pass), its nearest reach (the others).
var<workgroup> group_balls: array<vec4<f32>, GROUP>;
var<workgroup> group_reaches: array<f32, GROUP>;
var<workgroup> group_hulls: array<Hull, GROUP>;

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
    return vec2<u32>(lo, ty * binning.tiles_x + tx);
}

// First pass: marks each tile with the least occluding depth of the balls covering it.
@compute @workgroup_size(64, 1, 1)
fn occlude_tiles(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
    @builtin(num_workgroups) slices: vec3<u32>,
) {
    let i = id.x;
    var rect = vec4<i32>(1, 1, 0, 0);
    var ball = vec4<f32>(0.0);
    if i < binning.primitive_count && binning.occluders != 0u {
        ball = occluder_of(i);
        // A ball around the eye, or behind the eye plane, occludes nothing here.
        if ball.w > 0.0 && dot(ball.xyz - binning.origin, binning.forward) > ball.w * 1.0001 {
            rect = sphere_rect(ball);
        }
    }
    group_balls[lid] = ball;
    let total = share_rects(lid, rect);
    for (var k = id.y * GROUP + lid; k < total; k += GROUP * slices.y) {
        let p = pair(k);
        let b = group_balls[p.x];
        if ball_covers(b, p.y) {
            atomicMax(&occluded[p.y], ~bitcast<u32>(length(b.xyz - binning.origin)));
        }
    }
}

// Second pass: counts the primitives per tile, leaving out the occluded ones.
@compute @workgroup_size(64, 1, 1)
fn count_tiles(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
    @builtin(num_workgroups) slices: vec3<u32>,
) {
    let i = id.x;
    var rect = vec4<i32>(1, 1, 0, 0);
    var reach = 0.0;
    var hull = Hull(vec4<f32>(0.0, 0.0, 0.0, -1.0), vec4<f32>(0.0, 0.0, 0.0, -1.0));
    if i < binning.primitive_count {
        rect = tile_rect(i);
        reach = nearest_reach(i);
        hull = view_hull(support_hull(i));
        if id.y == 0u {
            rects[i] = rect;
            nearest[i] = reach;
        }
    }
    group_reaches[lid] = reach;
    group_hulls[lid] = hull;
    let total = share_rects(lid, rect);
    for (var k = id.y * GROUP + lid; k < total; k += GROUP * slices.y) {
        let p = pair(k);
        let reach = group_reaches[p.x];
        if reach <= occluding_depth(p.y) && !beam_misses_hull(p.y, group_hulls[p.x], COUNT_SLACK) {
            atomicAdd(&tile_counts[band_list(p.y, reach)], 1u);
        }
    }
}

const SCAN_GROUP: u32 = 256u;
var<workgroup> chunk_ends: array<u32, SCAN_GROUP>;

// Third pass, one workgroup: each list's range from the counts (exclusive prefix sum), each
// thread over a contiguous chunk of lists, and the total.
@compute @workgroup_size(256, 1, 1)
fn scan_tiles(@builtin(local_invocation_index) lid: u32) {
    let tiles = binning.tiles_x * binning.tiles_y * DEPTH_BANDS;
    let chunk = (tiles + SCAN_GROUP - 1u) / SCAN_GROUP;
    let begin = min(lid * chunk, tiles);
    let end = min(begin + chunk, tiles);
    var sum = 0u;
    for (var t = begin; t < end; t++) {
        sum += atomicLoad(&tile_counts[t]);
    }
    chunk_ends[lid] = sum;
    workgroupBarrier();
    for (var offset = 1u; offset < SCAN_GROUP; offset *= 2u) {
        var before = 0u;
        if lid >= offset {
            before = chunk_ends[lid - offset];
        }
        workgroupBarrier();
        chunk_ends[lid] += before;
        workgroupBarrier();
    }
    var start = chunk_ends[lid] - sum;
    for (var t = begin; t < end; t++) {
        let next = start + atomicLoad(&tile_counts[t]);
        tile_ranges[t] = vec2<u32>(start, next);
        start = next;
    }
    if lid == SCAN_GROUP - 1u {
        list_total[0] = chunk_ends[lid];
    }
}

// Fourth pass: tile_counts has been reset to 0 and is used as each tile's cursor; the same
// primitives as counted are left out (the stored rectangles and reaches).
@compute @workgroup_size(64, 1, 1)
fn fill_tiles(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(local_invocation_index) lid: u32,
    @builtin(num_workgroups) slices: vec3<u32>,
) {
    let i = id.x;
    var rect = vec4<i32>(1, 1, 0, 0);
    var reach = 0.0;
    var hull = Hull(vec4<f32>(0.0, 0.0, 0.0, -1.0), vec4<f32>(0.0, 0.0, 0.0, -1.0));
    if i < binning.primitive_count {
        rect = rects[i];
        reach = nearest[i];
        hull = view_hull(support_hull(i));
    }
    group_reaches[lid] = reach;
    group_hulls[lid] = hull;
    let total = share_rects(lid, rect);
    let first = id.x - lid;
    for (var k = id.y * GROUP + lid; k < total; k += GROUP * slices.y) {
        let p = pair(k);
        let reach = group_reaches[p.x];
        if reach > occluding_depth(p.y) || beam_misses_hull(p.y, group_hulls[p.x], FILL_SLACK) {
            continue;
        }
        let list = band_list(p.y, reach);
        let slot = atomicAdd(&tile_counts[list], 1u);
        let range = tile_ranges[list];
        let at = range.x + slot;
        if at < range.y && at < arrayLength(&tile_items) {
            tile_items[at] = first + p.x;
        }
    }
}

// Fifth pass: a list's range ends where its fill's cursor stopped (tile_counts), which the fill
// left at or before the counted end (its beam test keeps fewer pairs; see the top).
@compute @workgroup_size(64, 1, 1)
fn close_tiles(
    @builtin(global_invocation_id) id: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
) {
    let lists = binning.tiles_x * binning.tiles_y * DEPTH_BANDS;
    for (var t = id.x; t < lists; t += 64u * groups.x) {
        let range = tile_ranges[t];
        tile_ranges[t] = vec2<u32>(range.x, min(range.x + atomicLoad(&tile_counts[t]), range.y));
    }
}
