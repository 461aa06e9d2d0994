//! What the user has selected, and the scene edits that act on a selection (move, radius,
//! delete, duplicate, connect, disconnect, sketch a vertex, add a blob, change group). Each
//! edit is a pure function of the scene so the document can validate and record it. HRBF
//! points (2023 eq. 9) are items too: they move, delete and duplicate like the others, have no
//! radius, and stay in their group (a group with an HRBF set holds nothing else).
//!
//! Items are stored in their group's frame; the overlay shows them where the surface is, through
//! the group's transform and the first copy of its repetition ([`placement`]). Edits made in
//! the viewport take world positions and offsets and map them back ([`translate_in_view`],
//! [`to_group_frame`]).

use std::collections::BTreeSet;

use glam::DVec3;
use skeletrace_core::Scene;
use skeletrace_core::field::geometry::Similarity;
use skeletrace_core::field::program::group_transform;
use skeletrace_core::model::scene::{Blob, HrbfPoint, Skeleton, SkeletonField, Vertex};

/// A pickable item of the skeleton overlay.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Item {
    /// A skeleton vertex.
    Vertex {
        /// Group index.
        group: usize,
        /// Skeleton index in the group.
        skeleton: usize,
        /// Vertex index in the skeleton.
        vertex: usize,
    },
    /// A point blob.
    Blob {
        /// Group index.
        group: usize,
        /// Blob index in the group.
        blob: usize,
    },
    /// A point of an HRBF set.
    HrbfPoint {
        /// Group index.
        group: usize,
        /// Set index in the group.
        set: usize,
        /// Point index in the set.
        point: usize,
    },
}

impl Item {
    /// Group the item belongs to.
    #[must_use]
    pub fn group(self) -> usize {
        match self {
            Self::Vertex { group, .. }
            | Self::Blob { group, .. }
            | Self::HrbfPoint { group, .. } => group,
        }
    }

    /// `(centre, radius)` in `scene` (radius 0 for HRBF points), `None` when the item no
    /// longer exists.
    #[must_use]
    pub fn ball(self, scene: &Scene) -> Option<([f64; 3], f64)> {
        match self {
            Self::Vertex {
                group,
                skeleton,
                vertex,
            } => {
                let v = scene
                    .groups
                    .get(group)?
                    .skeletons
                    .get(skeleton)?
                    .vertices
                    .get(vertex)?;
                Some((v.position, v.radius))
            }
            Self::Blob { group, blob } => {
                let b = scene.groups.get(group)?.blobs.get(blob)?;
                Some((b.center, b.radius))
            }
            Self::HrbfPoint { .. } => Some((self.hrbf_point(scene)?.position, 0.0)),
        }
    }

    /// [`Self::ball`] where the overlay shows it: through its group's [`placement`].
    #[must_use]
    pub fn world_ball(self, scene: &Scene) -> Option<([f64; 3], f64)> {
        let (centre, radius) = self.ball(scene)?;
        let place = placement(scene, self.group());
        Some((
            place.point(DVec3::from_array(centre)).to_array(),
            place.scale * radius,
        ))
    }

    /// The HRBF point this item names, if it is one and still exists.
    #[must_use]
    pub fn hrbf_point(self, scene: &Scene) -> Option<&HrbfPoint> {
        match self {
            Self::HrbfPoint { group, set, point } => {
                scene.groups.get(group)?.hrbfs.get(set)?.points.get(point)
            }
            _ => None,
        }
    }
}

/// Every item of the scene.
#[must_use]
pub fn all_items(scene: &Scene) -> Vec<Item> {
    let mut items = Vec::new();
    for (group, g) in scene.groups.iter().enumerate() {
        for (skeleton, s) in g.skeletons.iter().enumerate() {
            items.extend((0..s.vertices.len()).map(|vertex| Item::Vertex {
                group,
                skeleton,
                vertex,
            }));
        }
        items.extend((0..g.blobs.len()).map(|blob| Item::Blob { group, blob }));
        for (set, h) in g.hrbfs.iter().enumerate() {
            items.extend((0..h.points.len()).map(|point| Item::HrbfPoint { group, set, point }));
        }
    }
    items
}

/// The selection.
pub type Selection = BTreeSet<Item>;

/// Where group `group`'s items are shown and edited in the viewport: its transform, which
/// places the first copy of its repetition (the identity for a group that no longer exists).
#[must_use]
pub fn placement(scene: &Scene, group: usize) -> Similarity {
    scene
        .groups
        .get(group)
        .map_or(Similarity::IDENTITY, group_transform)
}

