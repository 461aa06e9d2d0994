//! Mirror symmetry while modelling: a plane through the origin across one world axis. Each
//! skeleton vertex and blob has a twin — the item of its group at its mirrored position (itself
//! on the plane) — found by position, so twins stay linked as long as edits keep them mirrored,
//! which every edit below does: sketching adds the mirrored vertex beside the new one, moves
//! move the twin by the mirrored offset, radius changes and deletes reach the twin too.
//! "Symmetrize" rebuilds each skeleton and the blobs of a group from its positive side.

use glam::DVec3;
use skeletrace_core::Scene;
use skeletrace_core::model::scene::{Skeleton, Vertex};

use super::selection::{self, Item, Selection};
pub use super::state::Mirror;

/// How close two positions must be to be twins: a millionth of the scene's extent (its items'
/// spread), at least 1e-9.
fn tolerance(scene: &Scene) -> f64 {
    let mut extent: f64 = 0.0;
    for item in selection::all_items(scene) {
        if let Some((p, r)) = item.world_ball(scene) {
            extent = extent.max(DVec3::from_array(p).length() + r);
        }
    }
    (extent * 1e-6).max(1e-9)
}

/// The twin of `item` (itself on the plane), if the scene has one: a vertex or a blob of its
/// group at its mirrored world position.
#[must_use]
pub fn twin(scene: &Scene, item: Item, mirror: Mirror) -> Option<Item> {
    let (p, _) = item.world_ball(scene)?;
    let tol = tolerance(scene);
    let target = DVec3::from_array(mirror.point(p));
    selection::all_items(scene)
        .into_iter()
        .filter(|other| other.group() == item.group())
        .filter(|other| {
            matches!(
                (other, item),
                (Item::Vertex { .. }, Item::Vertex { .. }) | (Item::Blob { .. }, Item::Blob { .. })
            )
        })
        .find(|other| {
            other
                .world_ball(scene)
                .is_some_and(|(q, _)| DVec3::from_array(q).distance(target) <= tol)
        })
}

/// The twins of `chosen` that are not chosen themselves (nor on the plane).
#[must_use]
pub fn twins(scene: &Scene, chosen: &Selection, mirror: Mirror) -> Selection {
    chosen
        .iter()
        .filter_map(|&item| twin(scene, item, mirror))
        .filter(|t| !chosen.contains(t))
        .collect()
}

/// Moves `chosen` by the world offset `delta`, and under `mirror` their twins by its mirror
/// image.
pub fn translate(scene: &mut Scene, chosen: &Selection, delta: [f64; 3], mirror: Option<Mirror>) {
    let others = mirror.map(|m| (twins(scene, chosen, m), m.point(delta)));
    selection::translate_in_view(scene, chosen, delta);
    if let Some((others, mirrored)) = others {
        selection::translate_in_view(scene, &others, mirrored);
    }
}

/// `chosen` and, under `mirror`, their twins.
fn with_twins(scene: &Scene, chosen: &Selection, mirror: Option<Mirror>) -> Selection {
    match mirror {
        Some(m) => chosen.union(&twins(scene, chosen, m)).copied().collect(),
        None => chosen.clone(),
    }
}

/// Scales the radii of `chosen` and, under `mirror`, of their twins by `factor`.
pub fn scale_radius(scene: &mut Scene, chosen: &Selection, factor: f64, mirror: Option<Mirror>) {
    let both = with_twins(scene, chosen, mirror);
    selection::scale_radius(scene, &both, factor);
}

/// Deletes `chosen` and, under `mirror`, their twins.
pub fn delete(scene: &mut Scene, chosen: &Selection, mirror: Option<Mirror>) {
    let both = with_twins(scene, chosen, mirror);
    selection::delete(scene, &both);
}

