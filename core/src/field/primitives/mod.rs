//! Field primitives. Each evaluates value and gradient at a point, knows its support (box for
//! the acceleration structure, exact or bounding interval along a ray) and encloses `f`, `f′`
//! and `f″` over a ray interval inside that support.

mod hrbf;
mod point;
mod scalis;
mod segment;
mod shapes;

pub use hrbf::HrbfTerm;
pub use point::PointBlob;
pub use scalis::ScalisSegment;
pub use segment::DistanceSegment;
pub use shapes::{ShapePrimitive, Solid};

use glam::DVec3;

use crate::bounds::interval::{Interval, Jet};
use crate::field::geometry::{Aabb, Ray, Similarity, SphereCone};
use crate::field::kernel::KernelProfile;

/// One primitive of a field program.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Primitive {
    /// Point blob.
    Point(PointBlob),
    /// Segment with the homothetic-distance field (scalis eq. 7).
    Distance(DistanceSegment),
    /// SCALIS segment (scalis eq. 8), including end-point correctors.
    Scalis(ScalisSegment),
    /// Kernel of the distance to a solid.
    Shape(ShapePrimitive),
    /// One term of an HRBF set (forward inclusion eq. 9); no kernel.
    Hrbf(HrbfTerm),
}

impl Primitive {
    /// The primitive moved by a similarity: positions mapped, axes rotated, lengths and radii
    /// scaled, so that its field is the original one composed with the inverse map.
    #[must_use]
    pub fn transformed(&self, m: &Similarity) -> Self {
        let cone = |c: &SphereCone| SphereCone {
            start: m.point(c.start),
            axis: m.direction(c.axis),
            length: c.length * m.scale,
            radius: c.radius * m.scale,
            slope: c.slope,
        };
        match self {
            Self::Point(x) => Self::Point(PointBlob {
                center: m.point(x.center),
                radius: x.radius * m.scale,
                norm: x.norm,
            }),
            Self::Distance(x) => Self::Distance(DistanceSegment {
                cone: cone(&x.cone),
                norm: x.norm,
            }),
            Self::Scalis(x) => Self::Scalis(ScalisSegment {
                cone: cone(&x.cone),
                norm: x.norm,
            }),
            Self::Shape(x) => Self::Shape(x.transformed(m)),
            Self::Hrbf(x) => Self::Hrbf(x.transformed(m)),
        }
    }

    /// Value at `p`: bit for bit the value [`Primitive::value_gradient`] gives, without the
    /// gradient.
    #[must_use]
    #[inline]
    pub fn value(&self, p: DVec3, k: &KernelProfile) -> f64 {
        match self {
            Self::Point(x) => x.value(p, k),
            Self::Distance(x) => x.value(p, k),
            Self::Scalis(x) => x.value(p, k),
            Self::Shape(x) => x.value(p, k),
            Self::Hrbf(x) => x.value_gradient(p).0,
        }
    }

    /// Value and gradient at `p`.
    #[must_use]
    pub fn value_gradient(&self, p: DVec3, k: &KernelProfile) -> (f64, DVec3) {
        match self {
            Self::Point(x) => x.value_gradient(p, k),
            Self::Distance(x) => x.value_gradient(p, k),
            Self::Scalis(x) => x.value_gradient(p, k),
            Self::Shape(x) => x.value_gradient(p, k),
            Self::Hrbf(x) => x.value_gradient(p),
        }
    }

    /// Global Lipschitz bound `max |∇f|` of the primitive: the kernel's largest slope over the
    /// smallest radius it is scaled by; for a SCALIS segment `N·K′·L/(τ₀τ₁)` (MATH.md §3).
    #[must_use]
    pub fn lipschitz(&self, k: &KernelProfile) -> f64 {
        let slope = k.max_slope();
        match self {
            Self::Point(x) => x.norm * slope / x.radius,
            Self::Distance(x) => x.norm * slope / x.cone.radius,
            Self::Scalis(x) => {
                x.norm * slope * x.cone.length / (x.cone.radius * x.cone.end_radius())
            }
            Self::Shape(x) => x.norm * slope / x.radius,
            Self::Hrbf(x) => x.lipschitz(),
        }
    }

