//! The CPU renderer: one primary ray per pixel through the scene camera, traced by any method,
//! giving a [`Frame`] of colour, depth and step counts (DESIGN.md: `FieldProgram` → tracer →
//! `Frame`). Shading is Blinn–Phong with analytic normals (`−∇f`, the field grows inwards) and
//! optional shadow rays. Groups with opacity below 1 are rendered as in forward-inclusion 2023
//! §7.2: at each crossing of a transparent group the ray splits into a reflected and a refracted
//! ray (Snell's law with the group's index of refraction, Schlick's Fresnel term), up to
//! [`MAX_BOUNCES`] levels; the refracted ray starts inside and its first crossing is the exit.
//!
//! With [`FieldShading`], soft shadows and ambient occlusion are estimated from the field
//! (2014 notes §12.4, `shading.rs`) instead of, or on top of, exact shadow rays.
//!
//! The step count of a pixel is that of its primary ray; when the scene has transparent
//! groups, it is the sum over the reflected and refracted rays too (every crossing along the
//! path must be found, as in the paper's transparency tables). Shadow rays are not counted.

use glam::DVec3;
use rayon::prelude::*;

use crate::backend::Cancel;
use crate::bounds::interval::Interval;
use crate::compile::Compiled;
use crate::cpu::shading::{ambient_occlusion, soft_shadow};
use crate::field::geometry::Ray;
use crate::field::program::FieldProgram;
use crate::field::ray_field::{RayField, TileCandidates};
use crate::frame::{FieldShading, Frame, MAX_BOUNCES, PinholeCamera, far_distance, shading_scale};
use crate::methods::{RayTracer, Trace, TraceMode, TraceSettings};
use crate::model::scene::{Camera, Light, Material};
use crate::scratch::ScratchPool;

/// A traced pixel: colour, depth of the first crossing and steps.
type Pixel = ([f32; 3], f64, u32);

/// A screen tile's pixels, its candidate primitives, whether the whole tile was copied from
/// an earlier frame, and how many of its pixels were.
type TileOutcome = (Vec<Pixel>, Vec<u32>, bool, usize);

/// Side of the square screen tiles whose camera rays share one candidate list.
const TILE: usize = 8;

/// Options of a render.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderOptions {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Cast shadow rays towards each light.
    pub shadows: bool,
    /// Soft shadows and ambient occlusion from the field.
    pub shading: FieldShading,
}

/// A frame traced earlier by the same method through the same camera and options, on a
/// program that differs from this one in the primitives `changed` flags only
/// ([`Renderer::render_reusing`]).
pub struct EarlierFrame<'f> {
    /// Its pixels.
    pub frame: &'f Frame,
    /// Each tile's candidate primitives ([`TracedFrame::tile_primitives`]).
    pub tile_primitives: &'f [Vec<u32>],
    /// The primitives changed since, one flag per primitive of this renderer's program.
    pub changed: &'f [bool],
    /// The program it was traced on.
    pub program: &'f FieldProgram,
}

/// A frame with what a later one needs to reuse its tiles.
pub struct TracedFrame {
    /// The pixels.
    pub frame: Frame,
    /// Each screen tile's candidate primitives, in their order (row-major tiles).
    pub tile_primitives: Vec<Vec<u32>>,
    /// How many tiles were copied whole from the earlier frame.
    pub reused_tiles: usize,
    /// How many pixels were copied from the earlier frame: those of the tiles copied whole,
    /// and the rays of the other tiles that no changed primitive reaches.
    pub reused_pixels: usize,
}

/// The changed primitives the rays of a tile traced again after an edit may meet
/// ([`Renderer::render_reusing`]): those of the tile's earlier list, in the earlier program,
/// and those of its list now. A ray that meets none of them, as they were or as they are,
/// asks its questions of the same unchanged primitives in the same order as in the earlier
/// frame (its other candidates are left out both times, `RayField::leaves_out`), so its
/// pixel is the earlier one.
struct EditReach {
    before: Vec<u32>,
    now: Vec<u32>,
}

