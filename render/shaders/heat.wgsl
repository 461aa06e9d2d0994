// The step-count colour map (Turbo polynomial, coefficients TURBO_* emitted by shared.rs; the
// same as core::frame::heat_colour), shared by main.wgsl and the viewport's blit.

fn turbo_channel(x: f32, c: array<f32, 6>) -> f32 {
    return clamp(c[0] + x * (c[1] + x * (c[2] + x * (c[3] + x * (c[4] + x * c[5])))), 0.0, 1.0);
}

// sRGB in [0, 1] at x in [0, 1].
fn heat_colour(x_in: f32) -> vec3<f32> {
    let x = clamp(x_in, 0.0, 1.0);
    return vec3<f32>(
        turbo_channel(x, TURBO_RED),
        turbo_channel(x, TURBO_GREEN),
        turbo_channel(x, TURBO_BLUE));
}
