//! Distance-based primitives: a kernel applied to the distance `d` to a solid,
//! `f(p) = N₀·K(d²/ρ²)`, so the surface of an isolated shape is the solid offset by `ρ`
//! (numerical ray tracing notes 2014 §7; forward-inclusion 2023 fig. 16 uses the plane).
//! `d²` is C¹ for every solid here, and along a ray it is built from affine and quadratic jets
//! with `max(·, 0)²`, square roots and sums, so its bounds come from jet arithmetic.

use glam::{DMat3, DVec3};

use crate::bounds::interval::{Interval, Jet};
use crate::field::geometry::{Aabb, Ray, Similarity};
use crate::field::kernel::KernelProfile;

/// The solid a distance primitive measures the distance to, in its local frame (axis `y` for
/// the torus and cylinder).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Solid {
    /// The plane `n·p = offset` (distance unsigned: the surface is a slab of half-width `ρ`).
    Plane {
        /// Unit normal (world frame).
        normal: DVec3,
        /// Signed offset along the normal.
        offset: f64,
    },
    /// Box with half extents.
    Box {
        /// Half extents along the local axes.
        half_extents: DVec3,
    },
    /// Box with rounded edges: the inner box `half_extents − rounding` dilated by `rounding`.
    RoundedBox {
        /// Half extents of the outer box.
        half_extents: DVec3,
        /// Rounding radius.
        rounding: f64,
    },
    /// Solid torus around the local `y` axis.
    Torus {
        /// Distance from the centre to the tube's centre line.
        major: f64,
        /// Tube radius.
        minor: f64,
    },
    /// Capped solid cylinder along the local `y` axis.
    Cylinder {
        /// Radius.
        radius: f64,
        /// Half of the height.
        half_height: f64,
    },
}

/// A distance primitive placed in the world.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShapePrimitive {
    /// The solid.
    pub solid: Solid,
    /// Centre of the local frame.
    pub center: DVec3,
    /// Local axes as columns (orthonormal).
    pub frame: DMat3,
    /// Prescribed radius `ρ`: offset of the surface from the solid.
    pub radius: f64,
    /// Normalisation `N₀ = c / K(1)`.
    pub norm: f64,
}

impl ShapePrimitive {
    /// The primitive moved by a similarity (see [`super::Primitive::transformed`]).
    #[must_use]
    pub fn transformed(&self, m: &Similarity) -> Self {
        let s = m.scale;
        let solid = match self.solid {
            Solid::Plane { normal, offset } => {
                // n·p = o  ⇔  (R n)·(s R p + t) = s·o + (R n)·t
                let n = m.direction(normal);
                Solid::Plane {
                    normal: n,
                    offset: s * offset + n.dot(m.translation),
                }
            }
            Solid::Box { half_extents } => Solid::Box {
                half_extents: s * half_extents,
            },
            Solid::RoundedBox {
                half_extents,
                rounding,
            } => Solid::RoundedBox {
                half_extents: s * half_extents,
                rounding: s * rounding,
            },
            Solid::Torus { major, minor } => Solid::Torus {
                major: s * major,
                minor: s * minor,
            },
            Solid::Cylinder {
                radius,
                half_height,
            } => Solid::Cylinder {
                radius: s * radius,
                half_height: s * half_height,
            },
        };
        Self {
            solid,
            center: m.point(self.center),
            frame: m.rotation * self.frame,
            radius: s * self.radius,
            norm: self.norm,
        }
    }
}