impl EditReach {
    /// The changed primitives of tile `tile`'s lists, or `None` where its unchanged
    /// candidates are not those it had, in the same order: then every ray is traced again.
    fn of_tile(earlier: &EarlierFrame<'_>, tile: usize, listed: &[u32]) -> Option<Self> {
        let then = &earlier.tile_primitives[tile];
        let changed = |i: &&u32| earlier.changed[**i as usize];
        let unchanged = |i: &&u32| !changed(i);
        then.iter()
            .filter(unchanged)
            .eq(listed.iter().filter(unchanged))
            .then(|| Self {
                before: then.iter().filter(changed).copied().collect(),
                now: listed.iter().filter(changed).copied().collect(),
            })
    }

    /// Whether no changed primitive is in the tile's lists: its pixels are the earlier ones.
    fn is_empty(&self) -> bool {
        self.before.is_empty() && self.now.is_empty()
    }

    /// Whether `ray` (on `span`) may meet a changed primitive, in the program `before` the
    /// edit or in the program `now`.
    fn meets(
        &self,
        ray: &Ray,
        span: Interval,
        (before, now): (&FieldProgram, &FieldProgram),
    ) -> bool {
        let meets_in = |program, list: &[u32]| {
            list.iter()
                .any(|&i| !RayField::leaves_out(program, ray, span, i))
        };
        meets_in(before, &self.before) || meets_in(now, &self.now)
    }
}

/// A compiled scene bound to a method, ready to render frames through any camera.
pub struct Renderer<'a> {
    program: &'a FieldProgram,
    tracer: &'a dyn RayTracer,
    settings: TraceSettings,
    materials: &'a [Material],
    lights: &'a [Light],
    scale: f64,
}

/// What one frame's rays share: its options and the far distance of its camera.
struct FrameContext {
    options: RenderOptions,
    far: f64,
}

/// What shading needs of the field at a ray's first crossing.
struct SurfacePoint {
    gradient: DVec3,
    material: Material,
}

impl<'a> Renderer<'a> {
    /// Binds `tracer` (prepared on `compiled.program` with `settings`) to the compiled
    /// scene's materials and lights.
    #[must_use]
    pub fn new(compiled: &'a Compiled, tracer: &'a dyn RayTracer, settings: TraceSettings) -> Self {
        Self {
            program: &compiled.program,
            tracer,
            settings,
            materials: &compiled.materials,
            lights: &compiled.lights,
            scale: shading_scale(&compiled.program),
        }
    }

    /// Renders the view of `camera`; rays reach just past the farthest support seen from it.
    #[must_use]
    pub fn render(&self, camera: &Camera, options: RenderOptions) -> Frame {
        match self.render_unless_cancelled(camera, options, &Cancel::new()) {
            Some(frame) => frame,
            // Nobody else holds this flag: it is never set.
            None => unreachable!("a private cancel flag was set"),
        }
    }

    /// As [`Renderer::render`], but every pixel first checks `cancel`: `None` once it is set.
    #[must_use]
    pub fn render_unless_cancelled(
        &self,
        camera: &Camera,
        options: RenderOptions,
        cancel: &Cancel,
    ) -> Option<Frame> {
        self.render_reusing(camera, options, cancel, None)
            .map(|traced| traced.frame)
    }