/// Sketches a vertex at the world point `position` as [`selection::sketch_vertex`] does, and
/// its mirror image joined to the twin of the vertex it grows from (to that vertex itself where
/// it lies on the plane); a vertex sketched on the plane has no twin. Returns the new vertex.
pub fn sketch_vertex(
    scene: &mut Scene,
    chosen: &Selection,
    group: usize,
    position: [f64; 3],
    radius: f64,
    mirror: Option<Mirror>,
) -> Item {
    let Some(mirror) = mirror else {
        return selection::sketch_vertex(scene, chosen, group, position, radius);
    };
    let parent_twin = match chosen.iter().collect::<Vec<_>>()[..] {
        [&item @ Item::Vertex { .. }] => twin(scene, item, mirror),
        _ => None,
    };
    let added = selection::sketch_vertex(scene, chosen, group, position, radius);
    if mirror.on_plane(position, tolerance(scene)) {
        return added;
    }
    let from: Selection = parent_twin.into_iter().collect();
    let group = added.group();
    // Without a parent the new vertex starts a skeleton: so does its twin, with its radius.
    let radius = added.world_ball(scene).map_or(radius, |(_, r)| r);
    selection::sketch_vertex(scene, &from, group, mirror.point(position), radius);
    added
}

/// Rebuilds every skeleton of the group from its side where the mirror axis is positive: the
/// other side's vertices go, those off the plane are mirrored over with their segments (a
/// segment crossing the plane is cut at its positive end). Blobs likewise. Positions are those
/// of the group's own frame, which `transform` places: an untransformed group is symmetric in
/// the world.
pub fn symmetrize(scene: &mut Scene, group: usize, mirror: Mirror) {
    let tol = tolerance(scene);
    let Some(g) = scene.groups.get_mut(group) else {
        return;
    };
    for skeleton in &mut g.skeletons {
        *skeleton = symmetric(skeleton, mirror, tol);
    }
    g.skeletons.retain(|s| !s.vertices.is_empty());
    let kept: Vec<_> = g
        .blobs
        .iter()
        .copied()
        .filter(|b| b.center[mirror.axis()] >= -tol)
        .collect();
    let mut blobs = kept.clone();
    for b in kept {
        if !mirror.on_plane(b.center, tol) {
            blobs.push(skeletrace_core::model::scene::Blob {
                center: mirror.point(b.center),
                ..b
            });
        }
    }
    g.blobs = blobs;
}