impl ShapePrimitive {
    /// `d²` and its gradient in the local frame (world frame for planes).
    fn distance_sq(&self, p: DVec3) -> (f64, DVec3) {
        let q = self.frame.transpose() * (p - self.center);
        let excess = |q: DVec3, e: DVec3| {
            DVec3::new(
                (q.x.abs() - e.x).max(0.0).copysign(q.x),
                (q.y.abs() - e.y).max(0.0).copysign(q.y),
                (q.z.abs() - e.z).max(0.0).copysign(q.z),
            )
        };
        let (d2, grad) = match self.solid {
            Solid::Plane { normal, offset } => {
                // World frame: return before the local-to-world rotation below.
                let s = normal.dot(p) - offset;
                return (s * s, 2.0 * s * normal);
            }
            Solid::Box { half_extents } => {
                let g = excess(q, half_extents);
                (g.length_squared(), 2.0 * g)
            }
            Solid::RoundedBox {
                half_extents,
                rounding,
            } => {
                let g = excess(q, half_extents - DVec3::splat(rounding));
                let inner = g.length();
                let e = (inner - rounding).max(0.0);
                if e > 0.0 {
                    (e * e, (2.0 * e / inner) * g)
                } else {
                    (0.0, DVec3::ZERO)
                }
            }
            Solid::Torus { major, minor } => {
                let rho = q.x.hypot(q.z);
                let radial = if rho > 0.0 {
                    DVec3::new(q.x / rho, 0.0, q.z / rho)
                } else {
                    DVec3::ZERO
                };
                let a = rho - major;
                let tube = a.hypot(q.y);
                let e = (tube - minor).max(0.0);
                if e > 0.0 {
                    (
                        e * e,
                        (2.0 * e / tube) * (a * radial + DVec3::new(0.0, q.y, 0.0)),
                    )
                } else {
                    (0.0, DVec3::ZERO)
                }
            }
            Solid::Cylinder {
                radius,
                half_height,
            } => {
                let rho = q.x.hypot(q.z);
                let gr = (rho - radius).max(0.0);
                let gy = (q.y.abs() - half_height).max(0.0).copysign(q.y);
                let radial = if rho > 0.0 {
                    DVec3::new(q.x / rho, 0.0, q.z / rho)
                } else {
                    DVec3::ZERO
                };
                (
                    gr * gr + gy * gy,
                    2.0 * (gr * radial + DVec3::new(0.0, gy, 0.0)),
                )
            }
        };
        (d2, self.frame * grad)
    }

    /// Value and gradient at `p`.
    #[must_use]
    pub fn value_gradient(&self, p: DVec3, k: &KernelProfile) -> (f64, DVec3) {
        let inv_r2 = 1.0 / (self.radius * self.radius);
        let (d2, grad) = self.distance_sq(p);
        let (v, d1) = k.value_d1(d2 * inv_r2);
        (self.norm * v, (self.norm * d1 * inv_r2) * grad)
    }

    /// Value at `p`.
    #[must_use]
    pub fn value(&self, p: DVec3, k: &KernelProfile) -> f64 {
        // The arithmetic of `value_gradient`'s value, bit for bit.
        let inv_r2 = 1.0 / (self.radius * self.radius);
        let (d2, _) = self.distance_sq(p);
        self.norm * k.value(d2 * inv_r2)
    }

    /// Half extents of a local box bounding the support (`None` for the unbounded plane).
    fn local_bound(&self, k: &KernelProfile) -> Option<DVec3> {
        let reach = self.radius * k.support_radius();
        match self.solid {
            Solid::Plane { .. } => None,
            Solid::Box { half_extents } | Solid::RoundedBox { half_extents, .. } => {
                Some(half_extents + DVec3::splat(reach))
            }
            Solid::Torus { major, minor } => {
                let r = major + minor + reach;
                Some(DVec3::new(r, minor + reach, r))
            }
            Solid::Cylinder {
                radius,
                half_height,
            } => Some(DVec3::new(
                radius + reach,
                half_height + reach,
                radius + reach,
            )),
        }
    }

    /// Bounding box of the support; `None` for planes, whose support is an infinite slab.
    #[must_use]
    pub fn support_aabb(&self, k: &KernelProfile) -> Option<Aabb> {
        let half = self.local_bound(k)?;
        let m = self.frame;
        let world_half = DVec3::new(
            m.row(0).abs().dot(half),
            m.row(1).abs().dot(half),
            m.row(2).abs().dot(half),
        );
        Some(Aabb {
            min: self.center - world_half,
            max: self.center + world_half,
        })
    }

    /// Interval of the ray inside the support: exact for the plane's slab, the local bounding
    /// box of the support otherwise (a superset of the exact support interval).
    #[must_use]
    pub fn support_interval(&self, ray: &Ray, k: &KernelProfile) -> Option<Interval> {
        let reach = self.radius * k.support_radius();
        if let Solid::Plane { normal, offset } = self.solid {
            let s0 = normal.dot(ray.origin) - offset;
            let su = normal.dot(ray.direction);
            if su == 0.0 {
                return (s0.abs() < reach).then_some(Interval::ENTIRE);
            }
            return Some(Interval::new((-reach - s0) / su, (reach - s0) / su));
        }
        let half = self.local_bound(k)?;
        let local = Ray {
            origin: self.frame.transpose() * (ray.origin - self.center),
            direction: self.frame.transpose() * ray.direction,
        };
        Aabb {
            min: -half,
            max: half,
        }
        .ray_interval(&local, Interval::ENTIRE)
    }