    /// As [`Renderer::render_unless_cancelled`], taking from `earlier` the pixels it may: a
    /// tile whose candidates are those it had in `earlier`'s frame, in the same order, none
    /// of them changed since, has the same rays over the same primitives, so its pixels are
    /// copied instead of traced; in a tile whose unchanged candidates are those it had, in
    /// the same order, a ray that meets no changed primitive, as it was or as it is, is
    /// copied too ([`EditReach`]). The caller vouches for the rest (`earlier` was traced by
    /// this method, through this camera, with these options, on a program that differs from
    /// this one only in the primitives `earlier.changed` flags, with no global shading and
    /// no transparent group: `cpu_backend.rs`).
    #[must_use]
    pub fn render_reusing(
        &self,
        camera: &Camera,
        options: RenderOptions,
        cancel: &Cancel,
        earlier: Option<&EarlierFrame<'_>>,
    ) -> Option<TracedFrame> {
        let (w, h) = (options.width.max(1), options.height.max(1));
        let pinhole = PinholeCamera::new(camera);
        let context = FrameContext {
            options,
            far: far_distance(self.program, camera),
        };
        let span = Interval::new(0.0, context.far);
        let (columns, rows) = (w.div_ceil(TILE), h.div_ceil(TILE));
        let earlier = earlier.filter(|e| {
            (e.frame.width, e.frame.height) == (w, h) && e.tile_primitives.len() == columns * rows
        });
        // One BVH walk per tile gathers its camera rays' candidates (`TileCandidates`); tiles
        // are scheduled over the threads, each tile's rays traced together. Each tile is a
        // job of its own (`with_max_len(1)`): rayon's adaptive split otherwise leaves runs of
        // tiles that no thread can steal from once begun, and a thread that ran out of work
        // waited for the other's run to end (the creature at 797×734 on two threads: 11 % of
        // the frame idle, now 0.5 %).
        let tiles: Option<Vec<TileOutcome>> = (0..columns * rows)
            .into_par_iter()
            .with_max_len(1)
            .map(|tile| {
                if cancel.is_cancelled() {
                    return None;
                }
                let ((x0, x1), (y0, y1)) = tile_pixels(tile, w, h);
                let corners = pinhole.tile_corners((x0, x1), (y0, y1), w, h);
                let candidates =
                    TileCandidates::gather(self.program, pinhole.origin(), corners, span);
                let listed: Vec<u32> = candidates.primitives().collect();
                let mut pixels = Vec::with_capacity((x1 - x0) * (y1 - y0));
                let copy = |pixels: &mut Vec<Pixel>, f: &Frame, x: usize, y: usize| {
                    let i = y * w + x;
                    pixels.push((f.colour[i], f.depth[i], f.steps[i]));
                };
                let reach = earlier.and_then(|e| EditReach::of_tile(e, tile, &listed));
                if let (Some(earlier), Some(reach)) = (earlier, &reach)
                    && reach.is_empty()
                {
                    for y in y0..y1 {
                        for x in x0..x1 {
                            copy(&mut pixels, earlier.frame, x, y);
                        }
                    }
                    let copied = pixels.len();
                    return Some((pixels, listed, true, copied));
                }
                // A tile that lists no primitive, in a scene without unbounded ones (planes):
                // its rays' fields are empty, so every method's trace is empty (no support,
                // no part, no step) and the rays are background.
                let nothing_to_meet =
                    candidates.is_empty() && self.program.lookup_parts().1.is_empty();
                let mut copied = 0;
                for y in y0..y1 {
                    for x in x0..x1 {
                        let ray = pinhole.ray(x, y, w, h);
                        if let (Some(earlier), Some(reach)) = (earlier, &reach)
                            && !reach.meets(&ray, span, (earlier.program, self.program))
                        {
                            copy(&mut pixels, earlier.frame, x, y);
                            copied += 1;
                            continue;
                        }
                        if nothing_to_meet {
                            pixels.push((
                                background(ray.direction).as_vec3().to_array(),
                                f64::INFINITY,
                                0,
                            ));
                            continue;
                        }
                        // The field gives the crossing's normal and material, then is
                        // dropped before shading, so that the shadow rays' fields reuse its
                        // arrays.
                        let (trace, surface) = {
                            let field = RayField::from_tile(self.program, &ray, span, &candidates);
                            let trace = self.tracer.trace_field(&field, TraceMode::Opaque);
                            let surface = trace.first().map(|hit| self.surface_on(&field, hit.t));
                            (trace, surface)
                        };
                        let mut steps = 0;
                        let (colour, depth) =
                            self.shade_trace(&ray, &trace, surface, 0, &context, &mut steps);
                        pixels.push((colour.as_vec3().to_array(), depth, steps));
                    }
                }
                Some((pixels, listed, false, copied))
            })
            .collect();
        let tiles = tiles?;
        let mut colour = vec![[0.0; 3]; w * h];
        let mut depth = vec![f64::INFINITY; w * h];
        let mut steps = vec![0; w * h];
        for (tile, (pixels, ..)) in tiles.iter().enumerate() {
            let ((x0, x1), (y0, _)) = tile_pixels(tile, w, h);
            for (k, pixel) in pixels.iter().enumerate() {
                let i = (y0 + k / (x1 - x0)) * w + x0 + k % (x1 - x0);
                (colour[i], depth[i], steps[i]) = *pixel;
            }
        }
        let reused_tiles = tiles.iter().filter(|(_, _, whole, _)| *whole).count();
        let reused_pixels = tiles.iter().map(|(.., copied)| copied).sum();
        Some(TracedFrame {
            frame: Frame {
                width: w,
                height: h,
                colour,
                depth,
                steps,
            },
            tile_primitives: tiles.into_iter().map(|(_, listed, ..)| listed).collect(),
            reused_tiles,
            reused_pixels,
        })
    }

