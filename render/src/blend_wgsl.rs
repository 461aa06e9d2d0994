//! A scene's blend tree compiled to WGSL ("a compiled expression per scene"): four
//! straight-line functions over the group slots, one per quantity the shaders blend, each the
//! CPU's rule for every operator —
//!
//! - `blend_groups`: values and gradients (core `blend.rs` `value_gradient`),
//! - `blend_jets`: jets over a ray interval (`blend.rs` `jet`, with `ricci_jet`'s p-norm bounds),
//! - `blend_lipschitz`: segment tracing's Lipschitz bound (`blend.rs` `lipschitz`),
//! - `compose_groups`: the forward-inclusion composition (`inclusion.rs` `blend`), `valid` false
//!   where that has no rule.
//!
//! The operators' helpers are WGSL (`shared/blend.wgsl`, `primitive_jets.wgsl`, `inclusion.wgsl`);
//! this module only nests their calls in the tree's shape, operands in the tree's order, so the
//! smooth operators (not associative) fold as on the CPU. Straight-line code keeps every slot
//! index constant: an interpreter over a stack indexed at run time made lavapipe's compile of
//! each pipeline take minutes. A scene whose tree changes gets new pipelines
//! (`GpuRenderer::set_scene`); edits of primitives do not change the tree.

use std::fmt::Write as _;

use skeletrace_core::field::blend::BlendTree;

/// The WGSL of one blend tree: `values` defines `blend_groups` (every shader), `jets_and_lipschitz`
/// defines `blend_jets` and `blend_lipschitz` (after interval.wgsl, which defines `Jet`), and
/// `composition` defines `compose_groups` (after inclusion.wgsl, which defines `Inclusion`).
/// The group slots these take, one per group of the scene, are `GROUPS` in the shaders
/// ([`Self::groups_constant`]).
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct BlendWgsl {
    /// The scene's group count (at least 1: WGSL arrays are not empty).
    pub groups: u32,
    /// `fn blend_groups(values: array<vec4<f32>, GROUPS>) -> vec4<f32>`.
    pub values: String,
    /// `blend_jets` and `blend_lipschitz`.
    pub jets_and_lipschitz: String,
    /// `compose_groups`.
    pub composition: String,
}

impl BlendWgsl {
    /// The functions for `tree`, over a scene of `groups` groups.
    #[must_use]
    pub fn new(tree: &BlendTree, groups: usize) -> Self {
        let mut jets_and_lipschitz = function(
            "blend_jets(groups: array<Jet, GROUPS>) -> Jet",
            tree,
            jet_node,
        );
        jets_and_lipschitz.push_str(&function(
            "blend_lipschitz(groups: array<f32, GROUPS>) -> f32",
            tree,
            lipschitz_node,
        ));
        Self {
            groups: u32::try_from(groups.max(1)).unwrap_or(u32::MAX),
            values: function(
                "blend_groups(values: array<vec4<f32>, GROUPS>) -> vec4<f32>",
                tree,
                value_node,
            ),
            jets_and_lipschitz,
            composition: function(
                "compose_groups(groups: array<Inclusion, GROUPS>) -> Composed",
                tree,
                compose_node,
            ),
        }
    }

    /// `const GROUPS`, the length of the shaders' per-ray arrays of group slots.
    #[must_use]
    pub fn groups_constant(&self) -> String {
        format!("const GROUPS: u32 = {}u;\n", self.groups)
    }

    /// Every bound function of the inclusion family: jets, Lipschitz bound, composition.
    #[must_use]
    pub fn bounds(&self) -> String {
        format!("{}{}", self.jets_and_lipschitz, self.composition)
    }
}

/// A function body under construction: `let` statements naming each node's result.
struct Body {
    text: String,
    next: usize,
}

impl Body {
    /// Binds `expression` to a fresh name and returns the name.
    fn bind(&mut self, expression: &str) -> String {
        let name = format!("n{}", self.next);
        self.next += 1;
        let _ = writeln!(self.text, "    let {name} = {expression};");
        name
    }
}

type Node = fn(&BlendTree, &mut Body) -> String;

fn function(signature: &str, tree: &BlendTree, node: Node) -> String {
    let mut body = Body {
        text: String::new(),
        next: 0,
    };
    let result = node(tree, &mut body);
    format!("fn {signature} {{\n{}    return {result};\n}}\n", body.text)
}

/// A WGSL float literal of `v` (as f32).
fn float(v: f64) -> String {
    format!("{:?}", v as f32)
}

