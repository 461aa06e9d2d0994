//! Command-line round trips on the real binary: generate → info for every kind, `info` on every
//! asset, and one clear error line with a non-zero exit for bad input.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn skeletrace(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_skeletrace"))
        .args(args)
        .output()
        .unwrap_or_else(|e| panic!("cannot run skeletrace: {e}"))
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("skeletrace-cli-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{e}"));
    dir
}

#[test]
fn generate_then_info_for_every_kind_is_deterministic() {
    let dir = temp_dir("generate");
    for (kind, size) in [
        ("tree", "4"),
        ("random-skeleton", "30"),
        ("foam", "10"),
        ("truss", "2"),
        ("blobs", "30"),
        ("molecule", "300"),
    ] {
        let a = dir.join(format!("{kind}-a.ron"));
        let b = dir.join(format!("{kind}-b.ron"));
        for out in [&a, &b] {
            let o = skeletrace(&[
                "generate",
                kind,
                "--seed",
                "42",
                "--size",
                size,
                "-o",
                out.to_str().unwrap_or_default(),
            ]);
            assert!(o.status.success(), "{kind}: {}", text(&o.stderr));
        }
        let (ta, tb) = (std::fs::read_to_string(&a), std::fs::read_to_string(&b));
        assert!(
            ta.is_ok() && ta.ok() == tb.ok(),
            "{kind}: same seed, different files"
        );
        let info = skeletrace(&["info", a.to_str().unwrap_or_default()]);
        assert!(info.status.success(), "{kind}: {}", text(&info.stderr));
        let out = text(&info.stdout);
        assert!(
            out.contains("validation ok") && out.contains("bounds"),
            "{out}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn info_works_on_every_asset() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/scenes");
    let mut count = 0;
    for entry in std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{e}"))
        .flatten()
    {
        let path = entry.path();
        if path.extension().is_none_or(|e| e != "ron") {
            continue;
        }
        let o = skeletrace(&["info", path.to_str().unwrap_or_default()]);
        assert!(
            o.status.success(),
            "{}: {}",
            path.display(),
            text(&o.stderr)
        );
        count += 1;
    }
    assert!(count >= 8);
}

#[test]
fn bad_input_gets_one_line_and_a_failure_status() {
    let dir = temp_dir("bad");
    let broken = dir.join("broken.ron");
    std::fs::write(
        &broken,
        "(\n  version: 1,\n  groups: [(blobs: [(center: (0.0, 0.0, 0.0), radius: -2.0)])],\n)\n",
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let missing = dir.join("missing.ron");
    for (args, expected) in [
        (
            vec!["info", broken.to_str().unwrap_or_default()],
            vec!["broken.ron:3:", "radius", "-2"],
        ),
        (
            vec!["info", missing.to_str().unwrap_or_default()],
            vec!["missing.ron", "cannot read"],
        ),
        (
            vec![broken.to_str().unwrap_or_default()],
            vec!["broken.ron:3:", "radius"],
        ),
    ] {
        let o = skeletrace(&args);
        assert!(!o.status.success(), "{args:?} succeeded");
        let err = text(&o.stderr);
        assert_eq!(err.trim_end().lines().count(), 1, "{args:?}: {err}");
        for word in expected {
            assert!(err.contains(word), "{args:?}: {err:?} lacks {word:?}");
        }
        assert!(!err.contains("panicked"), "{err}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn no_argument_uses_the_embedded_default_scene() {
    let o = skeletrace(&[]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert!(text(&o.stdout).contains("embedded creature.ron"));
}

#[test]
fn stats_json_follows_the_design_schema() {
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/scenes/blobs.ron");
    let o = skeletrace(&[
        "stats",
        scene.to_str().unwrap_or_default(),
        "--methods",
        "segment,quadratic-taylor",
        "--rays",
        "600",
        "--json",
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let out = text(&o.stdout);
    for key in [
        "\"scene\"",
        "\"rays\": 600",
        "\"name\": \"segment\"",
        "\"name\": \"quadratic-taylor\"",
        "\"hits\"",
        "\"missed\": 0",
        "\"spurious\": 0",
        "\"avg_steps\"",
        "\"median_steps\"",
        "\"p95_steps\"",
        "\"max_steps\"",
        "\"ns_per_ray\"",
        "\"max_depth_error\"",
    ] {
        assert!(out.contains(key), "{key} missing from {out}");
    }
    let bad = skeletrace(&[
        "stats",
        scene.to_str().unwrap_or_default(),
        "--methods",
        "warp-drive",
    ]);
    assert!(!bad.status.success());
    assert!(text(&bad.stderr).contains("unknown method 'warp-drive'"));
}