    /// Colour seen along `ray` and the distance of its first crossing.
    fn radiance(
        &self,
        ray: &Ray,
        bounce: u32,
        context: &FrameContext,
        steps: &mut u32,
    ) -> (DVec3, f64) {
        let trace = self
            .tracer
            .trace(ray, Interval::new(0.0, context.far), TraceMode::Opaque);
        let surface = trace.first().map(|hit| SurfacePoint {
            gradient: self.program.value_gradient(ray.at(hit.t)).1,
            material: self.material_at(ray, hit.t),
        });
        self.shade_trace(ray, &trace, surface, bounce, context, steps)
    }

    /// The gradient and material at the crossing `ray.at(t)` of a camera ray, from its field:
    /// the same bits as from the program, without walking the BVH.
    fn surface_on(&self, field: &RayField, t: f64) -> SurfacePoint {
        thread_local! {
            static GROUP_VALUES: ScratchPool<Vec<(f64, f64)>> = const { ScratchPool::new() };
        }
        // The gradient first, then the groups' values, as the field was asked before.
        let gradient = field.value_gradient(t).1;
        let mut values = ScratchPool::take(&GROUP_VALUES);
        values.resize(self.program.group_count(), (0.0, 0.0));
        field.add_group_values(t, &mut values);
        let material = self.material_of(&values);
        ScratchPool::give_back(&GROUP_VALUES, values);
        SurfacePoint { gradient, material }
    }

    /// Colour seen along `ray`, traced as `trace`, whose first crossing is at `surface`, and
    /// the distance of that crossing.
    fn shade_trace(
        &self,
        ray: &Ray,
        trace: &Trace,
        surface: Option<SurfacePoint>,
        bounce: u32,
        context: &FrameContext,
        steps: &mut u32,
    ) -> (DVec3, f64) {
        *steps += trace.steps;
        let (Some(hit), Some(SurfacePoint { gradient, material })) = (trace.first(), surface)
        else {
            return (background(ray.direction), f64::INFINITY);
        };
        let p = ray.at(hit.t);
        let outward = (-gradient).normalize_or(-ray.direction);
        let lit = self.shade(p, outward, ray.direction, &material, context);
        if material.opacity >= 1.0 || bounce >= MAX_BOUNCES {
            return (lit, hit.t);
        }
        // Transparent: Fresnel-weighted reflection and refraction.
        let facing = if outward.dot(ray.direction) < 0.0 {
            outward
        } else {
            -outward
        };
        let eta = if hit.entering {
            1.0 / material.ior
        } else {
            material.ior
        };
        let cos_i = -facing.dot(ray.direction);
        let f0 = ((1.0 - material.ior) / (1.0 + material.ior)).powi(2);
        let fresnel = f0 + (1.0 - f0) * (1.0 - cos_i).powi(5);
        let offset = 2.0 * self.settings.min_step;
        let reflected_dir = ray.direction + 2.0 * cos_i * facing;
        let (reflected, _) = self.radiance(
            &Ray::new(p + offset * facing, reflected_dir),
            bounce + 1,
            context,
            steps,
        );
        let k = 1.0 - eta * eta * (1.0 - cos_i * cos_i);
        let through = if k < 0.0 {
            reflected
        } else {
            let refracted_dir = eta * ray.direction + (eta * cos_i - k.sqrt()) * facing;
            let (c, _) = self.radiance(
                &Ray::new(p - offset * facing, refracted_dir),
                bounce + 1,
                context,
                steps,
            );
            c * DVec3::from_array(material.color).lerp(DVec3::ONE, 0.5)
        };
        let glass = fresnel * reflected + (1.0 - fresnel) * through;
        let opacity = material.opacity;
        (opacity * lit + (1.0 - opacity) * glass, hit.t)
    }

