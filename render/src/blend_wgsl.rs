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
//! each pipeline take minutes.
//!
//! The code holds the tree's structure only. The operators' parameters (a smooth blend's width,
//! a Ricci exponent) are data: `blend_parameters[k]` at a constant index `k`, one slot per
//! parametrised operator in pre-order ([`blend_parameters`]), uploaded with the scene. Dragging a
//! parameter's slider therefore compiles nothing; a scene whose tree changes shape or operators
//! gets new pipelines (`GpuRenderer::set_scene`).

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

/// The operators' parameters of `tree`, one per smooth blend (its width) and Ricci blend (its
/// exponent), in pre-order: the slot `k` of `blend_parameters[k]` in [`BlendWgsl`]'s code.
#[must_use]
pub fn blend_parameters(tree: &BlendTree) -> Vec<f32> {
    fn walk(tree: &BlendTree, out: &mut Vec<f32>) {
        if let Some(value) = parameter_of(tree) {
            out.push(value as f32);
        }
        for child in children(tree) {
            walk(child, out);
        }
    }
    let mut out = Vec::new();
    walk(tree, &mut out);
    out
}

/// The parameter of an operator that has one.
fn parameter_of(tree: &BlendTree) -> Option<f64> {
    match tree {
        BlendTree::Ricci { p, .. } => Some(*p),
        BlendTree::SmoothUnion { width, .. } | BlendTree::SmoothIntersection { width, .. } => {
            Some(*width)
        }
        _ => None,
    }
}

/// An operator's operands, in order.
fn children(tree: &BlendTree) -> Vec<&BlendTree> {
    match tree {
        BlendTree::Group(_) => Vec::new(),
        BlendTree::Difference(a, b) => vec![a, b],
        BlendTree::Sum(v) | BlendTree::Max(v) | BlendTree::Min(v) => v.iter().collect(),
        BlendTree::Ricci { of, .. }
        | BlendTree::SmoothUnion { of, .. }
        | BlendTree::SmoothIntersection { of, .. } => of.iter().collect(),
    }
}

/// A function body under construction: `let` statements naming each node's result.
struct Body {
    text: String,
    next: usize,
    /// The next parameter slot, in pre-order.
    next_parameter: usize,
}

impl Body {
    /// The parameter slot of the operator being written (visited in pre-order, before its
    /// operands), bound to a name.
    fn parameter(&mut self) -> String {
        let k = self.next_parameter;
        self.next_parameter += 1;
        self.bind(&format!("frame.blend_parameters[{k}]"))
    }

    /// Passes over the parameter slots of a subtree whose code is not written.
    fn skip_parameters(&mut self, tree: &BlendTree) {
        self.next_parameter += blend_parameters(tree).len();
    }

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
        next_parameter: 0,
    };
    let result = node(tree, &mut body);
    format!("fn {signature} {{\n{}    return {result};\n}}\n", body.text)
}

