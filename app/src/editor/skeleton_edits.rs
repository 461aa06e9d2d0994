//! Edits of a skeleton's graph beyond connect and disconnect: insert a vertex into a segment,
//! merge two vertices, dissolve a vertex into the segment between its two neighbours. Each
//! works on the selection and says in words why it cannot.

use skeletrace_core::Scene;
use skeletrace_core::model::scene::{Skeleton, Vertex};

use super::selection::{Item, Selection, keep_vertices, selected_vertices, two_of_one_skeleton};

/// The three edits, as the Edit menu and the keys name them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SkeletonEdit {
    /// [`insert_vertex`].
    Insert,
    /// [`merge_vertices`].
    Merge,
    /// [`dissolve_vertex`].
    Dissolve,
}

impl SkeletonEdit {
    /// The undo entry's name.
    #[must_use]
    pub const fn name(self) -> &'static str {
        match self {
            Self::Insert => "insert vertex",
            Self::Merge => "merge vertices",
            Self::Dissolve => "dissolve vertex",
        }
    }

    /// What it needs and does, for the menu's tooltip.
    #[must_use]
    pub const fn hint(self) -> &'static str {
        match self {
            Self::Insert => "select two joined vertices: a vertex splits their segment",
            Self::Merge => "select two vertices of one skeleton: one vertex halfway replaces them",
            Self::Dissolve => "select a vertex of two segments: its neighbours are joined instead",
        }
    }
}

fn skeleton_mut(scene: &mut Scene, group: usize, skeleton: usize) -> Result<&mut Skeleton, String> {
    scene
        .groups
        .get_mut(group)
        .and_then(|g| g.skeletons.get_mut(skeleton))
        .ok_or_else(|| "the selected skeleton is gone".to_owned())
}

/// The vertex halfway between `a` and `b`, with their mean radius.
fn halfway(a: &Vertex, b: &Vertex) -> Vertex {
    Vertex {
        position: [0, 1, 2].map(|k| 0.5 * (a.position[k] + b.position[k])),
        radius: 0.5 * (a.radius + b.radius),
    }
}

/// Splits the segment between the two selected vertices at its middle: a new vertex of their
/// mean radius, joined to both. Returns the new vertex, to be selected.
///
/// # Errors
/// Unless exactly two vertices of one skeleton joined by a segment are selected.
pub fn insert_vertex(scene: &mut Scene, selection: &Selection) -> Result<Item, String> {
    let (group, skeleton, a, b) = two_of_one_skeleton(selection, "insert a vertex between")?;
    let s = skeleton_mut(scene, group, skeleton)?;
    let (a32, b32) = (a as u32, b as u32);
    let Some(edge) = s
        .edges
        .iter()
        .position(|&e| e == [a32, b32] || e == [b32, a32])
    else {
        return Err("the two vertices are not joined by a segment".to_owned());
    };
    let middle = halfway(&s.vertices[a], &s.vertices[b]);
    s.vertices.push(middle);
    let new = (s.vertices.len() - 1) as u32;
    let [from, to] = s.edges[edge];
    s.edges[edge] = [from, new];
    s.edges.push([new, to]);
    Ok(Item::Vertex {
        group,
        skeleton,
        vertex: new as usize,
    })
}

/// Merges the two selected vertices of one skeleton into one halfway between them with their
/// mean radius, joined to the neighbours of both (the segment between them goes). Returns the
/// merged vertex, to be selected.
///
/// # Errors
/// Unless exactly two vertices of one skeleton are selected.
pub fn merge_vertices(scene: &mut Scene, selection: &Selection) -> Result<Item, String> {
    let (group, skeleton, a, b) = two_of_one_skeleton(selection, "merge")?;
    let (keep, gone) = (a.min(b), a.max(b));
    let s = skeleton_mut(scene, group, skeleton)?;
    s.vertices[keep] = halfway(&s.vertices[keep], &s.vertices[gone]);
    let (keep32, gone32) = (keep as u32, gone as u32);
    let mut edges: Vec<[u32; 2]> = Vec::with_capacity(s.edges.len());
    for &[x, y] in &s.edges {
        let redirect = |v: u32| if v == gone32 { keep32 } else { v };
        let (x, y) = (redirect(x), redirect(y));
        if x != y && !edges.iter().any(|&e| e == [x, y] || e == [y, x]) {
            edges.push([x, y]);
        }
    }
    s.edges = edges;
    let removed: Vec<bool> = (0..s.vertices.len()).map(|v| v == gone).collect();
    keep_vertices(s, &removed);
    Ok(Item::Vertex {
        group,
        skeleton,
        vertex: keep,
    })
}