    /// Material of the group contributing most at the crossing.
    fn material_at(&self, ray: &Ray, t: f64) -> Material {
        self.material_of(&self.program.group_values_along_ray(ray, t))
    }

    /// Material of the group whose value in `values` (one `(f, f′)` per group) is largest.
    fn material_of(&self, values: &[(f64, f64)]) -> Material {
        let best = values
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.0.total_cmp(&b.1.0))
            .map_or(0, |(i, _)| i);
        self.materials.get(best).copied().unwrap_or_default()
    }

    /// Blinn–Phong with the scene lights.
    fn shade(
        &self,
        p: DVec3,
        normal: DVec3,
        view: DVec3,
        material: &Material,
        context: &FrameContext,
    ) -> DVec3 {
        let albedo = DVec3::from_array(material.color);
        let lifted = p + 2.0 * self.settings.min_step * normal;
        let occlusion = if context.options.shading.ambient_occlusion {
            ambient_occlusion(self.program, p, normal, self.scale)
        } else {
            1.0
        };
        let mut colour = 0.12 * occlusion * albedo;
        for light in self.lights {
            let (to_light, distance, light_colour, intensity) = match light {
                Light::Directional {
                    direction,
                    color,
                    intensity,
                } => (
                    DVec3::from_array(*direction).normalize_or(DVec3::Y),
                    context.far,
                    *color,
                    *intensity,
                ),
                Light::Point {
                    position,
                    color,
                    intensity,
                } => {
                    let d = DVec3::from_array(*position) - p;
                    (d.normalize_or(DVec3::Y), d.length(), *color, *intensity)
                }
            };
            let diffuse = normal.dot(to_light);
            if diffuse <= 0.0 {
                continue;
            }
            let mut transmitted = if context.options.shadows {
                self.transmittance(lifted, to_light, distance)
            } else {
                1.0
            };
            if context.options.shading.soft_shadows && transmitted > 0.0 {
                transmitted *= soft_shadow(self.program, lifted, to_light, distance, self.scale);
            }
            if transmitted <= 0.0 {
                continue;
            }
            let half = (to_light - view).normalize_or(normal);
            let specular = normal.dot(half).max(0.0).powf(48.0) * 0.35;
            colour += transmitted
                * (0.5 + 0.5 * occlusion)
                * intensity
                * DVec3::from_array(light_colour)
                * (diffuse * albedo + specular);
        }
        colour
    }

    /// Fraction of light reaching `from` along `direction`: 0 behind an opaque group, `1 −
    /// opacity` behind the first transparent one (no caustics).
    fn transmittance(&self, from: DVec3, direction: DVec3, distance: f64) -> f64 {
        let ray = Ray::new(from, direction);
        let trace = self
            .tracer
            .trace(&ray, Interval::new(0.0, distance), TraceMode::Opaque);
        trace
            .first()
            .map_or(1.0, |hit| 1.0 - self.material_at(&ray, hit.t).opacity)
    }
}

/// Tile `k`'s pixel columns `x0..x1` and rows `y0..y1` in a `w × h` frame (row-major tiles).
fn tile_pixels(k: usize, w: usize, h: usize) -> ((usize, usize), (usize, usize)) {
    let columns = w.div_ceil(TILE);
    let (x0, y0) = ((k % columns) * TILE, (k / columns) * TILE);
    ((x0, (x0 + TILE).min(w)), (y0, (y0 + TILE).min(h)))
}

/// Sky gradient behind the surface.
fn background(direction: DVec3) -> DVec3 {
    let up = 0.5 * (direction.y + 1.0);
    DVec3::new(0.16, 0.17, 0.20).lerp(DVec3::new(0.42, 0.47, 0.55), up)
}

