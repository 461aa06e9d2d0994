//! Settings profiles after each paper: comparisons are made on a paper's terms first.
//!
//! - `default`: skeletrace's own settings ([`TraceSettings::for_program`]): every support part
//!   starts with an interval of 0.05 of the box diagonal, the SCALIS tracer stops on the Newton
//!   distance `|F/F′| < ε` and field inversion refines its hit by bisection.
//! - `paper-2023` (forward inclusion, algorithm 1): the first interval of each support part is
//!   the whole part, so a quadratic bound may discard it in one step; field inversion reports the
//!   sample where it stopped, unrefined, as Bruckner's listing does.
//! - `paper-2014` (numerical ray tracing notes §12.1): over-relaxed sphere tracing with
//!   `ω = 1.2`, the value the notes quote from Keinert et al. (skeletrace's default is 1.6, inside
//!   their range [1.2, 1.9]).
//! - `paper-2021` (SCALIS, algorithm 1): the SCALIS tracer stops when the normalised field's
//!   value is small, `|F| < 10⁻³` (the paper names a threshold ε without its value; `F` is a
//!   squared normalised distance minus one, so 10⁻³ is a few thousandths of a radius on a
//!   direct ray), at the estimate itself, without the Newton correction; it enters each
//!   support part with one sphere-tracing step (§7) and evaluates nothing at the support
//!   limits; its sphere-tracing baseline (`sphere-normalized`) takes the thinnest radius per
//!   ray, as appendix B does, instead of per marching interval.
//!
//! The GPU backend takes a profile's trace settings (first interval, ε, budget, growth) but
//! runs each method's own choices as the default profile does: the per-method choices above
//! are the CPU's, which is what `stats` runs.
//!
//! What no profile changes: ε on the ray parameter (2·10⁻⁵ of the diagonal, the papers give none
//! in scene units that carry over), the budget of 2048 steps per ray and the growth k = 2 of the
//! inclusion methods (2023 §4.3). `segment-original` always runs as Galin et al. 2020 publish it
//! (growth 1.5, first segment the whole part, minimum step ε), whatever the profile.

use std::fmt;
use std::str::FromStr;

/// A settings profile.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Protocol {
    /// skeletrace's settings.
    #[default]
    Default,
    /// Forward inclusion 2023.
    Paper2023,
    /// Numerical ray tracing notes 2014.
    Paper2014,
    /// SCALIS 2021.
    Paper2021,
}

impl Protocol {
    /// Every profile.
    pub const ALL: [Self; 4] = [
        Self::Default,
        Self::Paper2023,
        Self::Paper2021,
        Self::Paper2014,
    ];

    /// The command-line name.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Self::Default => "default",
            Self::Paper2023 => "paper-2023",
            Self::Paper2021 => "paper-2021",
            Self::Paper2014 => "paper-2014",
        }
    }

    /// Whether each support part's first interval is the whole part (2023 algorithm 1).
    #[must_use]
    pub const fn first_interval_is_whole_part(self) -> bool {
        matches!(self, Self::Paper2023)
    }

    /// The SCALIS tracer's stopping rule.
    #[must_use]
    pub const fn scalis_stop(self) -> ScalisStop {
        match self {
            Self::Paper2021 => ScalisStop::Value(1e-3),
            Self::Default | Self::Paper2023 | Self::Paper2014 => ScalisStop::NewtonDistance,
        }
    }

    /// Whether `sphere-normalized` bounds its field by the thinnest radius the whole ray meets
    /// (scalis 2021 appendix B) rather than the thinnest on each marching interval.
    #[must_use]
    pub const fn thinnest_radius_per_ray(self) -> bool {
        matches!(self, Self::Paper2021)
    }

    /// Whether the SCALIS tracer enters each support part with the paper's sphere-tracing step
    /// off the support limit (scalis 2021 §7, algorithm 2), and takes the secant for the slope
    /// at the part's end, rather than starting at the limit and taking the slope of the
    /// quadratic through both values and the other end's slope (`scalis_quadratic.rs`).
    #[must_use]
    pub const fn scalis_sphere_step_entry(self) -> bool {
        matches!(self, Self::Paper2021)
    }

    /// The over-relaxation factor `ω` of `sphere-enhanced`.
    #[must_use]
    pub const fn over_relaxation(self) -> f64 {
        match self {
            Self::Paper2014 => 1.2,
            Self::Default | Self::Paper2023 | Self::Paper2021 => 1.6,
        }
    }

    /// Whether field inversion refines its hit between the last two samples.
    #[must_use]
    pub const fn refines_field_inversion(self) -> bool {
        !matches!(self, Self::Paper2023)
    }
}

/// When the SCALIS tracer accepts an estimate as the crossing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ScalisStop {
    /// `|F/F′| < ε` on the ray parameter, then placed one Newton step further.
    NewtonDistance,
    /// `|F| <` this value (scalis 2021 algorithm 1), at the estimate.
    Value(f64),
}

impl fmt::Display for Protocol {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Protocol {
    type Err = String;

    fn from_str(name: &str) -> Result<Self, String> {
        Self::ALL
            .into_iter()
            .find(|p| p.name() == name)
            .ok_or_else(|| {
                let known: Vec<&str> = Self::ALL.iter().map(|p| p.name()).collect();
                format!("unknown protocol '{name}'; available: {}", known.join(", "))
            })
    }
}
