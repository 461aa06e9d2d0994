// The pixel's ray and its supports: the window of supports a ray crosses and the parts of
// the ray inside their union (core field/ray_field.rs, field/program.rs ray_support_unions_in).

// A window of the supports a ray crosses within [0, far]: the RAY_SUPPORTS of them with the
// smallest entries among those leaving after `floor`, sorted by entry. Every support that
// overlaps [floor, horizon) is in the window; when the ray gets past `horizon`, `next_part`
// refills the window from the tile list (the 2021 paper §7 keeps a heap of the
// primitives overlapping the current interval, algorithm 2). Refilling
// instead of walking the whole tile list keeps a ray's loop iterations far below lavapipe's
// per-invocation limit of 65 535.
struct RaySupports {
    count: u32,
    list: u32,     // the first of the ray's lists in tile_ranges (one per depth band)
    horizon: f32,
    floor: f32,    // of the last fill, kept for a suspended march to refill the same window
    far: f32,      // end of the ray's interval
    listed: bool,  // the supports come from a tile list; false: every primitive (gather_every)
    ids: array<u32, RAY_SUPPORTS>,
    spans: array<vec2<f32>, RAY_SUPPORTS>,
};


fn pixel_ray(px: u32, py: u32) -> Ray {
    let w = f32(frame.globals.width);
    let h = f32(frame.globals.height);
    let u = (2.0 * (f32(px) + 0.5) / w - 1.0) * frame.globals.tan_half_fov * frame.globals.aspect;
    let v = (1.0 - 2.0 * (f32(py) + 0.5) / h) * frame.globals.tan_half_fov;
    let dir = normalize(frame.globals.forward + u * frame.globals.right + v * frame.globals.up);
    return Ray(frame.globals.origin, dir);
}

// Fills the window with the supports of the ray's list (a tile's, or with gather_every the
// primitives the hierarchy finds on the ray, then the unbounded ones) that the ray leaves after
// `floor`. Each candidate goes to one call of `window_take`, which the shader compilers inline
// with `support_interval`, the largest function a pipeline holds; the walk finds the next
// candidate in a loop of its own, so that a SIMD row's rays take theirs together.
fn fill_window(sp: ptr<function, RaySupports>, ray: Ray, floor: f32) {
    (*sp).count = 0u;
    (*sp).horizon = INF;
    (*sp).floor = floor;
    let listed = (*sp).listed;
    var j = 0u;
    var end = 0u;
    var band = 0u;
    if listed {
        let range = band_range((*sp).list);
        j = range.x;
        end = range.y;
    }
    let node_count = select(arrayLength(&bvh_nodes), 0u, listed);
    var node = 0u;
    var unbounded = !listed;
    loop {
        var i = 0u;
        var found = false;
        loop {
            if j < end {
                if listed {
                    i = tile_items[j];
                } else {
                    i = bvh_items[j];
                }
                j += 1u;
                found = true;
                break;
            }
            if listed && band + 1u < frame.globals.list_bands {
                // The next band's supports are at least `nearest` from the eye (binning.wgsl
                // band_list), less a margin for rounding. Where that is past the ray's end, or
                // past the horizon of a full window, none of them would be taken, nor move the
                // horizon (window_take): the window is complete.
                band += 1u;
                let lower = frame.globals.band_near + f32(band - 1u) * frame.globals.band_width;
                let nearest = lower - 1e-3 * (lower + frame.globals.band_width);
                if nearest > (*sp).far || ((*sp).count == RAY_SUPPORTS && nearest >= (*sp).horizon) {
                    break;
                }
                let range = band_range((*sp).list + band);
                j = range.x;
                end = range.y;
                continue;
            }
            if node < node_count {
                // A node whose box the ray's line misses, or meets only before the floor or
                // past the ray's end, holds no support the window takes: skipped whole. A
                // leaf's items are the next candidates.
                let n = bvh_nodes[node];
                let span = box_interval(ray.origin, ray.dir, n.min, n.max);
                let count = n.leaf & 7u;
                if span.x > span.y || span.y < max(floor, 0.0) || span.x > (*sp).far {
                    node = n.skip;
                } else if count == 0u {
                    node += 1u;
                } else {
                    j = n.leaf >> 3u;
                    end = j + count;
                    node = n.skip;
                }
                continue;
            }
            if unbounded {
                unbounded = false;
                j = frame.globals.bvh_unbounded;
                end = frame.globals.bvh_items;
                continue;
            }
            break;
        }
        if !found {
            break;
        }
        window_take(sp, ray, i);
    }
}

