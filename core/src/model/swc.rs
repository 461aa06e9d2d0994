//! SWC morphology files — the standard format of neuron reconstructions — read as skeletons.
//! Each line is `id type x y z radius parent` (`parent` −1 at a root), `#` starts a comment.
//! Samples become skeleton vertices with the file's radii, parent links become segments; each
//! SWC type (1 soma, 2 axon, 3 basal dendrite, 4 apical dendrite, others by number) becomes a
//! group, and each tree of a type one skeleton. A branch that leaves a sample of another type
//! (a dendrite growing from the soma) starts from a copy of that sample's centre with the
//! branch's radius, so the parts stay joined (the soma's own ball is in its group). A segment
//! whose radius changes faster than the kernel's support allows (`|Δr|/L < 1/σ`, the
//! sphere-cone condition the scene checks) has its child's radius brought within it; the import
//! says how many. A bad line is one error naming the file, the line and the value.

use std::collections::{BTreeMap, HashMap};

use super::kernel::Kernel;
use super::scene::{Group, Material, Scene, Skeleton, SkeletonField, Vertex};

/// One sample of an SWC file.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// Its id, unique in the file.
    pub id: i64,
    /// SWC structure type.
    pub kind: i64,
    /// Position.
    pub position: [f64; 3],
    /// Radius (> 0).
    pub radius: f64,
    /// The parent's id, `None` at a root.
    pub parent: Option<i64>,
}

/// The samples of an SWC text, checked: ids unique, parents present, no cycle.
///
/// # Errors
/// The first bad line: `source:LINE: what` with the offending value.
pub fn parse(text: &str, source: &str) -> Result<Vec<Sample>, String> {
    let mut samples = Vec::new();
    let mut lines = HashMap::new();
    for (k, line) in text.lines().enumerate() {
        let n = k + 1;
        let content = line.split('#').next().unwrap_or("").trim();
        if content.is_empty() {
            continue;
        }
        let fail = |what: String| format!("{source}:{n}: {what}");
        let fields: Vec<&str> = content.split_whitespace().collect();
        if fields.len() != 7 {
            return Err(fail(format!(
                "expected 7 fields (id type x y z radius parent), found {}: '{content}'",
                fields.len()
            )));
        }
        let integer = |i: usize, name: &str| {
            fields[i]
                .parse::<i64>()
                .map_err(|_| fail(format!("{name} '{}' is not a whole number", fields[i])))
        };
        let real = |i: usize, name: &str| {
            fields[i]
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| fail(format!("{name} '{}' is not a finite number", fields[i])))
        };
        let id = integer(0, "id")?;
        let kind = integer(1, "type")?;
        let position = [real(2, "x")?, real(3, "y")?, real(4, "z")?];
        let radius = real(5, "radius")?;
        if radius <= 0.0 {
            return Err(fail(format!(
                "radius {radius} of sample {id} is not positive"
            )));
        }
        let parent = integer(6, "parent")?;
        if lines.insert(id, n).is_some() {
            return Err(fail(format!("sample id {id} is used twice")));
        }
        samples.push(Sample {
            id,
            kind,
            position,
            radius,
            parent: (parent != -1).then_some(parent),
        });
    }
    let parent_of: HashMap<i64, Option<i64>> = samples.iter().map(|s| (s.id, s.parent)).collect();
    for s in &samples {
        if let Some(p) = s.parent
            && !parent_of.contains_key(&p)
        {
            return Err(format!(
                "{source}:{}: parent {p} of sample {} is not in the file",
                lines[&s.id], s.id
            ));
        }
        // Walk up: a path longer than the file is a cycle.
        let mut at = s.parent;
        for _ in 0..samples.len() {
            match at {
                Some(p) => at = parent_of[&p],
                None => break,
            }
        }
        if at.is_some() {
            return Err(format!(
                "{source}:{}: sample {} is on a cycle of parent links",
                lines[&s.id], s.id
            ));
        }
    }
    if samples.is_empty() {
        return Err(format!("{source}: no samples"));
    }
    Ok(samples)
}