    /// Enclosures of `f`, `f′`, `f″` over `span`.
    #[must_use]
    pub fn ray_jet(&self, ray: &Ray, span: Interval, k: &KernelProfile) -> Jet {
        let d2 = self.distance_sq_jet(ray, span);
        k.compose(d2.scale(1.0 / (self.radius * self.radius)))
            .scale(self.norm)
    }

    fn distance_sq_jet(&self, ray: &Ray, span: Interval) -> Jet {
        // A plane needs neither the local frame nor the distance to its axis: the other solids
        // build them (`LocalRay`).
        let local = || LocalRay::new(self, ray, span);
        match self.solid {
            Solid::Plane { normal, offset } => Jet::affine(
                normal.dot(ray.origin) - offset,
                normal.dot(ray.direction),
                span,
            )
            .square(),
            Solid::Box { half_extents } => {
                let l = local();
                (0..3)
                    .map(|i| l.slab_excess_sq(i, half_extents[i]))
                    .fold(Jet::ZERO, |a, b| a + b)
            }
            Solid::RoundedBox {
                half_extents,
                rounding,
            } => {
                let l = local();
                let inner = (0..3)
                    .map(|i| l.slab_excess_sq(i, half_extents[i] - rounding))
                    .fold(Jet::ZERO, |a, b| a + b);
                (inner.sqrt_above(rounding) - Jet::constant(rounding)).positive_part_squared()
            }
            Solid::Torus { major, minor } => {
                let l = local();
                let a = l.radial() - Jet::constant(major);
                let tube = (a.square() + l.coord(1).square()).sqrt_above(minor);
                (tube - Jet::constant(minor)).positive_part_squared()
            }
            Solid::Cylinder {
                radius,
                half_height,
            } => {
                let l = local();
                (l.radial_sq().sqrt_above(radius) - Jet::constant(radius)).positive_part_squared()
                    + l.slab_excess_sq(1, half_height)
            }
        }
    }
}

/// A ray over `span` in a solid's local frame (origin `o`, direction `u`), with the jets of
/// the local coordinates and distances along it that [`ShapePrimitive::distance_sq_jet`] takes.
struct LocalRay {
    o: DVec3,
    u: DVec3,
    span: Interval,
}

impl LocalRay {
    fn new(shape: &ShapePrimitive, ray: &Ray, span: Interval) -> Self {
        Self {
            o: shape.frame.transpose() * (ray.origin - shape.center),
            u: shape.frame.transpose() * ray.direction,
            span,
        }
    }

    /// Local coordinate `i`.
    fn coord(&self, i: usize) -> Jet {
        Jet::affine(self.o[i], self.u[i], self.span)
    }

    /// Squared distance to the slab `|x_i| ≤ e`.
    fn slab_excess_sq(&self, i: usize, e: f64) -> Jet {
        (self.coord(i) - Jet::constant(e)).positive_part_squared()
            + (Jet::constant(-e) - self.coord(i)).positive_part_squared()
    }

    /// Squared distance to the local y axis.
    fn radial_sq(&self) -> Jet {
        let (o, u) = (self.o, self.u);
        Jet::quadratic(
            u.x * u.x + u.z * u.z,
            2.0 * (o.x * u.x + o.z * u.z),
            o.x * o.x + o.z * o.z,
            self.span,
        )
    }

    /// Distance to the local y axis: 1-Lipschitz along any line (|ρ′| ≤ |u_xz|) and convex
    /// (ρ″ ≥ 0), which keeps its jet finite where the ray passes through the axis.
    fn radial(&self) -> Jet {
        let lateral = self.u.x.hypot(self.u.z);
        let mut rho = self.radial_sq().sqrt();
        rho.d1 = rho
            .d1
            .intersect(Interval::new(-lateral, lateral))
            .unwrap_or(Interval::new(-lateral, lateral));
        rho.d2.lo = rho.d2.lo.max(0.0);
        rho
    }
}