/// `skeleton`'s positive side and its mirror image.
fn symmetric(skeleton: &Skeleton, mirror: Mirror, tol: f64) -> Skeleton {
    let keep: Vec<bool> = skeleton
        .vertices
        .iter()
        .map(|v| v.position[mirror.axis()] >= -tol)
        .collect();
    let mut vertices: Vec<Vertex> = Vec::new();
    let mut index = vec![None; skeleton.vertices.len()];
    for (k, v) in skeleton.vertices.iter().enumerate() {
        if keep[k] {
            index[k] = Some(vertices.len() as u32);
            vertices.push(*v);
        }
    }
    // The mirror copies of the kept vertices off the plane (on the plane: themselves).
    let mut mirrored = index.clone();
    for (k, v) in skeleton.vertices.iter().enumerate() {
        if keep[k] && !mirror.on_plane(v.position, tol) {
            mirrored[k] = Some(vertices.len() as u32);
            vertices.push(Vertex {
                position: mirror.point(v.position),
                ..*v
            });
        }
    }
    let mut edges = Vec::new();
    for &[a, b] in &skeleton.edges {
        let (a, b) = (a as usize, b as usize);
        if let (Some(ia), Some(ib)) = (index[a], index[b]) {
            edges.push([ia, ib]);
            if let (Some(ma), Some(mb)) = (mirrored[a], mirrored[b])
                && [ma, mb] != [ia, ib]
            {
                edges.push([ma, mb]);
            }
        }
    }
    Skeleton {
        vertices,
        edges,
        ..skeleton.clone()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scene() -> Scene {
        crate::editor::templates::Template::Empty.scene()
    }

    fn vertices(scene: &Scene) -> Vec<Vertex> {
        scene.groups[0]
            .skeletons
            .iter()
            .flat_map(|s| s.vertices.iter().copied())
            .collect()
    }

    /// Every vertex has a twin at its mirrored position with its radius.
    fn assert_mirrored(scene: &Scene, mirror: Mirror) {
        let all = vertices(scene);
        for v in &all {
            let m = mirror.point(v.position);
            assert!(
                all.iter().any(
                    |w| DVec3::from_array(w.position).distance(DVec3::from_array(m)) < 1e-9
                        && w.radius == v.radius
                ),
                "no twin of {v:?} in {all:?}"
            );
        }
    }

    /// A limb sketched off the plane from a vertex on it gets its mirror image; moving, scaling
    /// and deleting a vertex reach its twin; the scene stays mirrored throughout.
    #[test]
    fn sketching_moving_scaling_and_deleting_keep_the_twins() {
        let mirror = Mirror::X;
        let mut s = scene();
        let spine = sketch_vertex(&mut s, &Selection::new(), 0, [0.0; 3], 0.3, Some(mirror));
        assert_eq!(vertices(&s).len(), 1, "on the plane: no twin");
        let shoulder = sketch_vertex(
            &mut s,
            &Selection::from([spine]),
            0,
            [0.5, 0.2, 0.0],
            0.3,
            Some(mirror),
        );
        let hand = sketch_vertex(
            &mut s,
            &Selection::from([shoulder]),
            0,
            [1.0, 0.1, 0.1],
            0.3,
            Some(mirror),
        );
        assert_eq!(vertices(&s).len(), 5);
        assert_mirrored(&s, mirror);
        let edges: usize = s.groups[0].skeletons.iter().map(|k| k.edges.len()).sum();
        assert_eq!(edges, 4, "the twin limb is joined to the spine");
        s.validate().unwrap_or_else(|e| panic!("{e}"));

        translate(
            &mut s,
            &Selection::from([hand]),
            [0.1, 0.3, -0.2],
            Some(mirror),
        );
        assert_mirrored(&s, mirror);
        scale_radius(&mut s, &Selection::from([shoulder]), 0.7, Some(mirror));
        assert_mirrored(&s, mirror);
        let twin_of_hand =
            twin(&s, hand, mirror).unwrap_or_else(|| panic!("the hand has its twin"));
        assert_ne!(twin_of_hand, hand);
        delete(&mut s, &Selection::from([hand]), Some(mirror));
        assert_eq!(vertices(&s).len(), 3);
        assert_mirrored(&s, mirror);
    }

    /// Symmetrize keeps the positive side and mirrors it: a lopsided skeleton crossing the
    /// plane becomes symmetric, with segments on both sides.
    #[test]
    fn symmetrize_mirrors_the_positive_side() {
        let mirror = Mirror::Z;
        let mut s = scene();
        s.groups[0].skeletons.push(Skeleton {
            name: "lopsided".to_owned(),
            field: skeletrace_core::model::scene::SkeletonField::Scalis,
            end_correctors: false,
            vertices: vec![
                Vertex {
                    position: [0.0, 0.0, 0.0],
                    radius: 0.3,
                },
                Vertex {
                    position: [0.2, 0.1, 0.6],
                    radius: 0.2,
                },
                Vertex {
                    position: [0.0, 0.5, -0.4],
                    radius: 0.2,
                },
            ],
            edges: vec![[0, 1], [0, 2]],
        });
        symmetrize(&mut s, 0, mirror);
        assert_mirrored(&s, mirror);
        let k = &s.groups[0].skeletons[0];
        assert_eq!(k.vertices.len(), 3, "the centre, one side and its mirror");
        assert_eq!(k.edges.len(), 2);
        s.validate().unwrap_or_else(|e| panic!("{e}"));
    }
}
