//! Every struct the Rust side shares with the WGSL shaders has the WGSL layout: each named field
//! at its WGSL member's offset, and the same size (naga lays out the composed shaders).

use skeletrace_core::field::blend::BlendTree;
use skeletrace_core::methods::MethodId;

use crate::blend_wgsl::BlendWgsl;
use crate::buffers::{GpuKernel, GpuLight, GpuMaterial, GpuPrimitive};
use crate::gpu_renderer::GpuGlobals;
use crate::shaders::{GpuMethod, binning_source};
use crate::shared::KindSet;
use crate::tile_binning::GpuBinning;

/// A blend of `groups` summed groups.
fn summed(groups: u32) -> BlendWgsl {
    BlendWgsl::new(
        &BlendTree::Sum((0..groups).map(BlendTree::Group).collect()),
        groups as usize,
    )
}

/// Size and member offsets of WGSL struct `name` as naga lays it out.
fn wgsl_layout(source: &str, name: &str) -> (u32, Vec<(String, u32)>) {
    let module = naga::front::wgsl::parse_str(source).unwrap_or_else(|e| panic!("{e}"));
    module
        .types
        .iter()
        .find_map(|(_, ty)| match &ty.inner {
            naga::TypeInner::Struct { members, span } if ty.name.as_deref() == Some(name) => {
                let offsets = members
                    .iter()
                    .map(|m| (m.name.clone().unwrap_or_default(), m.offset))
                    .collect();
                Some((*span, offsets))
            }
            _ => None,
        })
        .unwrap_or_else(|| panic!("no struct {name}"))
}

/// The Rust twin's size and the offsets of its named fields.
macro_rules! rust_layout {
    ($ty:ty: $($field:ident),* $(,)?) => {
        (
            std::mem::size_of::<$ty>() as u32,
            vec![$((stringify!($field), std::mem::offset_of!($ty, $field) as u32)),*],
        )
    };
}

/// Every field of the Rust twin sits where its WGSL namesake does, and the sizes agree
/// (padding fields excepted by name).
fn check_twin(source: &str, wgsl: &str, (size, fields): (u32, Vec<(&str, u32)>)) {
    let (span, members) = wgsl_layout(source, wgsl);
    assert_eq!(span, size, "{wgsl}: WGSL size {span}, Rust size {size}");
    for (field, offset) in fields {
        let wgsl_offset = members
            .iter()
            .find(|(n, _)| n == field)
            .map(|(_, o)| *o)
            .unwrap_or_else(|| panic!("{wgsl}: no member {field} in WGSL"));
        assert_eq!(wgsl_offset, offset, "{wgsl}.{field}");
    }
    let named = members
        .iter()
        .filter(|(n, _)| !n.starts_with("pad"))
        .count();
    assert!(named > 0, "{wgsl}: no members");
}

#[test]
fn every_struct_shared_with_wgsl_has_the_rust_layout() {
    let trace = GpuMethod::from_id(MethodId::QuadraticTaylor)
        .unwrap_or_else(|| panic!("quadratic-taylor has a shader"))
        .source(&summed(2), KindSet::ALL);
    let binning = binning_source();
    check_twin(
        &trace,
        "Globals",
        rust_layout!(GpuGlobals: origin, far, forward, tan_half_fov, right, aspect, up,
            isovalue, width, height, tiles_x, tiles_y, primitive_count, group_count,
            max_steps, epsilon, min_step, growth, initial_interval, lipschitz,
            gauss_sigma, gauss_radius, gauss_norm, tile_size, light_count, panel_x,
            output_width, heat_max, heat_view, shading_flags, shading_scale,
            steps_per_dispatch, secondary, stats_crossings, bvh_unbounded, bvh_items,
            band_near, band_width, list_bands, loop_probe),
    );
    check_twin(
        &binning,
        "Binning",
        rust_layout!(GpuBinning: origin, forward, tan_half_fov, right, aspect, up, tiles_x,
            tiles_y, tile_size, primitive_count, width, height, occluders, band_near,
            band_width, hulls),
    );
    for source in [&trace, &binning] {
        check_twin(
            source,
            "Primitive",
            rust_layout!(GpuPrimitive: kind, group, occluder, extra, a, b, c, d, bound),
        );
    }
    check_twin(
        &trace,
        "Kernel",
        rust_layout!(GpuKernel: family, kinked, clamped, exponent, inv_sigma2, support_sq,
            clip, clip_scale),
    );
    check_twin(&trace, "Light", rust_layout!(GpuLight: vector, colour));
    check_twin(&trace, "Material", rust_layout!(GpuMaterial: colour, ior));
    check_twin(
        &trace,
        "BvhNode",
        rust_layout!(crate::ray_bvh::GpuBvhNode: min, skip, max, leaf),
    );
    check_twin(
        &trace,
        "StatsRay",
        rust_layout!(crate::ray_lists::GpuStatsRay: origin, far, dir, list),
    );
}