/// The world point `p` in group `group`'s frame (the inverse of its [`placement`]).
#[must_use]
pub fn to_group_frame(scene: &Scene, group: usize, p: [f64; 3]) -> [f64; 3] {
    placement(scene, group)
        .inverse_point(DVec3::from_array(p))
        .to_array()
}

/// Moves the selected items by the world offset `delta` (each mapped into its group's frame).
pub fn translate_in_view(scene: &mut Scene, selection: &Selection, delta: [f64; 3]) {
    for &item in selection {
        let place = placement(scene, item.group());
        let local = place.inverse_direction(DVec3::from_array(delta)) / place.scale;
        shift(position_mut(scene, item), local.to_array());
    }
}

/// Centroid of the selected items where the viewport shows them.
#[must_use]
pub fn centroid(scene: &Scene, selection: &Selection) -> Option<[f64; 3]> {
    let balls: Vec<_> = selection
        .iter()
        .filter_map(|i| i.world_ball(scene))
        .collect();
    if balls.is_empty() {
        return None;
    }
    let n = balls.len() as f64;
    let mut c = [0.0; 3];
    for (p, _) in &balls {
        for k in 0..3 {
            c[k] += p[k] / n;
        }
    }
    Some(c)
}

/// Moves the selected items by `delta` in their groups' frames.
pub fn translate(scene: &mut Scene, selection: &Selection, delta: [f64; 3]) {
    for &item in selection {
        shift(position_mut(scene, item), delta);
    }
}

/// The stored position of `item` (in its group's frame).
fn position_mut(scene: &mut Scene, item: Item) -> &mut [f64; 3] {
    match item {
        Item::Vertex {
            group,
            skeleton,
            vertex,
        } => &mut scene.groups[group].skeletons[skeleton].vertices[vertex].position,
        Item::Blob { group, blob } => &mut scene.groups[group].blobs[blob].center,
        Item::HrbfPoint { group, set, point } => {
            &mut scene.groups[group].hrbfs[set].points[point].position
        }
    }
}

fn shift(p: &mut [f64; 3], delta: [f64; 3]) {
    for k in 0..3 {
        p[k] += delta[k];
    }
}

/// Multiplies the selected items' radii by `factor` (HRBF points have none).
pub fn scale_radius(scene: &mut Scene, selection: &Selection, factor: f64) {
    for &item in selection {
        match item {
            Item::Vertex {
                group,
                skeleton,
                vertex,
            } => scene.groups[group].skeletons[skeleton].vertices[vertex].radius *= factor,
            Item::Blob { group, blob } => scene.groups[group].blobs[blob].radius *= factor,
            Item::HrbfPoint { .. } => {}
        }
    }
}

/// Removes the selected items (and the segments that touch removed vertices).
pub fn delete(scene: &mut Scene, selection: &Selection) {
    for (group, g) in scene.groups.iter_mut().enumerate() {
        let mut index = 0;
        g.blobs.retain(|_| {
            let keep = !selection.contains(&Item::Blob { group, blob: index });
            index += 1;
            keep
        });
        for (skeleton, s) in g.skeletons.iter_mut().enumerate() {
            let removed: Vec<bool> = (0..s.vertices.len())
                .map(|vertex| {
                    selection.contains(&Item::Vertex {
                        group,
                        skeleton,
                        vertex,
                    })
                })
                .collect();
            keep_vertices(s, &removed);
        }
        g.skeletons.retain(|s| !s.vertices.is_empty());
        for (set, h) in g.hrbfs.iter_mut().enumerate() {
            let mut point = 0;
            h.points.retain(|_| {
                let keep = !selection.contains(&Item::HrbfPoint { group, set, point });
                point += 1;
                keep
            });
        }
        g.hrbfs.retain(|h| !h.points.is_empty());
    }
}

/// Removes the vertices marked in `removed` and the segments that reach them, renumbering the
/// others.
pub(super) fn keep_vertices(s: &mut Skeleton, removed: &[bool]) {
    let mut new_index = Vec::with_capacity(removed.len());
    let mut next = 0u32;
    for &r in removed {
        new_index.push(if r { None } else { Some(next) });
        next += u32::from(!r);
    }
    s.edges = s
        .edges
        .iter()
        .filter_map(|&[a, b]| Some([new_index[a as usize]?, new_index[b as usize]?]))
        .collect();
    let mut i = 0;
    s.vertices.retain(|_| {
        let keep = !removed[i];
        i += 1;
        keep
    });
}

