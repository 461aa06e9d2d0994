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

use crate::geometry::Ray;
use crate::interval::Interval;
use crate::methods::{RayTracer, TraceMode, TraceSettings};
use crate::program::FieldProgram;
use crate::scene::{Camera, Light, Material, Scene};
use crate::shading::{FieldShading, ambient_occlusion, shading_scale, soft_shadow};

/// Reflection/refraction depth for transparent groups.
pub const MAX_BOUNCES: u32 = 4;

/// Per-pixel output of a render.
#[derive(Clone, Debug, PartialEq)]
pub struct Frame {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// Linear RGB, row-major from the top-left pixel.
    pub colour: Vec<[f32; 3]>,
    /// Ray parameter of the first crossing (distance from the eye); infinite where none.
    pub depth: Vec<f64>,
    /// Steps per pixel.
    pub steps: Vec<u32>,
}

/// Summary of a frame's step counts, over every pixel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepSummary {
    /// Mean.
    pub average: f64,
    /// Median.
    pub median: u32,
    /// Maximum.
    pub max: u32,
}

impl Frame {
    /// Average, median and maximum steps.
    #[must_use]
    pub fn step_summary(&self) -> StepSummary {
        let mut sorted = self.steps.clone();
        sorted.sort_unstable();
        let n = sorted.len().max(1);
        StepSummary {
            average: sorted.iter().map(|&s| f64::from(s)).sum::<f64>() / n as f64,
            median: sorted.get(sorted.len() / 2).copied().unwrap_or(0),
            max: sorted.last().copied().unwrap_or(0),
        }
    }

    /// Whether pixel `i` hit the surface.
    #[must_use]
    pub fn is_hit(&self, i: usize) -> bool {
        self.depth[i].is_finite()
    }
}

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

/// Primary rays of a pinhole camera.
#[derive(Clone, Copy, Debug)]
pub struct PinholeCamera {
    origin: DVec3,
    forward: DVec3,
    right: DVec3,
    up: DVec3,
    tan_half: f64,
}

impl PinholeCamera {
    /// The scene camera.
    #[must_use]
    pub fn new(camera: &Camera) -> Self {
        let origin = DVec3::from_array(camera.position);
        let forward = (DVec3::from_array(camera.target) - origin).normalize_or(DVec3::NEG_Z);
        let right = forward
            .cross(DVec3::from_array(camera.up))
            .normalize_or(DVec3::X);
        Self {
            origin,
            forward,
            right,
            up: right.cross(forward),
            tan_half: (0.5 * camera.fov_degrees.to_radians()).tan(),
        }
    }

    /// Unit forward, right and up axes.
    #[must_use]
    pub fn axes(&self) -> (DVec3, DVec3, DVec3) {
        (self.forward, self.right, self.up)
    }

    /// Ray through the centre of pixel `(x, y)` of a `width × height` image.
    #[must_use]
    pub fn ray(&self, x: usize, y: usize, width: usize, height: usize) -> Ray {
        let aspect = width as f64 / height.max(1) as f64;
        let u = (2.0 * (x as f64 + 0.5) / width as f64 - 1.0) * self.tan_half * aspect;
        let v = (1.0 - 2.0 * (y as f64 + 0.5) / height as f64) * self.tan_half;
        Ray::new(self.origin, self.forward + u * self.right + v * self.up)
    }
}

/// A scene bound to a method, ready to render frames.
pub struct Renderer<'a> {
    program: &'a FieldProgram,
    tracer: &'a dyn RayTracer,
    settings: TraceSettings,
    materials: Vec<Material>,
    lights: Vec<Light>,
    far: f64,
    scale: f64,
}

impl<'a> Renderer<'a> {
    /// Binds `tracer` (prepared on `program` with `settings`) to the scene's materials and
    /// lights.
    #[must_use]
    pub fn new(
        scene: &Scene,
        program: &'a FieldProgram,
        tracer: &'a dyn RayTracer,
        settings: TraceSettings,
    ) -> Self {
        let far = far_distance(program, &scene.camera);
        let lights = if scene.lights.is_empty() {
            Scene::default_lights()
        } else {
            scene.lights.clone()
        };
        Self {
            program,
            tracer,
            settings,
            materials: scene.groups.iter().map(|g| g.material).collect(),
            lights,
            far,
            scale: shading_scale(program),
        }
    }