// Takes primitive `i` into the window if the ray leaves its support after the window's
// floor: the window keeps the RAY_SUPPORTS earliest entries, sorted, and its horizon is the
// earliest entry it could not keep.
fn window_take(sp: ptr<function, RaySupports>, ray: Ray, i: u32) {
    var span = support_interval(ray, i);
    span = vec2<f32>(max(span.x, 0.0), min(span.y, (*sp).far));
    if span.x > span.y || span.y <= (*sp).floor {
        return;
    }
    var k = (*sp).count;
    if k == RAY_SUPPORTS {
        // Full: the later entry of the newcomer and the last kept one bounds the window.
        let last = (*sp).spans[k - 1u].x;
        if span.x >= last {
            (*sp).horizon = min((*sp).horizon, span.x);
            return;
        }
        (*sp).horizon = min((*sp).horizon, last);
        k -= 1u;
    } else {
        (*sp).count += 1u;
    }
    // Insertion by entry.
    while k > 0u && (*sp).spans[k - 1u].x > span.x {
        (*sp).spans[k] = (*sp).spans[k - 1u];
        (*sp).ids[k] = (*sp).ids[k - 1u];
        k -= 1u;
    }
    (*sp).spans[k] = span;
    (*sp).ids[k] = i;
}

fn gather_supports(sp: ptr<function, RaySupports>, ray: Ray, px: u32, py: u32, floor: f32) {
    let ts = frame.globals.tile_size;
    gather_list(sp, ray, (py / ts) * frame.globals.tiles_x + px / ts, frame.globals.far, floor);
}

// The supports along `ray` over [floor, far] among those of list `list` (a tile's, made of
// frame.globals.list_bands lists in tile_ranges).
fn gather_list(sp: ptr<function, RaySupports>, ray: Ray, list: u32, far: f32, floor: f32) {
    (*sp).far = far;
    (*sp).list = list * frame.globals.list_bands;
    (*sp).listed = true;
    fill_window(sp, ray, floor);
}

// The items of list `list` in tile_items. A list past the items' end (the host grows them and
// traces again, tile_binning.rs) is read only as far as it was written.
fn band_range(list: u32) -> vec2<u32> {
    let range = tile_ranges[list];
    let written = arrayLength(&tile_items);
    return vec2<u32>(min(range.x, written), min(range.y, written));
}

// The supports along `ray` over [floor, far] among every primitive: a secondary ray (main.wgsl
// trace_path) or a statistics ray off the axes leaves the screen tiles, and is traced against
// the whole scene as on the CPU, whose primitives the hierarchy (bvh_nodes) finds.
fn gather_every(sp: ptr<function, RaySupports>, ray: Ray, far: f32, floor: f32) {
    (*sp).far = far;
    (*sp).listed = false;
    fill_window(sp, ray, floor);
}

// Where the window of ray `k`'s march starts: the floor its suspended march left (parts.wgsl),
// whose window the march goes on with, or 0 for a march that begins. One fill per dispatch.
fn resumed_floor(k: u32) -> f32 {
    let s = suspensions[k];
    return select(0.0, s.window_floor, (s.flags & SUSPENDED) != 0u);
}

fn support_count(sp: ptr<function, RaySupports>) -> u32 {
    return (*sp).count;
}

struct SupportItem {
    id: u32,
    span: vec2<f32>,
};

fn support_item(sp: ptr<function, RaySupports>, ray: Ray, j: u32) -> SupportItem {
    return SupportItem((*sp).ids[j], (*sp).spans[j]);
}

// The part of the ray inside the union of supports that starts at or after `start_at`: (lo, hi),
// empty (x > y) when none is left. A part is cut at the window's horizon; the next call then
// refills the window from there.
fn next_part(sp: ptr<function, RaySupports>, ray: Ray, start_at: f32) -> vec2<f32> {
    if start_at >= (*sp).horizon {
        fill_window(sp, ray, start_at);
    }
    var lo = INF;
    var hi = -INF;
    for (var j = 0u; j < (*sp).count; j++) {
        let s = (*sp).spans[j];
        if s.y <= start_at {
            continue;
        }
        if lo == INF {
            lo = max(s.x, start_at);
            hi = s.y;
        } else if s.x <= hi {
            hi = max(hi, s.y);
        } else {
            break;
        }
    }
    if lo == INF {
        return vec2<f32>(INF, -INF);
    }
    // The part is cut where the ray enters or leaves an HRBF set's box inside it: the field may
    // jump there (program.rs ray_support_unions_in, cut_boxes).
    for (var j = 0u; j < select(0u, (*sp).count, HAS_HRBF); j++) {
        if primitives[(*sp).ids[j]].kind != KIND_HRBF {
            continue;
        }
        let s = (*sp).spans[j];
        if lo < s.x && s.x < hi {
            hi = s.x;
        }
        if lo < s.y && s.y < hi {
            hi = s.y;
        }
    }
    // More than RAY_SUPPORTS supports overlap at lo: the window is incomplete there; march a
    // minimum step with what it holds rather than stall.
    return vec2<f32>(lo, min(hi, max((*sp).horizon, lo + frame.globals.min_step)));
}