/// The name of an SWC structure type's group.
fn type_name(kind: i64) -> String {
    match kind {
        1 => "soma".to_owned(),
        2 => "axon".to_owned(),
        3 => "basal dendrite".to_owned(),
        4 => "apical dendrite".to_owned(),
        other => format!("type {other}"),
    }
}

/// A colour per group, in the order the groups come.
fn colour(k: usize) -> [f64; 3] {
    const COLOURS: [[f64; 3]; 6] = [
        [0.85, 0.55, 0.45],
        [0.45, 0.6, 0.85],
        [0.5, 0.8, 0.5],
        [0.85, 0.75, 0.4],
        [0.7, 0.5, 0.8],
        [0.6, 0.6, 0.6],
    ];
    COLOURS[k % COLOURS.len()]
}

/// Brings each segment's radius change within `limit` per unit length, from the roots out:
/// the child's radius moves towards its parent's. Returns how many radii moved.
fn limit_slopes(skeleton: &mut Skeleton, limit: f64) -> usize {
    let mut moved = vec![false; skeleton.vertices.len()];
    // Edges are (parent, child) in tree order from the file; passes settle any order.
    for _ in 0..skeleton.vertices.len() {
        let mut changed = false;
        for &[p, c] in &skeleton.edges {
            let (parent, child) = (skeleton.vertices[p as usize], skeleton.vertices[c as usize]);
            let d = [0, 1, 2].map(|k| parent.position[k] - child.position[k]);
            let length = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            let reach = limit * length;
            let radius = child
                .radius
                .clamp(parent.radius - reach, parent.radius + reach)
                .max(parent.radius.min(child.radius).min(1e-6));
            if radius != child.radius {
                skeleton.vertices[c as usize].radius = radius;
                moved[c as usize] = true;
                changed = true;
            }
        }
        if !changed {
            break;
        }
    }
    moved.iter().filter(|m| **m).count()
}

