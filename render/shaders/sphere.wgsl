// Sphere tracing with the global Lipschitz bound (core: methods/sphere.rs): the symmetric
// inclusion f ± L·s of forward-inclusion eq. 10, marched by march.wgsl.

fn method_bound(sp: ptr<function, RaySupports>, ray: Ray, t: f32, f: f32, d: f32, h: f32) -> Inclusion {
    return symmetric(f, frame.globals.lipschitz, INF);
}