/// The tree's operator with its operands, in the tree's order.
enum Operator<'a> {
    Sum(&'a [BlendTree]),
    Max(&'a [BlendTree]),
    Min(&'a [BlendTree]),
    Difference(&'a BlendTree, &'a BlendTree),
    Ricci(f64, &'a [BlendTree]),
    SmoothUnion(f64, &'a [BlendTree]),
    SmoothIntersection(f64, &'a [BlendTree]),
}

fn operator(tree: &BlendTree) -> Result<Operator<'_>, u32> {
    Ok(match tree {
        BlendTree::Group(g) => return Err(*g),
        BlendTree::Sum(v) => Operator::Sum(v),
        BlendTree::Max(v) => Operator::Max(v),
        BlendTree::Min(v) => Operator::Min(v),
        BlendTree::Difference(a, b) => Operator::Difference(a, b),
        BlendTree::Ricci { p, of } => Operator::Ricci(*p, of),
        BlendTree::SmoothUnion { width, of } => Operator::SmoothUnion(*width, of),
        BlendTree::SmoothIntersection { width, of } => Operator::SmoothIntersection(*width, of),
    })
}

/// `init`, then `step(acc, operand)` over the operands: the chain of nested calls.
fn fold(
    operands: &[BlendTree],
    body: &mut Body,
    node: Node,
    init: Option<&str>,
    step: impl Fn(&str, &str) -> String,
) -> Option<String> {
    let names: Vec<String> = operands.iter().map(|c| node(c, body)).collect();
    fold_names(names, body, init, step)
}

/// [`fold`] over operands already written, by their names.
fn fold_names(
    names: Vec<String>,
    body: &mut Body,
    init: Option<&str>,
    step: impl Fn(&str, &str) -> String,
) -> Option<String> {
    let mut names = names.into_iter();
    let mut acc = match init {
        Some(i) => i.to_owned(),
        None => names.next()?,
    };
    for name in names {
        acc = body.bind(&step(&acc, &name));
    }
    Some(acc)
}

/// How the value and the jet programs write a node: the two have one shape, each operator a
/// helper of its own, and their own Ricci rule in passes over the operands.
struct Vocabulary {
    /// The node function itself, for the operands.
    node: Node,
    /// The array of group slots.
    slots: &'static str,
    /// An operator without operands.
    zero: &'static str,
    add: fn(&str, &str) -> String,
    max: fn(&str, &str) -> String,
    min: fn(&str, &str) -> String,
    difference: fn(&str, &str) -> String,
    smooth_max: fn(&str, &str, &str) -> String,
    smooth_min: fn(&str, &str, &str) -> String,
    /// The Ricci blend of the operands' names with exponent `p`.
    ricci: fn(&[String], &str, &mut Body) -> String,
}

const VALUES: Vocabulary = Vocabulary {
    node: value_node,
    slots: "values",
    zero: "vec4<f32>(0.0)",
    add: |a, b| format!("{a} + {b}"),
    max: |a, b| format!("value_max({a}, {b})"),
    min: |a, b| format!("value_min({a}, {b})"),
    difference: |a, b| format!("value_difference({a}, {b})"),
    smooth_max: |a, b, w| format!("smooth_max({a}, {b}, {w})"),
    smooth_min: |a, b, w| format!("-smooth_max(-{a}, -{b}, {w})"),
    ricci: |names, p, body| {
        // The largest fᵢ, m; Σ max(fᵢ/m, 0)^p, its root R, then Σ (fᵢ/R)^(p−1) ∇fᵢ.
        let mut scale = "0.0".to_owned();
        for n in names {
            scale = body.bind(&format!("ricci_scale({scale}, {n})"));
        }
        let mut sum = "0.0".to_owned();
        for n in names {
            sum = body.bind(&format!("{sum} + ricci_power({n}, {scale}, {p})"));
        }
        let root = body.bind(&format!("ricci_root({sum}, {scale}, {p})"));
        let mut gradient = "vec3<f32>(0.0)".to_owned();
        for n in names {
            gradient = body.bind(&format!("{gradient} + ricci_slope({n}, {root}, {p})"));
        }
        body.bind(&format!("vec4<f32>({root}, {gradient})"))
    },
};

const JETS: Vocabulary = Vocabulary {
    node: jet_node,
    slots: "groups",
    zero: "jet_constant(0.0)",
    add: |a, b| format!("jet_add({a}, {b})"),
    max: |a, b| format!("jet_max({a}, {b})"),
    min: |a, b| format!("jet_min({a}, {b})"),
    difference: |a, b| format!("jet_difference({a}, {b})"),
    smooth_max: |a, b, w| format!("jet_smooth_max({a}, {b}, {w})"),
    smooth_min: |a, b, w| format!("jet_neg(jet_smooth_max(jet_neg({a}), jet_neg({b}), {w}))"),
    ricci: |names, p, body| {
        // Three passes (blend.rs ricci_jet): the largest value ends, the operands' value ends
        // relative to them, then their weights.
        let mut scale = "vec2<f32>(0.0)".to_owned();
        for n in names {
            scale = body.bind(&format!("ricci_scale_add({scale}, {n})"));
        }
        let mut ends = "ricci_ends_start()".to_owned();
        for n in names {
            ends = body.bind(&format!("ricci_ends_add({ends}, {n}, {p}, {scale})"));
        }
        let mut weights = body.bind(&format!("ricci_weights_start({ends}, {p}, {scale})"));
        for n in names {
            weights = body.bind(&format!("ricci_weights_add({weights}, {n}, {p})"));
        }
        body.bind(&format!("ricci_jet_finish({ends}, {weights}, {p})"))
    },
};

fn value_node(tree: &BlendTree, body: &mut Body) -> String {
    node_in(tree, body, &VALUES)
}

fn jet_node(tree: &BlendTree, body: &mut Body) -> String {
    node_in(tree, body, &JETS)
}

/// A node of the value or the jet program, in `words`.
fn node_in(tree: &BlendTree, body: &mut Body, words: &Vocabulary) -> String {
    let op = match operator(tree) {
        Err(g) => return body.bind(&format!("{}[{g}]", words.slots)),
        Ok(op) => op,
    };
    let node = words.node;
    match op {
        Operator::Sum(v) => fold(v, body, node, Some(words.zero), words.add),
        Operator::Max(v) => fold(v, body, node, None, words.max),
        Operator::Min(v) => fold(v, body, node, None, words.min),
        Operator::Difference(a, b) => {
            let (a, b) = (node(a, body), node(b, body));
            Some(body.bind(&(words.difference)(&a, &b)))
        }
        Operator::Ricci(p, v) => {
            let names: Vec<String> = v.iter().map(|c| node(c, body)).collect();
            Some((words.ricci)(&names, &float(p), body))
        }
        Operator::SmoothUnion(w, v) => {
            let w = float(w);
            fold(v, body, node, None, |a, b| (words.smooth_max)(a, b, &w))
        }
        Operator::SmoothIntersection(w, v) => {
            let w = float(w);
            fold(v, body, node, None, |a, b| (words.smooth_min)(a, b, &w))
        }
    }
    .unwrap_or_else(|| body.bind(words.zero))
}

fn lipschitz_node(tree: &BlendTree, body: &mut Body) -> String {
    let op = match operator(tree) {
        Err(g) => return body.bind(&format!("groups[{g}]")),
        Ok(op) => op,
    };
    let max = |a: &str, b: &str| format!("max({a}, {b})");
    match op {
        Operator::Sum(v) => fold(v, body, lipschitz_node, Some("0.0"), |a, b| {
            format!("{a} + {b}")
        }),
        Operator::Ricci(p, v) => {
            // The p-norm of the operands' bounds (Hölder), relative to the largest.
            let p = float(p);
            let names: Vec<String> = v.iter().map(|c| lipschitz_node(c, body)).collect();
            let mut scale = "0.0".to_owned();
            for n in &names {
                scale = body.bind(&max(&scale, n));
            }
            let sum = fold_names(names, body, Some("0.0"), |a, b| {
                format!("{a} + p_norm_term({b}, {scale}, {p})")
            });
            sum.map(|s| body.bind(&format!("p_norm_root({s}, {scale}, {p})")))
        }
        Operator::Difference(a, b) => {
            let names = vec![lipschitz_node(a, body), lipschitz_node(b, body)];
            fold_names(names, body, Some("0.0"), max)
        }
        Operator::Max(v)
        | Operator::Min(v)
        | Operator::SmoothUnion(_, v)
        | Operator::SmoothIntersection(_, v) => fold(v, body, lipschitz_node, Some("0.0"), max),
    }
    .unwrap_or_else(|| body.bind("0.0"))
}

fn compose_node(tree: &BlendTree, body: &mut Body) -> String {
    let op = match operator(tree) {
        Err(g) => return body.bind(&format!("Composed(groups[{g}], true)")),
        Ok(op) => op,
    };
    // The Bézier hull of the operands (negated for a minimum, the complement's shift for a
    // difference) on the shortest of their intervals.
    let hull = |items: Vec<String>, body: &mut Body| {
        let mut h = "INF".to_owned();
        for i in &items {
            h = body.bind(&format!("min({h}, {i}.inclusion.length)"));
        }
        let mut acc = body.bind(&format!("hull_start({}, {h})", items[0]));
        for i in &items[1..] {
            acc = body.bind(&format!("hull_add({acc}, {i}, {h})"));
        }
        body.bind(&format!("hull_end({acc}, {h})"))
    };
    let no_rule = "Composed(groups[0], false)";
    match op {
        Operator::Sum(v) => fold(v, body, compose_node, None, |a, b| {
            format!("composed_add({a}, {b})")
        }),
        Operator::Max(v) if !v.is_empty() => {
            let items = v.iter().map(|c| compose_node(c, body)).collect();
            Some(hull(items, body))
        }
        Operator::Min(v) if !v.is_empty() => {
            let items = v
                .iter()
                .map(|c| {
                    let n = compose_node(c, body);
                    body.bind(&format!("composed_neg({n})"))
                })
                .collect();
            let h = hull(items, body);
            Some(body.bind(&format!("composed_neg({h})")))
        }
        Operator::Difference(a, b) => {
            // −min(a, 2c − b) = max(−a, b − 2c).
            let a = compose_node(a, body);
            let b = compose_node(b, body);
            let items = vec![
                body.bind(&format!("composed_neg({a})")),
                body.bind(&format!("composed_shift({b}, -2.0 * globals.isovalue)")),
            ];
            let h = hull(items, body);
            Some(body.bind(&format!("composed_neg({h})")))
        }
        Operator::Ricci(_, v) => {
            let mut acc = "ricci_inclusion_start()".to_owned();
            for c in v {
                let n = compose_node(c, body);
                acc = body.bind(&format!("ricci_inclusion_add({acc}, {n})"));
            }
            Some(body.bind(&format!("ricci_inclusion_end({acc})")))
        }
        Operator::Max(_)
        | Operator::Min(_)
        | Operator::SmoothUnion(..)
        | Operator::SmoothIntersection(..) => None,
    }
    .unwrap_or_else(|| body.bind(no_rule))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The operators asset's `Ricci(p: 4, [Difference(0, 1), 2])`, value by value.
    #[test]
    fn a_tree_becomes_nested_helper_calls_in_its_own_order() {
        let tree = BlendTree::Ricci {
            p: 4.0,
            of: vec![
                BlendTree::Difference(Box::new(BlendTree::Group(0)), Box::new(BlendTree::Group(1))),
                BlendTree::Group(2),
            ],
        };
        let wgsl = BlendWgsl::new(&tree, 3);
        assert_eq!(
            wgsl.values,
            "fn blend_groups(values: array<vec4<f32>, GROUPS>) -> vec4<f32> {
    let n0 = values[0];
    let n1 = values[1];
    let n2 = value_difference(n0, n1);
    let n3 = values[2];
    let n4 = ricci_scale(0.0, n2);
    let n5 = ricci_scale(n4, n3);
    let n6 = 0.0 + ricci_power(n2, n5, 4.0);
    let n7 = n6 + ricci_power(n3, n5, 4.0);
    let n8 = ricci_root(n7, n5, 4.0);
    let n9 = vec3<f32>(0.0) + ricci_slope(n2, n8, 4.0);
    let n10 = n9 + ricci_slope(n3, n8, 4.0);
    let n11 = vec4<f32>(n8, n10);
    return n11;
}
"
        );
        // The smooth intersection folds left to right on the negations; a sum starts at 0.
        let tree = BlendTree::SmoothIntersection {
            width: 0.25,
            of: vec![
                BlendTree::Sum(vec![BlendTree::Group(1), BlendTree::Group(0)]),
                BlendTree::Group(2),
            ],
        };
        let values = BlendWgsl::new(&tree, 3).values;
        assert!(values.contains("let n2 = vec4<f32>(0.0) + n0;"), "{values}");
        assert!(values.contains("let n3 = n2 + n1;"), "{values}");
        assert!(
            values.contains("let n5 = -smooth_max(-n3, -n4, 0.25);"),
            "{values}"
        );
    }

    /// Operators without operands give the CPU's empty results, and the composition has no rule
    /// for them or for the smooth operators.
    #[test]
    fn empty_operators_and_smooth_compositions_have_the_cpus_answers() {
        let wgsl = BlendWgsl::new(&BlendTree::Max(vec![]), 1);
        assert!(
            wgsl.values.contains("let n0 = vec4<f32>(0.0);"),
            "{}",
            wgsl.values
        );
        assert!(
            wgsl.composition.contains("Composed(groups[0], false)"),
            "{}",
            wgsl.composition
        );
        let smooth = BlendWgsl::new(
            &BlendTree::SmoothUnion {
                width: 0.3,
                of: vec![BlendTree::Group(0), BlendTree::Group(1)],
            },
            2,
        );
        assert!(
            smooth.composition.contains("Composed(groups[0], false)"),
            "{}",
            smooth.composition
        );
        let sum = BlendWgsl::new(
            &BlendTree::Sum(vec![BlendTree::Group(0), BlendTree::Group(1)]),
            2,
        );
        assert!(!sum.composition.contains("false"), "{}", sum.composition);
    }
}