/// Copies the selected items (with the segments between selected vertices) offset by
/// `offset`; returns the copies, to be selected.
pub fn duplicate(scene: &mut Scene, selection: &Selection, offset: [f64; 3]) -> Selection {
    let shifted = |p: [f64; 3]| [p[0] + offset[0], p[1] + offset[1], p[2] + offset[2]];
    let mut copies = Selection::new();
    for (group, g) in scene.groups.iter_mut().enumerate() {
        let blobs: Vec<Blob> = g
            .blobs
            .iter()
            .enumerate()
            .filter(|(blob, _)| selection.contains(&Item::Blob { group, blob: *blob }))
            .map(|(_, b)| Blob {
                center: shifted(b.center),
                ..*b
            })
            .collect();
        for b in blobs {
            copies.insert(Item::Blob {
                group,
                blob: g.blobs.len(),
            });
            g.blobs.push(b);
        }
        for (set, h) in g.hrbfs.iter_mut().enumerate() {
            let chosen: Vec<HrbfPoint> = (0..h.points.len())
                .filter(|&point| selection.contains(&Item::HrbfPoint { group, set, point }))
                .map(|point| HrbfPoint {
                    position: shifted(h.points[point].position),
                    ..h.points[point]
                })
                .collect();
            for copy in chosen {
                copies.insert(Item::HrbfPoint {
                    group,
                    set,
                    point: h.points.len(),
                });
                h.points.push(copy);
            }
        }
        for (skeleton, s) in g.skeletons.iter_mut().enumerate() {
            let chosen: Vec<usize> = (0..s.vertices.len())
                .filter(|&vertex| {
                    selection.contains(&Item::Vertex {
                        group,
                        skeleton,
                        vertex,
                    })
                })
                .collect();
            let first = s.vertices.len();
            for (k, &v) in chosen.iter().enumerate() {
                let copy = Vertex {
                    position: shifted(s.vertices[v].position),
                    ..s.vertices[v]
                };
                s.vertices.push(copy);
                copies.insert(Item::Vertex {
                    group,
                    skeleton,
                    vertex: first + k,
                });
            }
            let copy_of = |v: u32| {
                chosen
                    .iter()
                    .position(|&c| c == v as usize)
                    .map(|k| (first + k) as u32)
            };
            let new_edges: Vec<[u32; 2]> = s
                .edges
                .iter()
                .filter_map(|&[a, b]| Some([copy_of(a)?, copy_of(b)?]))
                .collect();
            s.edges.extend(new_edges);
        }
    }
    copies
}

/// The selected vertices as (group, skeleton, vertex).
pub(super) fn selected_vertices(selection: &Selection) -> Vec<(usize, usize, usize)> {
    selection
        .iter()
        .filter_map(|i| match *i {
            Item::Vertex {
                group,
                skeleton,
                vertex,
            } => Some((group, skeleton, vertex)),
            Item::Blob { .. } | Item::HrbfPoint { .. } => None,
        })
        .collect()
}

/// The two selected vertices of one skeleton as (group, skeleton, a, b), or why not (`what`
/// names the edit).
pub(super) fn two_of_one_skeleton(
    selection: &Selection,
    what: &str,
) -> Result<(usize, usize, usize, usize), String> {
    let [(g, s, a), (g2, s2, b)] = selected_vertices(selection)[..] else {
        return Err(format!("select exactly two vertices to {what}"));
    };
    if (g, s) != (g2, s2) {
        return Err("the two vertices belong to different skeletons".to_owned());
    }
    Ok((g, s, a, b))
}

/// Joins two selected vertices of one skeleton by a segment; `Err` says why not.
///
/// # Errors
/// Not exactly two vertices of the same skeleton, or already joined.
pub fn connect(scene: &mut Scene, selection: &Selection) -> Result<(), String> {
    let (g, s, a, b) = two_of_one_skeleton(selection, "connect")?;
    let edges = &mut scene.groups[g].skeletons[s].edges;
    let (a, b) = (a as u32, b as u32);
    if edges.iter().any(|&e| e == [a, b] || e == [b, a]) {
        return Err("these vertices are already connected".to_owned());
    }
    edges.push([a, b]);
    Ok(())
}