/// Removes the one selected vertex, which has exactly two neighbours, and joins them.
///
/// # Errors
/// Unless exactly one vertex, of two segments, is selected.
pub fn dissolve_vertex(scene: &mut Scene, selection: &Selection) -> Result<(), String> {
    let [(group, skeleton, v)] = selected_vertices(selection)[..] else {
        return Err("select exactly one vertex to dissolve".to_owned());
    };
    let s = skeleton_mut(scene, group, skeleton)?;
    let v32 = v as u32;
    let neighbours: Vec<u32> = s
        .edges
        .iter()
        .filter_map(|&[x, y]| match (x == v32, y == v32) {
            (true, false) => Some(y),
            (false, true) => Some(x),
            _ => None,
        })
        .collect();
    let [p, q] = neighbours[..] else {
        return Err(format!(
            "a vertex dissolves into the segment between its two neighbours; this one has {}",
            neighbours.len()
        ));
    };
    if !s.edges.iter().any(|&e| e == [p, q] || e == [q, p]) {
        s.edges.push([p, q]);
    }
    let removed: Vec<bool> = (0..s.vertices.len()).map(|u| u == v).collect();
    keep_vertices(s, &removed);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use skeletrace_core::model::scene::SkeletonField;

    /// A chain 0 – 1 – 2 – 3 along x, radii 0.1, 0.2, 0.3, 0.4, in group 0.
    fn chain() -> Scene {
        let mut scene = super::super::Template::Empty.scene();
        scene.groups[0].skeletons = vec![Skeleton {
            name: "chain".into(),
            field: SkeletonField::Scalis,
            end_correctors: false,
            vertices: (0..4)
                .map(|i| Vertex {
                    position: [f64::from(i), 0.0, 0.0],
                    radius: 0.1 * f64::from(i + 1),
                })
                .collect(),
            edges: vec![[0, 1], [1, 2], [2, 3]],
        }];
        scene
    }

    fn vertex(v: usize) -> Item {
        Item::Vertex {
            group: 0,
            skeleton: 0,
            vertex: v,
        }
    }

    fn picked(items: &[usize]) -> Selection {
        items.iter().map(|&v| vertex(v)).collect()
    }

    #[test]
    fn inserting_splits_the_segment_at_its_middle() {
        let mut scene = chain();
        let new = insert_vertex(&mut scene, &picked(&[2, 1])).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(new, vertex(4));
        let s = &scene.groups[0].skeletons[0];
        assert_eq!(s.vertices[4].position, [1.5, 0.0, 0.0]);
        assert!((s.vertices[4].radius - 0.25).abs() < 1e-12);
        assert_eq!(s.edges, vec![[0, 1], [1, 4], [2, 3], [4, 2]]);
        let why = insert_vertex(&mut scene, &picked(&[0, 3]))
            .err()
            .unwrap_or_default();
        assert!(why.contains("not joined"), "{why}");
    }

    #[test]
    fn merging_joins_the_neighbours_of_both() {
        let mut scene = chain();
        let kept = merge_vertices(&mut scene, &picked(&[1, 2])).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(kept, vertex(1));
        let s = &scene.groups[0].skeletons[0];
        assert_eq!(s.vertices.len(), 3);
        assert_eq!(s.vertices[1].position, [1.5, 0.0, 0.0]);
        // 0 – 1 and the old 2 – 3, now 1 – 2; the merged segment is gone.
        assert_eq!(s.edges, vec![[0, 1], [1, 2]]);
    }

    #[test]
    fn dissolving_reconnects_the_two_neighbours() {
        let mut scene = chain();
        dissolve_vertex(&mut scene, &picked(&[1])).unwrap_or_else(|e| panic!("{e}"));
        let s = &scene.groups[0].skeletons[0];
        assert_eq!(s.vertices.len(), 3);
        assert_eq!(s.vertices[1].position, [2.0, 0.0, 0.0]);
        assert_eq!(s.edges, vec![[1, 2], [0, 1]]);
        let why = dissolve_vertex(&mut scene, &picked(&[0]))
            .err()
            .unwrap_or_default();
        assert!(why.contains("has 1"), "{why}");
    }
}