#[cfg(test)]
mod tests {
    //! The tile path ([`Renderer::render`]: candidates gathered once per tile, empty tiles
    //! given the background without a trace) shades every pixel as [`Renderer::radiance`]
    //! does for the same ray traced alone through the BVH: colour, depth and steps, bit for bit.
    use super::*;
    use crate::compile;
    use crate::methods::MethodId;
    use crate::model::generate::{GenerateOptions, GeneratorKind, generate};
    use crate::model::scene::Scene;

    /// Pixels of `scene`'s frame (`width × height`, with shadows) that differ from their ray
    /// traced alone, per method, as messages.
    fn differences(scene: &Scene, name: &str, (width, height): (usize, usize)) -> Vec<String> {
        let compiled = compile(scene);
        let options = RenderOptions {
            width,
            height,
            shadows: true,
            shading: FieldShading::default(),
        };
        let pinhole = PinholeCamera::new(&scene.camera);
        let context = FrameContext {
            options,
            far: far_distance(&compiled.program, &scene.camera),
        };
        let mut failures = Vec::new();
        for id in MethodId::ALL {
            let method = id.method();
            if id == MethodId::Reference || method.supports(&compiled.program).is_err() {
                continue;
            }
            let tracer = method.prepare(&compiled.program, compiled.settings);
            let renderer = Renderer::new(&compiled, tracer.as_ref(), compiled.settings);
            let frame = renderer.render(&scene.camera, options);
            let differing = (0..width * height)
                .filter(|&i| {
                    let ray = pinhole.ray(i % width, i / width, width, height);
                    let mut steps = 0;
                    let (colour, depth) = renderer.radiance(&ray, 0, &context, &mut steps);
                    colour.as_vec3().to_array() != frame.colour[i]
                        || depth.to_bits() != frame.depth[i].to_bits()
                        || steps != frame.steps[i]
                })
                .count();
            if differing > 0 {
                failures.push(format!("{name}: {}: {differing} pixels differ", id.name()));
            }
        }
        failures
    }

    fn asset(name: &str) -> Scene {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../assets/scenes")
            .join(name);
        Scene::load(&path).unwrap_or_else(|e| panic!("{e}"))
    }

    /// The tree has tiles that list nothing and no plane (the empty-tile shortcut); the
    /// creature has a ground plane (no shortcut) and shadows; random skeletons and blob sets
    /// of random seeds and sizes, seen from their generated cameras, have both kinds of tile.
    #[test]
    fn tile_frames_shade_every_pixel_as_its_ray_traced_alone() {
        let mut scenes = vec![
            ("tree.ron".to_owned(), asset("tree.ron")),
            ("creature.ron".to_owned(), asset("creature.ron")),
        ];
        for seed in 0..3 {
            for kind in [GeneratorKind::RandomSkeleton, GeneratorKind::Blobs] {
                let options = GenerateOptions {
                    seed: 1_000 + seed,
                    size: Some(6 + 9 * seed as usize),
                    ..GenerateOptions::default()
                };
                let scene = generate(kind, &options).unwrap_or_else(|e| panic!("{e}"));
                scenes.push((format!("{} seed {}", kind.name(), options.seed), scene));
            }
        }
        let failures: Vec<String> = scenes
            .par_iter()
            .flat_map_iter(|(name, scene)| differences(scene, name, (27, 19)))
            .collect();
        assert!(failures.is_empty(), "{}", failures.join("\n"));
    }

    /// The check above does exercise the shortcut: some of the tree's tiles list nothing.
    #[test]
    fn the_tree_has_tiles_that_list_nothing() {
        let scene = asset("tree.ron");
        let compiled = compile(&scene);
        let pinhole = PinholeCamera::new(&scene.camera);
        let span = Interval::new(0.0, far_distance(&compiled.program, &scene.camera));
        let (w, h): (usize, usize) = (27, 19);
        let empty = (0..w.div_ceil(TILE) * h.div_ceil(TILE))
            .filter(|&k| {
                let (columns, rows) = tile_pixels(k, w, h);
                let corners = pinhole.tile_corners(columns, rows, w, h);
                TileCandidates::gather(&compiled.program, pinhole.origin(), corners, span)
                    .is_empty()
            })
            .count();
        assert!(empty > 0 && compiled.program.lookup_parts().1.is_empty());
    }
}
