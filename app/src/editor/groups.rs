//! Groups as a modeller manages them: add, duplicate, delete, rename and reorder, each one
//! undoable edit. The blend tree names groups by index, so every change of the list rewrites
//! the tree with it: a new group joins the root operator's operands (or a sum with the tree),
//! a deleted group's leaves leave the tree (an operator left without operands goes too, a
//! difference without its first operand becomes nothing), and a move swaps the two indices.

use skeletrace_core::Scene;
use skeletrace_core::model::scene::{Blend, Group};

/// The tree with every group index mapped by `map` (`None`: the leaf goes); `None` when nothing
/// of the tree is left.
fn remap(blend: &Blend, map: &dyn Fn(u32) -> Option<u32>) -> Option<Blend> {
    let all = |v: &[Blend]| -> Vec<Blend> { v.iter().filter_map(|b| remap(b, map)).collect() };
    let some = |v: Vec<Blend>| (!v.is_empty()).then_some(v);
    Some(match blend {
        Blend::Group(g) => Blend::Group(map(*g)?),
        Blend::Sum(v) => Blend::Sum(some(all(v))?),
        Blend::Max(v) => Blend::Max(some(all(v))?),
        Blend::Min(v) => Blend::Min(some(all(v))?),
        Blend::Difference(a, b) => match (remap(a, map), remap(b, map)) {
            (Some(a), Some(b)) => Blend::Difference(Box::new(a), Box::new(b)),
            (Some(a), None) => a,
            (None, _) => return None,
        },
        Blend::Ricci { p, of } => Blend::Ricci {
            p: *p,
            of: some(all(of))?,
        },
        Blend::SmoothUnion { width, of } => Blend::SmoothUnion {
            width: *width,
            of: some(all(of))?,
        },
        Blend::SmoothIntersection { width, of } => Blend::SmoothIntersection {
            width: *width,
            of: some(all(of))?,
        },
    })
}

/// Adds `group` at the end of the list; in a blend tree it joins the root's operands where the
/// root takes any number of them, else the tree and it are summed. Returns its index.
pub fn add(scene: &mut Scene, group: Group) -> usize {
    scene.groups.push(group);
    let g = scene.groups.len() - 1;
    let leaf = Blend::Group(g as u32);
    if let Some(tree) = scene.blend.take() {
        scene.blend = Some(match tree {
            Blend::Sum(mut v) => {
                v.push(leaf);
                Blend::Sum(v)
            }
            Blend::Max(mut v) => {
                v.push(leaf);
                Blend::Max(v)
            }
            Blend::Ricci { p, mut of } => {
                of.push(leaf);
                Blend::Ricci { p, of }
            }
            Blend::SmoothUnion { width, mut of } => {
                of.push(leaf);
                Blend::SmoothUnion { width, of }
            }
            other => Blend::Sum(vec![other, leaf]),
        });
    }
    g
}

/// A new, empty group named after the count, with the kernel and material of group `like`.
#[must_use]
pub fn new_group(scene: &Scene, like: usize) -> Group {
    let mut group = scene.groups.get(like).cloned().unwrap_or_else(|| Group {
        name: String::new(),
        kernel: Default::default(),
        material: Default::default(),
        skeletons: Vec::new(),
        blobs: Vec::new(),
        shapes: Vec::new(),
        hrbfs: Vec::new(),
        transform: Default::default(),
        repeat: None,
    });
    group.name = format!("group {}", scene.groups.len() + 1);
    group.skeletons.clear();
    group.blobs.clear();
    group.shapes.clear();
    group.hrbfs.clear();
    group.transform = Default::default();
    group.repeat = None;
    group
}

/// Removes group `g` and its leaves in the blend tree.
///
/// # Errors
/// The scene's only group (a scene has at least one), or no such group.
pub fn delete(scene: &mut Scene, g: usize) -> Result<(), String> {
    if g >= scene.groups.len() {
        return Err(format!("no group {g}"));
    }
    if scene.groups.len() == 1 {
        return Err("a scene keeps at least one group".to_owned());
    }
    scene.groups.remove(g);
    let g = g as u32;
    let map = |i: u32| match i.cmp(&g) {
        std::cmp::Ordering::Less => Some(i),
        std::cmp::Ordering::Equal => None,
        std::cmp::Ordering::Greater => Some(i - 1),
    };
    scene.blend = scene.blend.as_ref().and_then(|b| remap(b, &map));
    Ok(())
}