/// Removes the segments whose two ends are selected.
pub fn disconnect(scene: &mut Scene, selection: &Selection) {
    for (group, g) in scene.groups.iter_mut().enumerate() {
        for (skeleton, s) in g.skeletons.iter_mut().enumerate() {
            let selected = |v: u32| {
                selection.contains(&Item::Vertex {
                    group,
                    skeleton,
                    vertex: v as usize,
                })
            };
            s.edges.retain(|&[a, b]| !(selected(a) && selected(b)));
        }
    }
}

/// Sketch mode: adds a vertex at the world point `position`, joined to the one selected vertex
/// if there is one (same radius), or starting a new skeleton in `group` (`radius` in world
/// units). Returns the new vertex.
pub fn sketch_vertex(
    scene: &mut Scene,
    selection: &Selection,
    group: usize,
    position: [f64; 3],
    radius: f64,
) -> Item {
    let from = match selection.iter().collect::<Vec<_>>()[..] {
        [
            &Item::Vertex {
                group,
                skeleton,
                vertex,
            },
        ] => Some((group, skeleton, vertex)),
        _ => None,
    };
    if let Some((group, skeleton, vertex)) = from {
        let position = to_group_frame(scene, group, position);
        let s = &mut scene.groups[group].skeletons[skeleton];
        let radius = s.vertices[vertex].radius;
        s.vertices.push(Vertex { position, radius });
        let new = s.vertices.len() - 1;
        s.edges.push([vertex as u32, new as u32]);
        return Item::Vertex {
            group,
            skeleton,
            vertex: new,
        };
    }
    let position = to_group_frame(scene, group, position);
    let radius = radius / placement(scene, group).scale;
    let g = &mut scene.groups[group];
    g.skeletons.push(Skeleton {
        name: format!("sketch {}", g.skeletons.len() + 1),
        field: SkeletonField::Scalis,
        end_correctors: false,
        vertices: vec![Vertex { position, radius }],
        edges: Vec::new(),
    });
    Item::Vertex {
        group,
        skeleton: g.skeletons.len() - 1,
        vertex: 0,
    }
}