    /// Renders the scene camera's view.
    #[must_use]
    pub fn render(&self, camera: &Camera, options: RenderOptions) -> Frame {
        let (w, h) = (options.width.max(1), options.height.max(1));
        let pinhole = PinholeCamera::new(camera);
        let pixels: Vec<([f32; 3], f64, u32)> = (0..w * h)
            .into_par_iter()
            .map(|i| {
                let ray = pinhole.ray(i % w, i / w, w, h);
                let mut steps = 0;
                let (colour, depth) = self.radiance(&ray, 0, &options, &mut steps);
                (colour.as_vec3().to_array(), depth, steps)
            })
            .collect();
        Frame {
            width: w,
            height: h,
            colour: pixels.iter().map(|p| p.0).collect(),
            depth: pixels.iter().map(|p| p.1).collect(),
            steps: pixels.iter().map(|p| p.2).collect(),
        }
    }

    /// Colour seen along `ray` and the distance of its first crossing.
    fn radiance(
        &self,
        ray: &Ray,
        bounce: u32,
        options: &RenderOptions,
        steps: &mut u32,
    ) -> (DVec3, f64) {
        let trace = self
            .tracer
            .trace(ray, Interval::new(0.0, self.far), TraceMode::Opaque);
        *steps += trace.steps;
        let Some(hit) = trace.first() else {
            return (background(ray.direction), f64::INFINITY);
        };
        let p = ray.at(hit.t);
        let (_, gradient) = self.program.value_gradient(p);
        let outward = (-gradient).normalize_or(-ray.direction);
        let material = self.material_at(ray, hit.t);
        let lit = self.shade(p, outward, ray.direction, &material, options);
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
            options,
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
                options,
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
        let values = self.program.group_values_along_ray(ray, t);
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
        options: &RenderOptions,
    ) -> DVec3 {
        let albedo = DVec3::from_array(material.color);
        let lifted = p + 2.0 * self.settings.min_step * normal;
        let occlusion = if options.shading.ambient_occlusion {
            ambient_occlusion(self.program, p, normal, self.scale)
        } else {
            1.0
        };
        let mut colour = 0.12 * occlusion * albedo;
        for light in &self.lights {
            let (to_light, distance, light_colour, intensity) = match light {
                Light::Directional {
                    direction,
                    color,
                    intensity,
                } => (
                    DVec3::from_array(*direction).normalize_or(DVec3::Y),
                    self.far,
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
            let mut transmitted = if options.shadows {
                self.transmittance(lifted, to_light, distance)
            } else {
                1.0
            };
            if options.shading.soft_shadows && transmitted > 0.0 {
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

/// Length of the primary rays: past the farthest support seen from the camera (four times as
/// far when a plane reaches to infinity). The GPU backend uses the same value.
#[must_use]
pub fn far_distance(program: &FieldProgram, camera: &Camera) -> f64 {
    let bounds = program.support_bounds();
    if bounds.is_empty() {
        return 100.0;
    }
    let eye = DVec3::from_array(camera.position);
    let reach = (bounds.center() - eye).length() + bounds.diagonal();
    if program.has_unbounded_support() {
        4.0 * reach
    } else {
        reach
    }
}

/// Sky gradient behind the surface.
fn background(direction: DVec3) -> DVec3 {
    let up = 0.5 * (direction.y + 1.0);
    DVec3::new(0.16, 0.17, 0.20).lerp(DVec3::new(0.42, 0.47, 0.55), up)
}

/// Linear to sRGB-encoded 8-bit.
#[must_use]
pub fn srgb8(linear: f32) -> u8 {
    let c = linear.clamp(0.0, 1.0);
    let s = if c <= 0.003_130_8 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    };
    (s * 255.0 + 0.5) as u8
}

/// The step-count colour map (Turbo, Mikhailov 2019, polynomial fit) at `x ∈ [0, 1]`, sRGB
/// in `[0, 1]`. The GPU backend uses the same polynomial.
#[must_use]
pub fn heat_colour(x: f64) -> [f32; 3] {
    let x = x.clamp(0.0, 1.0);
    let poly = |c: [f64; 6]| {
        let v = c[0] + x * (c[1] + x * (c[2] + x * (c[3] + x * (c[4] + x * c[5]))));
        v.clamp(0.0, 1.0) as f32
    };
    [
        poly([
            0.135_721_38,
            4.615_392_6,
            -42.660_322_6,
            132.131_082_9,
            -152.942_393_9,
            59.286_379_0,
        ]),
        poly([
            0.091_402_61,
            2.194_188_39,
            4.842_966_58,
            -14.185_033_3,
            4.277_298_55,
            2.829_566_04,
        ]),
        poly([
            0.106_673_30,
            12.641_946_08,
            -60.582_048_8,
            110.362_767_7,
            -89.903_109_8,
            27.348_249_3,
        ]),
    ]
}