/// The tree's operator with its operands, in the tree's order.
enum Operator<'a> {
    Sum(&'a [BlendTree]),
    Max(&'a [BlendTree]),
    Min(&'a [BlendTree]),
    Difference(&'a BlendTree, &'a BlendTree),
    Ricci(&'a [BlendTree]),
    SmoothUnion(&'a [BlendTree]),
    SmoothIntersection(&'a [BlendTree]),
}

fn operator(tree: &BlendTree) -> Result<Operator<'_>, u32> {
    Ok(match tree {
        BlendTree::Group(g) => return Err(*g),
        BlendTree::Sum(v) => Operator::Sum(v),
        BlendTree::Max(v) => Operator::Max(v),
        BlendTree::Min(v) => Operator::Min(v),
        BlendTree::Difference(a, b) => Operator::Difference(a, b),
        BlendTree::Ricci { of, .. } => Operator::Ricci(of),
        BlendTree::SmoothUnion { of, .. } => Operator::SmoothUnion(of),
        BlendTree::SmoothIntersection { of, .. } => Operator::SmoothIntersection(of),
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
        Operator::Ricci(v) => {
            let p = body.parameter();
            let names: Vec<String> = v.iter().map(|c| node(c, body)).collect();
            Some((words.ricci)(&names, &p, body))
        }
        Operator::SmoothUnion(v) => {
            let w = body.parameter();
            fold(v, body, node, None, |a, b| (words.smooth_max)(a, b, &w))
        }
        Operator::SmoothIntersection(v) => {
            let w = body.parameter();
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
        Operator::Ricci(v) => {
            // The p-norm of the operands' bounds (Hölder), relative to the largest.
            let p = body.parameter();
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
        Operator::SmoothUnion(v) | Operator::SmoothIntersection(v) => {
            body.next_parameter += 1;
            fold(v, body, lipschitz_node, Some("0.0"), max)
        }
        Operator::Max(v) | Operator::Min(v) => fold(v, body, lipschitz_node, Some("0.0"), max),
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
                body.bind(&format!(
                    "composed_shift({b}, -2.0 * frame.globals.isovalue)"
                )),
            ];
            let h = hull(items, body);
            Some(body.bind(&format!("composed_neg({h})")))
        }
        Operator::Ricci(v) => {
            body.next_parameter += 1;
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
        | Operator::SmoothIntersection(..) => {
            body.skip_parameters(tree);
            None
        }
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
    let n0 = frame.blend_parameters[0];
    let n1 = values[0];
    let n2 = values[1];
    let n3 = value_difference(n1, n2);
    let n4 = values[2];
    let n5 = ricci_scale(0.0, n3);
    let n6 = ricci_scale(n5, n4);
    let n7 = 0.0 + ricci_power(n3, n6, n0);
    let n8 = n7 + ricci_power(n4, n6, n0);
    let n9 = ricci_root(n8, n6, n0);
    let n10 = vec3<f32>(0.0) + ricci_slope(n3, n9, n0);
    let n11 = n10 + ricci_slope(n4, n9, n0);
    let n12 = vec4<f32>(n9, n11);
    return n12;
}
"
        );
        assert_eq!(blend_parameters(&tree), vec![4.0]);
        // The smooth intersection folds left to right on the negations; a sum starts at 0.
        let tree = BlendTree::SmoothIntersection {
            width: 0.25,
            of: vec![
                BlendTree::Sum(vec![BlendTree::Group(1), BlendTree::Group(0)]),
                BlendTree::Group(2),
            ],
        };
        let values = BlendWgsl::new(&tree, 3).values;
        assert!(
            values.contains("let n0 = frame.blend_parameters[0];"),
            "{values}"
        );
        assert!(values.contains("let n3 = vec4<f32>(0.0) + n1;"), "{values}");
        assert!(values.contains("let n4 = n3 + n2;"), "{values}");
        assert!(
            values.contains("let n6 = -smooth_max(-n4, -n5, n0);"),
            "{values}"
        );
    }

    /// A tree with a parameter under every kind of parametrised operator, nested, and under a
    /// smooth blend (which the composition has no rule for, so its code skips the subtree).
    fn nested(width: f64, p: f64, inner_width: f64) -> BlendTree {
        BlendTree::Sum(vec![
            BlendTree::SmoothUnion {
                width,
                of: vec![
                    BlendTree::Ricci {
                        p,
                        of: vec![BlendTree::Group(0), BlendTree::Group(1)],
                    },
                    BlendTree::Group(2),
                ],
            },
            BlendTree::Ricci {
                p: p + 1.0,
                of: vec![
                    BlendTree::SmoothIntersection {
                        width: inner_width,
                        of: vec![BlendTree::Group(3), BlendTree::Group(1)],
                    },
                    BlendTree::Group(0),
                ],
            },
        ])
    }

    /// The code holds the tree's structure only: changing every parameter changes the uploaded
    /// slots, not one character of the four functions, and no parameter's value appears in
    /// them as a literal.
    #[test]
    fn parameters_are_data_at_constant_slots() {
        let a = nested(0.125, 3.0, 0.375);
        let b = nested(0.5, 7.5, 0.0625);
        assert_eq!(BlendWgsl::new(&a, 4), BlendWgsl::new(&b, 4));
        assert_eq!(blend_parameters(&a), vec![0.125, 3.0, 4.0, 0.375]);
        assert_eq!(blend_parameters(&b), vec![0.5, 7.5, 8.5, 0.0625]);
        let wgsl = BlendWgsl::new(&a, 4);
        let all = format!(
            "{}{}{}",
            wgsl.values, wgsl.jets_and_lipschitz, wgsl.composition
        );
        for literal in ["0.125", "3.0", "4.0", "0.375"] {
            assert!(!all.contains(literal), "{literal} in\n{all}");
        }
    }

    /// Each function reads an operator's parameter from the same slot: the slot of the
    /// operator's pre-order position, also where a function writes no code for a subtree.
    #[test]
    fn every_function_reads_each_operator_from_its_own_slot() {
        let wgsl = BlendWgsl::new(&nested(0.125, 3.0, 0.375), 4);
        let slots = |text: &str| -> Vec<usize> {
            text.match_indices("blend_parameters[")
                .map(|(i, m)| {
                    let rest = &text[i + m.len()..];
                    let end = rest.find(']').unwrap_or_else(|| panic!("unclosed slot"));
                    rest[..end]
                        .parse()
                        .unwrap_or_else(|e| panic!("slot {}: {e}", &rest[..end]))
                })
                .collect()
        };
        assert_eq!(slots(&wgsl.values), vec![0, 1, 2, 3]);
        let (jets, lipschitz) = wgsl.jets_and_lipschitz.split_at(
            wgsl.jets_and_lipschitz
                .find("fn blend_lipschitz")
                .unwrap_or_else(|| panic!("no blend_lipschitz")),
        );
        assert_eq!(slots(jets), vec![0, 1, 2, 3]);
        // The Lipschitz bound needs only the Ricci exponents (max bounds a smooth blend).
        assert_eq!(slots(lipschitz), vec![1, 2]);
        assert_eq!(slots(&wgsl.composition), Vec::<usize>::new());
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
