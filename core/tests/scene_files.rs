//! Scene files: every asset loads and round-trips exactly, saves are atomic, every kind of bad
//! input gets one message with its position, item and value, and no input makes the loader
//! panic (random bytes and randomly mutated valid scenes).

mod common;

use std::path::Path;

use common::assets;
use glam::DVec3;
use skeletrace_core::model::rng::SplitMix64;
use skeletrace_core::{FieldProgram, Scene, SceneError};

#[test]
fn every_asset_loads_and_round_trips_exactly() {
    let files = assets();
    assert!(
        files.len() >= 8,
        "expected one asset per generator plus hand-made ones: {files:?}"
    );
    for path in files {
        let scene = Scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
        let text = scene.to_ron();
        let again = Scene::from_ron(&text, "round trip").unwrap_or_else(|e| panic!("{e}"));
        assert!(
            again == scene,
            "{} changes when saved and loaded",
            path.display()
        );
        assert_eq!(
            again.to_ron(),
            text,
            "{} text is not stable",
            path.display()
        );
    }
}

#[test]
fn saving_is_atomic_and_reports_the_file_on_failure() {
    let dir = std::env::temp_dir().join(format!("skeletrace-save-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{e}"));
    let path = dir.join("scene.ron");
    let scene = Scene::load(&assets()[0]).unwrap_or_else(|e| panic!("{e}"));
    scene.save(&path).unwrap_or_else(|e| panic!("{e}"));
    scene.save(&path).unwrap_or_else(|e| panic!("{e}"));
    let leftovers: Vec<_> = std::fs::read_dir(&dir)
        .map(|d| d.filter_map(|e| e.ok()).map(|e| e.file_name()).collect())
        .unwrap_or_default();
    assert_eq!(
        leftovers.len(),
        1,
        "temporary files left behind: {leftovers:?}"
    );
    assert!(Scene::load(&path).is_ok_and(|s| s == scene));
    let missing_dir = dir.join("no such folder").join("scene.ron");
    let err = scene
        .save(&missing_dir)
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
    assert!(
        err.contains("no such folder") && err.contains("cannot save"),
        "{err}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_missing_file_names_the_file() {
    let err = Scene::load(Path::new("/nonexistent/scene.ron")).err();
    assert!(matches!(err, Some(SceneError::Read { .. })));
    let text = err.map(|e| e.to_string()).unwrap_or_default();
    assert!(text.contains("/nonexistent/scene.ron"), "{text}");
}

const VALID: &str = r#"(
  version: 1,
  groups: [
    (
      kernel: CompactPolynomial(degree: 6, scale: 2.0),
      skeletons: [
        (
          name: "arm",
          vertices: [
            (position: (0.0, 0.0, 0.0), radius: 0.5),
            (position: (1.0, 0.0, 0.0), radius: 0.4),
          ],
          edges: [(0, 1)],
        ),
      ],
    ),
  ],
)
"#;

/// `(replace this, with this, expected line, words the message must contain)`.
const BROKEN: &[(&str, &str, usize, &[&str])] = &[
    ("radius: 0.4", "radius: -0.4", 11, &["radius", "-0.4"]),
    ("radius: 0.4", "radius: 0.0", 11, &["radius", "got 0"]),
    ("(1.0, 0.0, 0.0)", "(NaN, 0.0, 0.0)", 11, &["finite", "NaN"]),
    ("(1.0, 0.0, 0.0)", "(inf, 0.0, 0.0)", 11, &["finite", "inf"]),
    // Found by mutating the assets: a radius or coordinate of 1e308 passed validation, and
    // its support box overflowed (`export` panicked on an infinite grid).
    (
        "radius: 0.4",
        "radius: 1e308",
        11,
        &["radius", "1e6", "got 1e308"],
    ),
    (
        "radius: 0.4",
        "radius: 1e-320",
        11,
        &["radius", "1e-6", "got 1e-320"],
    ),
    ("(1.0, 0.0, 0.0)", "(1.0, -2e9, 0.0)", 11, &["±1e6", "-2e9"]),
    (
        "scale: 2.0",
        "scale: 1e308",
        5,
        &[
            "support radius",
            "1000 times the prescribed radius",
            "decrease",
        ],
    ),
    (
        "edges: [(0, 1)]",
        "edges: [(0, 7)]",
        14,
        &["arm", "edge 0", "vertex index 7", "2 vertices"],
    ),
    (
        "(1.0, 0.0, 0.0), radius",
        "(0.0, 0.0, 0.0), radius",
        14,
        &["arm", "zero-length"],
    ),
    (
        "edges: [(0, 1)]",
        "edges: [(0, 1), (1, 0)]",
        14,
        &[
            "arm",
            "edge 1 (1, 0)",
            "repeats edge 0 (0, 1)",
            "count twice",
        ],
    ),
    ("scale: 2.0", "scale: 1.0", 5, &["σ = 1", "> 1"]),
    ("degree: 6", "degree: 5", 5, &["degree 5", "even"]),
    (
        "radius: 0.5",
        "radius: 0.95",
        16,
        &["arm", "edge 0", "slope", "0.55"],
    ),
    (
        "version: 1",
        "version: 7",
        2,
        &["version 7", "reads version 1"],
    ),
    ("edges: [(0, 1)],", "edges: [(0, 1)],, ", 13, &[]),
];