/// The scene of `samples` and how many radii were brought within the kernel's slope limit: one
/// group per SWC type (by type number), in each one SCALIS skeleton per tree of that type; a
/// sample whose parent is of another type starts its branch from a copy of the parent's centre
/// with its own radius. Summed groups, the default camera and lights (frame it once compiled).
#[must_use]
pub fn scene(samples: &[Sample]) -> (Scene, usize) {
    let kernel = Kernel::default();
    let limit = 0.95 / kernel.support_sq().sqrt();
    let mut moved = 0;
    let by_id: HashMap<i64, &Sample> = samples.iter().map(|s| (s.id, s)).collect();
    // Per type, the samples of that type in file order.
    let mut types: BTreeMap<i64, Vec<&Sample>> = BTreeMap::new();
    for s in samples {
        types.entry(s.kind).or_default().push(s);
    }
    let mut groups = Vec::new();
    for (k, (kind, members)) in types.iter().enumerate() {
        // The root of each sample's tree within its type: walk up while the parent has the
        // same type.
        let root_of = |s: &Sample| {
            let mut at = s;
            while let Some(p) = at.parent.map(|p| by_id[&p])
                && p.kind == *kind
            {
                at = p;
            }
            at.id
        };
        let mut trees: BTreeMap<i64, Vec<&Sample>> = BTreeMap::new();
        for s in members {
            trees.entry(root_of(s)).or_default().push(s);
        }
        let skeletons = trees
            .values()
            .enumerate()
            .map(|(t, tree)| {
                let mut index: HashMap<i64, u32> = HashMap::new();
                let mut vertices = Vec::new();
                let mut add = |s: &Sample, vertices: &mut Vec<Vertex>| {
                    *index.entry(s.id).or_insert_with(|| {
                        vertices.push(Vertex {
                            position: s.position,
                            radius: s.radius,
                        });
                        (vertices.len() - 1) as u32
                    })
                };
                let mut edges = Vec::new();
                for s in tree {
                    let me = add(s, &mut vertices);
                    if let Some(parent) = s.parent.map(|p| by_id[&p]) {
                        // Same type: a segment of this tree; another type: a copy of the
                        // parent's centre with this sample's radius starts the branch.
                        let start = if parent.kind == *kind {
                            *parent
                        } else {
                            Sample {
                                radius: s.radius,
                                ..*parent
                            }
                        };
                        let other = add(&start, &mut vertices);
                        edges.push([other, me]);
                    }
                }
                let mut skeleton = Skeleton {
                    name: format!("{} {}", type_name(*kind), t + 1),
                    field: SkeletonField::Scalis,
                    end_correctors: false,
                    vertices,
                    edges,
                };
                moved += limit_slopes(&mut skeleton, limit);
                skeleton
            })
            .collect();
        groups.push(Group {
            name: type_name(*kind),
            kernel,
            material: Material {
                color: colour(k),
                ..Material::default()
            },
            skeletons,
            blobs: Vec::new(),
            shapes: Vec::new(),
            hrbfs: Vec::new(),
            transform: Default::default(),
            repeat: None,
        });
    }
    let scene = Scene {
        version: super::scene::SCENE_VERSION,
        isovalue: 1.0,
        groups,
        blend: None,
        camera: super::scene::Camera::default(),
        lights: Scene::default_lights(),
    };
    (scene, moved)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn comments_blank_lines_and_a_soma_with_two_dendrites() {
        let text = "# a neuron\n\n1 1 0 0 0 1.0 -1\n2 3 2 0 0 0.5 1 # first\n3 3 4 0 0 0.4 2\n4 3 0 2 0 0.5 1\n5 2 0 -2 0 0.3 1\n";
        let samples = parse(text, "n.swc").unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(samples.len(), 5);
        let (s, moved) = scene(&samples);
        assert_eq!(moved, 0);
        let names: Vec<&str> = s.groups.iter().map(|g| g.name.as_str()).collect();
        assert_eq!(names, ["soma", "axon", "basal dendrite"]);
        // The dendrites: two trees from the soma, each starting at a copy of it.
        let dendrites = &s.groups[2].skeletons;
        assert_eq!(dendrites.len(), 2);
        assert_eq!(dendrites[0].vertices.len(), 3);
        assert_eq!(dendrites[0].edges.len(), 2);
        assert_eq!(
            dendrites[0].vertices[1].radius, 0.5,
            "the soma's centre, with the branch's radius"
        );
        assert_eq!(s.groups[0].skeletons[0].vertices.len(), 1);
        s.validate().unwrap_or_else(|e| panic!("{e}"));
    }

    /// A radius that changes faster along a segment than the kernel's support allows is
    /// brought within the limit (the scene validates), and the import counts it.
    #[test]
    fn steep_radius_changes_are_brought_within_the_kernel_limit() {
        let text = "1 3 0 0 0 1.0 -1\n2 3 0.5 0 0 0.1 1\n3 3 1.0 0 0 0.1 2\n";
        let samples = parse(text, "n.swc").unwrap_or_else(|e| panic!("{e}"));
        let (s, moved) = scene(&samples);
        // The second sample's radius moves up towards the first's, then the third's towards it.
        assert_eq!(moved, 2);
        s.validate().unwrap_or_else(|e| panic!("{e}"));
        let v = &s.groups[0].skeletons[0].vertices;
        assert_eq!(v[0].radius, 1.0);
        assert!(v[1].radius > 0.1 && v[1].radius < 1.0, "{}", v[1].radius);
    }

    #[test]
    fn bad_lines_name_the_file_the_line_and_the_value() {
        let cases = [
            ("1 1 0 0 0 1 -1\n2 3 0 0\n", "n.swc:2: expected 7 fields"),
            ("1 1 0 0 x 1 -1\n", "n.swc:1: z 'x' is not a finite number"),
            ("1 1 0 0 0 -2 -1\n", "n.swc:1: radius -2 of sample 1"),
            (
                "1 1 0 0 0 1 -1\n1 3 0 0 0 1 1\n",
                "n.swc:2: sample id 1 is used twice",
            ),
            ("1 1 0 0 0 1 7\n", "n.swc:1: parent 7 of sample 1"),
            ("1 1 0 0 0 1 2\n2 1 0 0 0 1 1\n", "cycle"),
            ("1 1 0 0 NaN 1 -1\n", "not a finite number"),
            ("# nothing\n", "no samples"),
        ];
        for (text, want) in cases {
            let e = parse(text, "n.swc").err().unwrap_or_default();
            assert!(e.contains(want), "{text:?}: {e}");
        }
    }
}