    /// Segment tracing's bound on `|f′|` over `span` as Galin et al. 2020 publish it: for a
    /// point, the kernel's slope over the distance range times the largest cosine
    /// ([`PointBlob::kernel_slope_times_cosine`]). For the other kernel-of-a-distance
    /// primitives the ray jet's `f′ = K′(x)·x′` already is such a product, of the kernel
    /// derivative's range and the distance derivative's range, each bounded on its own; SCALIS
    /// segments and HRBF terms, which the original had no bound for, use their ray jets too.
    /// `inside` is the support's part of `span`.
    #[must_use]
    pub fn published_slope_bound(
        &self,
        ray: &Ray,
        (span, inside): (Interval, Interval),
        k: &KernelProfile,
    ) -> f64 {
        match self {
            Self::Point(x) => x.kernel_slope_times_cosine(ray, inside, k),
            _ => self.ray_jet_inside(ray, span, inside, k).d1.magnitude(),
        }
    }

    /// Bounding box of the support; `None` when unbounded (planes).
    #[must_use]
    pub fn support_aabb(&self, k: &KernelProfile) -> Option<Aabb> {
        match self {
            Self::Point(x) => Some(x.support_aabb(k)),
            Self::Distance(x) => Some(x.support_aabb(k)),
            Self::Scalis(x) => Some(x.support_aabb(k)),
            Self::Shape(x) => x.support_aabb(k),
            Self::Hrbf(x) => Some(x.support_aabb()),
        }
    }

    /// Interval of the whole line of the ray inside the support (exact for balls, sphere-cones
    /// and slabs; a bounding interval for the other shapes).
    #[must_use]
    pub fn support_interval(&self, ray: &Ray, k: &KernelProfile) -> Option<Interval> {
        match self {
            Self::Point(x) => x.support_interval(ray, k),
            Self::Distance(x) => x.support_interval(ray, k),
            Self::Scalis(x) => x.support_interval(ray, k),
            Self::Shape(x) => x.support_interval(ray, k),
            Self::Hrbf(x) => x.support_interval(ray),
        }
    }

    /// Two balls whose convex hull holds the support, where the support is a ball (point
    /// blobs: the ball twice) or a sphere-cone (SCALIS segments: its end balls; every ball
    /// along it is a convex combination of them).
    #[must_use]
    pub fn support_hull(&self, k: &KernelProfile) -> Option<[(DVec3, f64); 2]> {
        match self {
            Self::Point(x) => {
                let ball = (x.center, x.radius * k.support_radius());
                Some([ball, ball])
            }
            Self::Scalis(x) => {
                let cone = x.support(k);
                Some([(cone.start, cone.radius), (cone.end(), cone.end_radius())])
            }
            Self::Distance(_) | Self::Shape(_) | Self::Hrbf(_) => None,
        }
    }

    /// Whether the primitive is exactly 0 (with a zero gradient) at every point `ray.at(t)`,
    /// `|t| ≤ t_max`, because the ray's line misses its support by more than rounding; `false`
    /// where that is not established (a ray's field leaves such primitives out).
    #[must_use]
    pub fn zero_on_line(&self, ray: &Ray, k: &KernelProfile, t_max: f64) -> bool {
        match self {
            Self::Point(x) => x.line_misses_support(ray, k, t_max),
            Self::Scalis(x) => x.line_misses_support(ray, k, t_max),
            Self::Distance(_) | Self::Shape(_) | Self::Hrbf(_) => false,
        }
    }

    /// Enclosures of `f`, `f′`, `f″` on `span`. The primitive is evaluated on the part of
    /// `span` inside its support and extended by zero outside; where the extension crosses the
    /// support boundary of a kinked kernel the upper `f″` bound becomes infinite.
    #[must_use]
    pub fn ray_jet(&self, ray: &Ray, span: Interval, k: &KernelProfile) -> Jet {
        let Some(support) = self.support_interval(ray, k) else {
            return Jet::ZERO;
        };
        let Some(inside) = span.intersect(support) else {
            return Jet::ZERO;
        };
        self.ray_jet_inside(ray, span, inside, k)
    }

    /// [`Primitive::ray_jet`] where `inside`, the part of `span` inside the support, is already
    /// known (a ray's gathered candidates carry their support intervals).
    #[must_use]
    pub fn ray_jet_inside(
        &self,
        ray: &Ray,
        span: Interval,
        inside: Interval,
        k: &KernelProfile,
    ) -> Jet {
        let jet = match self {
            Self::Point(x) => x.ray_jet(ray, inside, k),
            Self::Distance(x) => x.ray_jet(ray, inside, k),
            Self::Scalis(x) => x.ray_jet(ray, inside, k),
            Self::Shape(x) => x.ray_jet(ray, inside, k),
            Self::Hrbf(x) => x.ray_jet(ray, inside),
        };
        if inside == span {
            jet
        } else {
            let mut extended = jet.hull(Jet::ZERO);
            if k.is_kinked() {
                extended.d2.hi = f64::INFINITY;
            }
            extended
        }
    }
}