/// Moves the selected blobs, and the skeletons holding selected vertices, to `target`.
/// Returns the moved items' new identities. HRBF points stay in their set.
pub fn assign_group(scene: &mut Scene, selection: &Selection, target: usize) -> Selection {
    let mut moved = Selection::new();
    let skeletons: BTreeSet<(usize, usize)> = selection
        .iter()
        .filter_map(|i| match *i {
            Item::Vertex {
                group, skeleton, ..
            } if group != target => Some((group, skeleton)),
            _ => None,
        })
        .collect();
    let blobs: BTreeSet<(usize, usize)> = selection
        .iter()
        .filter_map(|i| match *i {
            Item::Blob { group, blob } if group != target => Some((group, blob)),
            _ => None,
        })
        .collect();
    // Remove from the back so earlier indices stay valid.
    for &(group, skeleton) in skeletons.iter().rev() {
        let s = scene.groups[group].skeletons.remove(skeleton);
        let n = s.vertices.len();
        scene.groups[target].skeletons.push(s);
        let skeleton = scene.groups[target].skeletons.len() - 1;
        moved.extend((0..n).map(|vertex| Item::Vertex {
            group: target,
            skeleton,
            vertex,
        }));
    }
    for &(group, blob) in blobs.iter().rev() {
        let b = scene.groups[group].blobs.remove(blob);
        scene.groups[target].blobs.push(b);
        moved.insert(Item::Blob {
            group: target,
            blob: scene.groups[target].blobs.len() - 1,
        });
    }
    moved
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scene() -> Scene {
        Scene::from_ron(crate::DEFAULT_SCENE, "creature").unwrap_or_else(|e| panic!("{e}"))
    }

    #[test]
    fn deleting_a_vertex_drops_its_segments_and_renumbers_the_rest() {
        let mut s = scene();
        let before = s.groups[0].skeletons[0].clone();
        let selection = Selection::from([Item::Vertex {
            group: 0,
            skeleton: 0,
            vertex: 0,
        }]);
        delete(&mut s, &selection);
        let after = &s.groups[0].skeletons[0];
        assert_eq!(after.vertices.len(), before.vertices.len() - 1);
        let touching = before.edges.iter().filter(|e| e.contains(&0)).count();
        assert_eq!(after.edges.len(), before.edges.len() - touching);
        assert!(
            after
                .edges
                .iter()
                .all(|e| e.iter().all(|&v| (v as usize) < after.vertices.len()))
        );
    }

    #[test]
    fn duplicate_then_connect_and_disconnect() {
        let mut s = scene();
        let pair = Selection::from([
            Item::Vertex {
                group: 0,
                skeleton: 0,
                vertex: 0,
            },
            Item::Vertex {
                group: 0,
                skeleton: 0,
                vertex: 1,
            },
        ]);
        let edges = s.groups[0].skeletons[0].edges.len();
        let copies = duplicate(&mut s, &pair, [0.0, 1.0, 0.0]);
        assert_eq!(copies.len(), 2);
        disconnect(&mut s, &copies);
        let after_cut = s.groups[0].skeletons[0].edges.len();
        connect(&mut s, &copies).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(s.groups[0].skeletons[0].edges.len(), after_cut + 1);
        assert!(connect(&mut s, &copies).is_err(), "already connected");
        assert!(after_cut >= edges);
    }

    #[test]
    fn hrbf_points_move_duplicate_and_delete_as_items() {
        let mut s = Scene::from_ron(include_str!("../../../assets/scenes/hrbf.ron"), "hrbf")
            .unwrap_or_else(|e| panic!("{e}"));
        let points = |s: &Scene| s.groups[0].hrbfs[0].points.len();
        let n = points(&s);
        let items = all_items(&s);
        let first = Item::HrbfPoint {
            group: 0,
            set: 0,
            point: 0,
        };
        assert!(items.contains(&first));
        let selection = Selection::from([first]);
        let before = first.ball(&s).unwrap_or_else(|| panic!("point 0"));
        assert_eq!(before.1, 0.0, "HRBF points have no radius");
        translate(&mut s, &selection, [0.1, 0.0, -0.2]);
        scale_radius(&mut s, &selection, 2.0);
        let after = s.groups[0].hrbfs[0].points[0];
        assert_eq!(
            after.position,
            [before.0[0] + 0.1, before.0[1], before.0[2] - 0.2]
        );
        let copies = duplicate(&mut s, &selection, [0.0, 0.5, 0.0]);
        assert_eq!(points(&s), n + 1);
        let copy = copies.iter().next().and_then(|c| c.hrbf_point(&s)).copied();
        assert_eq!(copy.map(|c| c.normal), Some(after.normal));
        assert!(
            assign_group(&mut s, &copies, 1).is_empty(),
            "HRBF points stay in their set"
        );
        delete(&mut s, &copies);
        assert_eq!(points(&s), n);
        assert!(connect(&mut s, &selection).is_err());
    }

    #[test]
    fn viewport_edits_of_a_transformed_group_land_where_the_overlay_shows_them() {
        let mut s = scene();
        s.groups[0].transform = skeletrace_core::model::scene::Transform {
            translate: [0.5, -0.25, 1.0],
            rotate: [20.0, -35.0, 60.0],
            scale: 1.7,
        };
        s.groups[0].repeat = Some(skeletrace_core::model::scene::Repeat {
            count: [2, 1, 1],
            spacing: [0.8, 0.0, 0.0],
        });
        let vertex = Item::Vertex {
            group: 0,
            skeleton: 0,
            vertex: 0,
        };
        let (before, r_before) = vertex.world_ball(&s).unwrap_or_else(|| panic!("vertex"));
        let local_r = vertex.ball(&s).map_or(0.0, |b| b.1);
        assert!((r_before - 1.7 * local_r).abs() < 1e-12);
        let delta = [0.3, -0.1, 0.2];
        translate_in_view(&mut s, &Selection::from([vertex]), delta);
        let (after, _) = vertex.world_ball(&s).unwrap_or_else(|| panic!("vertex"));
        for k in 0..3 {
            assert!(
                (after[k] - before[k] - delta[k]).abs() < 1e-12,
                "{after:?} vs {before:?}"
            );
        }
        // A sketched vertex appears at the clicked world point, with the world radius asked.
        let added = sketch_vertex(&mut s, &Selection::new(), 0, [1.0, 2.0, 3.0], 0.34);
        let (at, r) = added.world_ball(&s).unwrap_or_else(|| panic!("sketched"));
        assert!((DVec3::from_array(at) - DVec3::new(1.0, 2.0, 3.0)).length() < 1e-12);
        assert!((r - 0.34).abs() < 1e-12);
    }
}