/// Swaps groups `a` and `b` (their places in the list and in the blend tree: the scene stays
/// the same shape).
pub fn swap(scene: &mut Scene, a: usize, b: usize) {
    if a >= scene.groups.len() || b >= scene.groups.len() || a == b {
        return;
    }
    scene.groups.swap(a, b);
    let (a, b) = (a as u32, b as u32);
    let map = |i: u32| {
        Some(if i == a {
            b
        } else if i == b {
            a
        } else {
            i
        })
    };
    scene.blend = scene.blend.as_ref().and_then(|t| remap(t, &map));
}

#[cfg(test)]
mod tests {
    use super::*;

    fn operators() -> Scene {
        let path =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/scenes/operators.ron");
        Scene::load(&path).unwrap_or_else(|e| panic!("{e}"))
    }

    /// The operators asset's `Ricci(p: 4, [Difference(0, 1), 2])` through every change.
    #[test]
    fn group_changes_rewrite_the_blend_tree_and_keep_the_scene_valid() {
        let g = Blend::Group;
        let d = |a, b| Blend::Difference(Box::new(g(a)), Box::new(g(b)));
        let ricci = |of| Blend::Ricci { p: 4.0, of };
        let base = operators();
        assert_eq!(base.blend, Some(ricci(vec![d(0, 1), g(2)])));

        let mut s = base.clone();
        let new = new_group(&s, 1);
        assert_eq!(add(&mut s, new), 3);
        assert_eq!(s.blend, Some(ricci(vec![d(0, 1), g(2), g(3)])));
        assert_eq!(s.groups[3].kernel, s.groups[1].kernel);
        assert_eq!(s.groups[3].name, "group 4");
        s.validate().unwrap_or_else(|e| panic!("{e}"));

        // Deleting the carving blobs (group 1) leaves the shapes uncarved; the ground (2)
        // becomes group 1.
        let mut s = base.clone();
        delete(&mut s, 1).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(s.blend, Some(ricci(vec![g(0), g(1)])));
        assert_eq!(s.groups[1].name, "ground");
        s.validate().unwrap_or_else(|e| panic!("{e}"));
        // Deleting the shapes (the difference's base) takes the difference with them.
        let mut s = base.clone();
        delete(&mut s, 0).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(s.blend, Some(ricci(vec![g(1)])));
        s.validate().unwrap_or_else(|e| panic!("{e}"));
        let mut one = base.clone();
        one.groups.truncate(1);
        one.blend = None;
        assert!(delete(&mut one, 0).is_err(), "the last group stays");

        // A swap changes the list, not the field.
        let mut s = base.clone();
        swap(&mut s, 0, 2);
        assert_eq!(s.blend, Some(ricci(vec![d(2, 1), g(0)])));
        assert_eq!(s.groups[0].name, base.groups[2].name);
        swap(&mut s, 0, 2);
        assert_eq!(s, base);
    }

    /// Random delete and swap sequences on generated blend trees keep every leaf in range and
    /// every scene valid.
    #[test]
    fn random_group_edits_keep_the_tree_in_range() {
        use skeletrace_core::model::rng::SplitMix64;
        for seed in 0..40_u64 {
            let mut rng = SplitMix64::new(seed);
            let mut s = operators();
            for _ in 0..6 {
                match rng.below(3) {
                    0 => {
                        let like = rng.below(s.groups.len());
                        let group = new_group(&s, like);
                        add(&mut s, group);
                    }
                    1 => {
                        let victim = rng.below(s.groups.len());
                        let _ = delete(&mut s, victim);
                    }
                    _ => {
                        let n = s.groups.len();
                        swap(&mut s, rng.below(n), rng.below(n));
                    }
                }
                fn leaves(b: &Blend, out: &mut Vec<u32>) {
                    match b {
                        Blend::Group(g) => out.push(*g),
                        Blend::Sum(v) | Blend::Max(v) | Blend::Min(v) => {
                            v.iter().for_each(|c| leaves(c, out));
                        }
                        Blend::Difference(a, b) => {
                            leaves(a, out);
                            leaves(b, out);
                        }
                        Blend::Ricci { of, .. }
                        | Blend::SmoothUnion { of, .. }
                        | Blend::SmoothIntersection { of, .. } => {
                            of.iter().for_each(|c| leaves(c, out));
                        }
                    }
                }
                let mut out = Vec::new();
                if let Some(b) = &s.blend {
                    leaves(b, &mut out);
                }
                assert!(
                    out.iter().all(|&g| (g as usize) < s.groups.len()),
                    "seed {seed}: {:?} with {} groups",
                    s.blend,
                    s.groups.len()
                );
                s.validate().unwrap_or_else(|e| panic!("seed {seed}: {e}"));
            }
        }
    }
}