#[test]
fn broken_scenes_get_one_clear_message_with_position_item_and_value() {
    for &(from, to, line, words) in BROKEN {
        assert!(VALID.contains(from), "test case {from:?} does not apply");
        let text = VALID.replacen(from, to, 1);
        let err = Scene::from_ron(&text, "broken.ron").err();
        let Some(SceneError::Invalid { line: got_line, .. }) = &err else {
            panic!("{to:?}: expected an invalid-scene error, got {err:?}");
        };
        let message = err.as_ref().map(ToString::to_string).unwrap_or_default();
        assert!(message.starts_with("broken.ron:"), "{message}");
        assert!(!message.contains('\n'), "one line: {message}");
        assert_eq!(*got_line, line, "{to:?}: {message}");
        for w in words {
            assert!(message.contains(w), "{to:?}: {message:?} lacks {w:?}");
        }
    }
    assert!(Scene::from_ron(VALID, "valid.ron").is_ok());
}

#[test]
fn blend_references_are_checked() {
    let text = VALID.replacen(
        "\n)\n",
        "\n  blend: Some(Max([Group(0), Group(3)])),\n)\n",
        1,
    );
    let message = Scene::from_ron(&text, "b.ron")
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
    assert!(
        message.contains("Group(3)") && message.contains("1 groups"),
        "{message}"
    );
    assert!(message.starts_with("b.ron:18:"), "{message}");
}

/// Loads `text`; when it is valid, compiles and evaluates it. Must never panic.
/// Repetitions that would expand a small file past the primitive limit are refused with the
/// count and the limit; the same file with fewer copies loads.
#[test]
fn repetitions_past_the_primitive_limit_are_refused_in_one_line() {
    use skeletrace_core::model::scene::{Blob, Repeat};
    let file = |copies_z: u32| {
        let mut scene = Scene::from_ron(VALID, "valid").unwrap_or_else(|e| panic!("{e}"));
        // 200 blobs and the arm's segment: 201 primitives per copy.
        scene.groups[0].blobs = (0..200)
            .map(|i| Blob {
                center: [f64::from(i) * 0.01, 2.0, 0.0],
                radius: 0.3,
            })
            .collect();
        scene.groups[0].repeat = Some(Repeat {
            count: [10, 10, copies_z],
            spacing: [3.0, 3.0, 3.0],
        });
        scene.to_ron()
    };
    assert!(Scene::from_ron(&file(4), "small.ron").is_ok());
    let err = Scene::from_ron(&file(100), "huge.ron")
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
    assert!(
        err.contains("huge.ron") && err.contains("2010000 primitives") && err.contains("1000000"),
        "{err}"
    );
    assert!(!err.contains('\n'), "{err}");
}

/// The memory estimate of the generator limit covers what one primitive takes.
#[test]
fn the_bytes_per_primitive_estimate_covers_the_types() {
    use skeletrace_core::field::primitives::Primitive;
    use skeletrace_core::model::generate::BYTES_PER_PRIMITIVE;
    use skeletrace_core::model::scene::Vertex;
    let used = std::mem::size_of::<Vertex>()
        + std::mem::size_of::<[u32; 2]>()
        + std::mem::size_of::<Primitive>()
        + 2 * std::mem::size_of::<skeletrace_core::Aabb>()
        + 2 * std::mem::size_of::<u32>();
    assert!(
        used as u64 <= BYTES_PER_PRIMITIVE,
        "{used} bytes per primitive"
    );
}

fn exercise(text: &str) {
    if let Ok(scene) = Scene::from_ron(text, "fuzz.ron") {
        let program = FieldProgram::new(&scene);
        for p in [DVec3::ZERO, DVec3::new(0.3, -0.2, 0.1)] {
            let _ = program.value_gradient(p);
        }
    }
}

#[test]
fn random_bytes_never_panic_the_loader() {
    let mut rng = SplitMix64::new(1);
    for _ in 0..20_000 {
        let len = rng.below(200);
        let bytes: Vec<u8> = (0..len).map(|_| (rng.next_u64() & 0xff) as u8).collect();
        exercise(&String::from_utf8_lossy(&bytes));
    }
}

#[test]
fn mutated_valid_scenes_never_panic_the_loader() {
    let sources: Vec<String> = assets()
        .iter()
        .filter(|p| std::fs::metadata(p).is_ok_and(|m| m.len() < 50_000))
        .filter_map(|p| std::fs::read_to_string(p).ok())
        .chain([VALID.to_owned()])
        .collect();
    let tokens = [
        "NaN",
        "-1.0",
        "0",
        "1e308",
        "-inf",
        "(",
        ")",
        "[",
        "]",
        ",",
        ":",
        "\"",
        "99999999999",
        "Group(0)",
        "Max([",
        "radius",
        "degree: 3",
        "scale: 0.5",
        "Cauchy(degree: 0, scale: 1.0)",
    ];
    let mut rng = SplitMix64::new(2);
    let mut accepted = 0;
    for _ in 0..6_000 {
        let mut text = sources[rng.below(sources.len())].clone().into_bytes();
        for _ in 0..1 + rng.below(4) {
            if text.is_empty() {
                break;
            }
            let at = rng.below(text.len());
            match rng.below(4) {
                0 => {
                    text.remove(at);
                }
                1 => text[at] = b"0123456789.-(),:[]eE"[rng.below(20)],
                2 => {
                    let t = tokens[rng.below(tokens.len())].as_bytes();
                    text.splice(at..at, t.iter().copied());
                }
                _ => {
                    let end = (at + rng.below(30)).min(text.len());
                    text.drain(at..end);
                }
            }
        }
        let text = String::from_utf8_lossy(&text).into_owned();
        if Scene::from_ron(&text, "m.ron").is_ok() {
            accepted += 1;
        }
        exercise(&text);
    }
    // Some mutations (in comments, in names, benign numbers) keep the scene valid.
    assert!(accepted > 0);
}
