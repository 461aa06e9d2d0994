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

/// Standard output parsed as JSON.
fn parse_json(stdout: &str) -> serde_json::Value {
    serde_json::from_str(stdout).unwrap_or_else(|e| panic!("{e}: {stdout}"))
}

/// The names of a `--json` output's `key` list (`methods`, `skipped`).
fn names(value: &serde_json::Value, key: &str) -> Vec<String> {
    value[key]
        .as_array()
        .map(|list| {
            list.iter()
                .filter_map(|m| m["name"].as_str().map(str::to_owned))
                .collect()
        })
        .unwrap_or_default()
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

/// Every scene file of assets/scenes.
fn assets() -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/scenes");
    let mut out: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{e}"))
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == "ron"))
        .collect();
    out.sort();
    out
}

/// Width and height from a PNG header.
fn png_size(path: &Path) -> (u32, u32) {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    assert_eq!(&bytes[1..4], b"PNG", "{} is not a PNG", path.display());
    let word = |i: usize| u32::from_be_bytes([bytes[i], bytes[i + 1], bytes[i + 2], bytes[i + 3]]);
    (word(16), word(20))
}

#[test]
fn info_works_on_every_asset() {
    let mut count = 0;
    for path in assets() {
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
    let deep = dir.join("deep.ron");
    for (args, expected) in [
        (
            vec![
                "generate",
                "tree",
                "--size",
                "40",
                "-o",
                deep.to_str().unwrap_or_default(),
            ],
            vec!["tree of size 40", "limit of 1000000", "--allow-large"],
        ),
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
    assert!(!deep.exists(), "a refused generator writes nothing");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_editor_reports_a_bad_scene_or_a_missing_display_in_one_line() {
    // A broken file is reported by the loader before any window opens.
    let dir = temp_dir("editor");
    let broken = dir.join("broken.ron");
    std::fs::write(
        &broken,
        "(version: 1, groups: [(name: \"g\", blobs: [(center: (0, 0, 0), radius: -1)])])",
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let o = skeletrace(&[broken.to_str().unwrap_or_default()]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        text(&o.stderr).contains("broken.ron"),
        "{}",
        text(&o.stderr)
    );
    // No display at all: one clear message, not a panic (the window itself is checked by
    // scripts/smoke-editor under Xvfb).
    let o = Command::new(env!("CARGO_BIN_EXE_skeletrace"))
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .output()
        .unwrap_or_else(|e| panic!("cannot run skeletrace: {e}"));
    assert_eq!(o.status.code(), Some(1), "{}", text(&o.stderr));
    assert!(
        text(&o.stderr).contains("cannot open the editor window"),
        "{}",
        text(&o.stderr)
    );
    let _ = std::fs::remove_dir_all(&dir);
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
        "\"avg_evaluations\"",
        "\"median_steps\"",
        "\"p95_steps\"",
        "\"max_steps\"",
        "\"out_of_steps\": 0",
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

/// `stats --protocol` and `--transparent` are reported in the JSON, the profiles
/// change the statistics where they should (segment-original does not depend on the profile;
/// quadratic-taylor's first interval does), and an unknown profile is one clear error.
#[test]
fn stats_runs_each_protocol_opaque_and_transparent() {
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/scenes/summed-blobs.ron");
    let scene = scene.to_str().unwrap_or_default();
    let run = |extra: &[&str]| {
        let mut args = vec![
            "stats",
            scene,
            "--methods",
            "segment-original,quadratic-taylor",
            "--rays",
            "300",
            "--json",
        ];
        args.extend_from_slice(extra);
        let o = skeletrace(&args);
        assert!(o.status.success(), "{extra:?}: {}", text(&o.stderr));
        text(&o.stdout)
    };
    let avg = |out: &str, method: &str| -> f64 {
        let value = parse_json(out);
        let methods = value["methods"].as_array().cloned().unwrap_or_default();
        methods
            .iter()
            .find(|m| m["name"] == method)
            .and_then(|m| m["avg_steps"].as_f64())
            .unwrap_or_else(|| panic!("{method} missing from {out}"))
    };
    let default = run(&[]);
    assert_eq!(parse_json(&default)["protocol"], "default", "{default}");
    assert_eq!(parse_json(&default)["transparent"], false, "{default}");
    for protocol in ["paper-2023", "paper-2021"] {
        let out = run(&["--protocol", protocol]);
        assert!(
            out.contains(&format!("\"protocol\": \"{protocol}\"")),
            "{out}"
        );
        assert!(
            out.contains("\"missed\": 0") && !out.contains("\"missed\": 1"),
            "{out}"
        );
    }
    // paper-2021 differs from the default only for the SCALIS tracer and its baseline.
    let paper_2021 = run(&["--protocol", "paper-2021"]);
    assert_eq!(
        avg(&default, "quadratic-taylor"),
        avg(&paper_2021, "quadratic-taylor")
    );
    let transparent = run(&["--transparent"]);
    assert!(
        transparent.contains("\"transparent\": true"),
        "{transparent}"
    );
    for method in ["segment-original", "quadratic-taylor"] {
        assert!(
            avg(&transparent, method) >= avg(&default, method),
            "{method}"
        );
    }
    let bad = skeletrace(&["stats", scene, "--protocol", "paper-1999"]);
    assert!(!bad.status.success());
    assert!(text(&bad.stderr).contains("unknown protocol 'paper-1999'"));
}

/// Requests too small to mean anything or too large to finish (rays, mesh cells, generated
/// scenes) are refused in one line that says the range, instead of being clamped in silence
/// or running out of memory.
#[test]
fn out_of_range_requests_get_one_line_with_the_range() {
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/scenes/blobs.ron");
    let scene = scene.to_str().unwrap_or_default();
    let dir = temp_dir("ranges");
    let mesh = dir.join("mesh.glb");
    let mesh = mesh.to_str().unwrap_or_default();
    let one_line_error = |args: &[&str], expected: &str| {
        let o = skeletrace(args);
        assert!(!o.status.success(), "{args:?} succeeded");
        let err = text(&o.stderr);
        assert!(
            err.contains(expected),
            "{args:?}: {err:?} lacks {expected:?}"
        );
        err
    };
    for rays in ["0", "5", "10000001", "18446744073709551615"] {
        let err = one_line_error(
            &["stats", scene, "--methods", "segment", "--rays", rays],
            "expected from 6 (one per axis direction) to 10000000 on the CPU",
        );
        assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    }
    for cells in ["0", "7", "1025"] {
        one_line_error(
            &["export", scene, "-o", mesh, "--resolution", cells],
            "expected a number of grid cells from 8 to 1024",
        );
    }
    assert!(!Path::new(mesh).exists());
    // The estimate's size in MB, not a saturated product.
    let tree = dir.join("tree.ron");
    let err = one_line_error(
        &[
            "generate",
            "tree",
            "--size",
            "40",
            "--output",
            tree.to_str().unwrap_or_default(),
        ],
        "primitives (about ",
    );
    let number_before = |tail: &str| -> f64 {
        let head = &err[..err.find(tail).unwrap_or(0)];
        let digits: String = head
            .chars()
            .rev()
            .take_while(|c| c.is_ascii_digit() || matches!(c, '.' | 'e' | '+' | '-'))
            .collect();
        digits
            .chars()
            .rev()
            .collect::<String>()
            .parse()
            .unwrap_or(f64::NAN)
    };
    let (primitives, megabytes) = (number_before(" primitives"), number_before(" MB"));
    let per_primitive = megabytes * 1e6 / primitives;
    assert!((399.0..401.0).contains(&per_primitive), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Field inversion steps towards a ray's first entry and stops there: `stats --transparent`
/// leaves it out with its reason instead of counting every exit it never looks for as missed,
/// and naming it is one clear error. Opaque rays still run it.
#[test]
fn stats_leaves_first_crossing_methods_out_of_transparent_rays() {
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/scenes/molecule.ron");
    let scene = scene.to_str().unwrap_or_default();
    let stats = |extra: &[&str]| {
        let mut args = vec!["stats", scene, "--rays", "6", "--json"];
        args.extend_from_slice(extra);
        skeletrace(&args)
    };
    let opaque = stats(&["--methods", "field-inversion,quadratic-taylor"]);
    assert!(opaque.status.success(), "{}", text(&opaque.stderr));
    assert!(
        names(&parse_json(&text(&opaque.stdout)), "methods")
            .contains(&"field-inversion".to_owned())
    );
    let all = stats(&["--methods", "all", "--transparent"]);
    assert!(all.status.success(), "{}", text(&all.stderr));
    let (out, err) = (text(&all.stdout), text(&all.stderr));
    let value = parse_json(&out);
    assert!(
        !names(&value, "methods").contains(&"field-inversion".to_owned()),
        "{out}"
    );
    assert!(
        names(&value, "methods").contains(&"quadratic-taylor".to_owned()),
        "{out}"
    );
    // Left out with its reason, in the JSON as on standard error.
    let skipped = value["skipped"].as_array().cloned().unwrap_or_default();
    assert!(
        skipped.iter().any(|m| m["name"] == "field-inversion"
            && m["reason"]
                .as_str()
                .is_some_and(|r| r.contains("first crossing only"))),
        "{out}"
    );
    assert!(
        err.contains("skipping field-inversion: field inversion finds the first crossing only"),
        "{err}"
    );
    let named = stats(&["--methods", "field-inversion", "--transparent"]);
    assert!(!named.status.success());
    let err = text(&named.stderr);
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    assert!(
        err.contains("method 'field-inversion' cannot trace transparent rays"),
        "{err}"
    );
}

#[test]
fn render_compare_and_stats_json_work_on_every_asset() {
    let dir = temp_dir("compare");
    for scene in assets() {
        let name = scene.file_stem().map(|s| s.to_string_lossy().into_owned());
        let out = dir.join(format!("{}.png", name.unwrap_or_default()));
        let o = skeletrace(&[
            "render",
            scene.to_str().unwrap_or_default(),
            "-o",
            out.to_str().unwrap_or_default(),
            "--compare",
            "all",
            "--size",
            "16x12",
        ]);
        assert!(
            o.status.success(),
            "{}: {}",
            scene.display(),
            text(&o.stderr)
        );
        let panels = text(&o.stdout)
            .lines()
            .filter(|l| l.contains("steps avg"))
            .count();
        assert!(panels >= 10, "{}: {panels} panels", scene.display());
        let (w, h) = png_size(&out);
        assert_eq!(w, 4 * 16, "{}", scene.display());
        assert!(h > 12 * panels.div_ceil(4) as u32, "{}", scene.display());
        let json = skeletrace(&[
            "stats",
            scene.to_str().unwrap_or_default(),
            "--rays",
            "12",
            "--json",
        ]);
        assert!(
            json.status.success(),
            "{}: {}",
            scene.display(),
            text(&json.stderr)
        );
        let body = text(&json.stdout);
        assert!(
            body.starts_with('{') && body.contains("\"methods\": ["),
            "{body}"
        );
        assert_eq!(names(&parse_json(&body), "methods").len(), panels, "{body}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn render_writes_the_requested_size_and_refuses_bad_arguments() {
    let dir = temp_dir("render");
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/scenes/creature.ron");
    let scene = scene.to_str().unwrap_or_default();
    let out = dir.join("shaded.png");
    let o = skeletrace(&[
        "render",
        scene,
        "-o",
        out.to_str().unwrap_or_default(),
        "--size",
        "40x30",
        "--shadows",
        "--soft-shadows",
        "--ao",
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    assert_eq!(png_size(&out), (40, 30));
    let out = out.to_str().unwrap_or_default();
    for (args, expected) in [
        (vec!["--size", "40by30"], "--size '40by30'"),
        (
            vec!["--method", "warp-drive"],
            "unknown method 'warp-drive'",
        ),
        (
            vec!["--method", "field-inversion"],
            "does not apply to this scene: field inversion needs",
        ),
    ] {
        let mut all = vec!["render", scene, "-o", out];
        all.extend(args);
        let o = skeletrace(&all);
        assert!(!o.status.success(), "{all:?} succeeded");
        let err = text(&o.stderr);
        assert_eq!(err.trim_end().lines().count(), 1, "{err}");
        assert!(err.contains(expected), "{err:?} lacks {expected:?}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bench_reports_milliseconds_per_frame_for_each_method() {
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/scenes/blobs.ron");
    let o = skeletrace(&[
        "bench",
        scene.to_str().unwrap_or_default(),
        "--size",
        "16x16",
        "--frames",
        "2",
        "--methods",
        "segment,quadratic-taylor",
        "--json",
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let out = text(&o.stdout);
    for key in [
        "\"device\": \"CPU",
        "\"width\": 16",
        "\"frames\": 2",
        "\"name\": \"segment\"",
        "\"name\": \"quadratic-taylor\"",
    ] {
        assert!(out.contains(key), "{key} missing from {out}");
    }
    let times: Vec<f64> = out
        .split("\"ms_per_frame\": ")
        .skip(1)
        .filter_map(|s| s.split(['}', ',']).next()?.trim().parse().ok())
        .collect();
    assert_eq!(times.len(), 2, "{out}");
    assert!(times.iter().all(|&t| t > 0.0 && t.is_finite()), "{out}");
}

/// `bench --after-edits` moves the point blobs of a blob scene in turn and reports the frames
/// after them with the shares of tiles and pixels copied (pixels include the whole tiles'),
/// the mean and slowest frames and how many edits copied nothing.
#[test]
fn bench_after_edits_reports_the_shares_copied() {
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/scenes/blobs.ron");
    let o = skeletrace(&[
        "bench",
        scene.to_str().unwrap_or_default(),
        "--size",
        "48x40",
        "--methods",
        "quadratic-taylor",
        "--after-edits",
        "--json",
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let out = text(&o.stdout);
    let number = |key: &str| -> f64 {
        out.split(&format!("\"{key}\": "))
            .nth(1)
            .and_then(|s| s.split(['}', ',']).next()?.trim().parse().ok())
            .unwrap_or_else(|| panic!("{key} missing from {out}"))
    };
    let (ms, tiles, pixels) = (
        number("ms_per_frame"),
        number("tiles_reused"),
        number("pixels_reused"),
    );
    assert!(ms > 0.0 && ms.is_finite(), "{out}");
    assert!((0.0..=1.0).contains(&tiles), "{out}");
    assert!(pixels >= tiles && pixels <= 1.0, "{out}");
    assert!(
        pixels > 0.0,
        "moving one blob of several copies pixels: {out}"
    );
    let (mean, slowest, edits, in_full) = (
        number("mean_ms"),
        number("slowest_ms"),
        number("edits"),
        number("traced_in_full"),
    );
    assert!(mean > 0.0 && slowest >= mean && slowest >= ms, "{out}");
    assert!(edits >= 1.0 && (0.0..edits).contains(&in_full), "{out}");
}

/// `trace-ray --json` traces the ray the CPU renderer traces for that pixel: its step counts are
/// the step heat map's there, and its step log (for the marching methods) has one record per
/// step.
#[test]
fn trace_ray_reports_the_heat_maps_step_counts_and_a_consistent_step_log() {
    use skeletrace_core::cpu::renderer::{RenderOptions, Renderer};
    use skeletrace_core::frame::FieldShading;
    use skeletrace_core::methods::MethodId;
    use skeletrace_core::{Scene, compile};

    let scene_path = assets().into_iter().find(|p| p.ends_with("blobs.ron"));
    let scene_path = scene_path.unwrap_or_default();
    let scene = Scene::load(&scene_path).unwrap_or_else(|e| panic!("{e}"));
    let compiled = compile(&scene);
    let (w, h) = (48, 40);
    for method in [
        MethodId::Segment,
        MethodId::QuadraticTaylor,
        MethodId::SphereEnhanced,
    ] {
        let tracer = method
            .method()
            .prepare(&compiled.program, compiled.settings);
        let frame = Renderer::new(&compiled, tracer.as_ref(), compiled.settings).render(
            &scene.camera,
            RenderOptions {
                width: w,
                height: h,
                shadows: false,
                shading: FieldShading::default(),
            },
        );
        for (x, y) in [(24, 20), (10, 30), (40, 5), (30, 22)] {
            let o = skeletrace(&[
                "trace-ray",
                &scene_path.display().to_string(),
                "--pixel",
                &format!("{x},{y}"),
                "--size",
                &format!("{w}x{h}"),
                "--methods",
                method.name(),
                "--json",
            ]);
            assert!(o.status.success(), "{}", text(&o.stderr));
            let out = text(&o.stdout);
            let want = frame.steps[y * w + x];
            assert!(
                out.contains(&format!("\"steps\": {want},")),
                "{method} at ({x}, {y}): the heat map has {want} steps; trace-ray said {out}"
            );
            let records = out.matches("\"t\": ").count();
            if method == MethodId::SphereEnhanced {
                assert!(out.contains("\"log\": null"), "{out}");
            } else {
                assert_eq!(
                    records, want as usize,
                    "{method}: one record per step: {out}"
                );
            }
        }
    }
    let bad = skeletrace(&[
        "trace-ray",
        &scene_path.display().to_string(),
        "--pixel",
        "99,1",
        "--size",
        "48x40",
    ]);
    assert!(!bad.status.success());
    assert!(text(&bad.stderr).contains("outside the 48x40 frame"));
}

/// `bench --backend gpu` reports the size of the frame's tile lists, the first limit a
/// scene of many primitives meets: at 4-pixel tiles, and growing with the frame (the same
/// supports over four times as many tiles); and the first frame's time, which holds the
/// pipelines' compilation (a duration, not compared with anything: timings vary). Skipped without an adapter, unless
/// `SKELETRACE_REQUIRE_GPU=1` (CI) makes that a failure.
#[test]
fn bench_on_the_gpu_reports_the_tile_lists() {
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/scenes/blobs.ron");
    let bench = |size: &str| {
        skeletrace(&[
            "bench",
            scene.to_str().unwrap_or_default(),
            "--backend",
            "gpu",
            "--size",
            size,
            "--frames",
            "1",
            "--methods",
            "quadratic-taylor",
            "--json",
        ])
    };
    let small = bench("32x32");
    if !small.status.success() && std::env::var("SKELETRACE_REQUIRE_GPU").as_deref() != Ok("1") {
        eprintln!("SKIPPED: no GPU adapter ({})", text(&small.stderr));
        return;
    }
    let large = bench("64x64");
    let number = |o: &std::process::Output, key: &str| -> f64 {
        assert!(o.status.success(), "{}", text(&o.stderr));
        let out = text(&o.stdout);
        out.split(&format!("\"{key}\": "))
            .nth(1)
            .and_then(|s| s.split(['}', ',']).next()?.trim().parse().ok())
            .unwrap_or_else(|| panic!("{key} missing from {out}"))
    };
    assert_eq!(number(&small, "tile_edge"), 4.0);
    assert_eq!(number(&large, "tile_edge"), 4.0);
    let first = number(&small, "first_frame_ms");
    assert!(first.is_finite() && first > 0.0, "first frame {first} ms");
    let (few, many) = (
        number(&small, "tile_list_items"),
        number(&large, "tile_list_items"),
    );
    assert!(
        few > 0.0 && many > few,
        "{few} items at 32x32, {many} at 64x64"
    );
}

/// `stats --backend gpu` prints the DESIGN.md JSON with the rays compared with the
/// reference (`--compared`), no evaluation count (`null`), and the CPU's hits on the same rays.
/// Without an adapter it is skipped, unless `SKELETRACE_REQUIRE_GPU=1` (CI) makes that a failure.
#[test]
fn stats_on_the_gpu_compares_the_first_rays_with_the_reference() {
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/scenes/tree.ron");
    let scene = scene.to_str().unwrap_or_default();
    let args = |backend: &'static str| {
        vec![
            "stats",
            scene,
            "--methods",
            "quadratic-taylor",
            "--rays",
            "1200",
            "--compared",
            "500",
            "--json",
            "--backend",
            backend,
        ]
    };
    let gpu = skeletrace(&args("gpu"));
    if !gpu.status.success() && std::env::var("SKELETRACE_REQUIRE_GPU").as_deref() != Ok("1") {
        eprintln!("SKIPPED: no GPU adapter ({})", text(&gpu.stderr));
        return;
    }
    assert!(gpu.status.success(), "{}", text(&gpu.stderr));
    let json = text(&gpu.stdout);
    for field in [
        "\"rays\": 1200",
        "\"compared\": 500",
        "\"avg_evaluations\": null",
        "\"missed\": 0",
        "\"spurious\": 0",
    ] {
        assert!(json.contains(field), "{field} missing from {json}");
    }
    let cpu = text(&skeletrace(&args("cpu")).stdout);
    let hits = |json: &str| {
        json.split("\"hits\": ")
            .nth(1)
            .map(|r| r.split(',').next().unwrap_or("").to_owned())
    };
    assert_eq!(hits(&json), hits(&cpu), "GPU {json}\nCPU {cpu}");
    assert!(cpu.contains("\"compared\": 1200"), "{cpu}");
}

/// `stats` reports the methods in the order they were asked for, not in the table's order.
#[test]
fn stats_reports_methods_in_the_order_asked() {
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets/scenes/blobs.ron");
    let o = skeletrace(&[
        "stats",
        scene.to_str().unwrap_or_default(),
        "--methods",
        "quadratic-taylor,segment",
        "--rays",
        "60",
        "--json",
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let value = parse_json(&text(&o.stdout));
    assert_eq!(names(&value, "methods"), ["quadratic-taylor", "segment"]);
}

/// `bench --sweep`: on the CPU (no pipelines to count: the field is absent), every value is
/// traced and compared with the CPU tracer (the same frames: no difference); a scene without
/// the parameter, or a sweep without `--sweep`'s values, fails in one line naming it.
#[test]
fn bench_sweep_reports_each_value_and_refuses_a_scene_without_the_parameter() {
    let asset = |name: &str| {
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join(format!("../assets/scenes/{name}.ron"))
            .display()
            .to_string()
    };
    let (operators, blobs) = (asset("operators"), asset("blobs"));
    let operators = operators.as_str();
    let out = skeletrace(&[
        "bench",
        operators,
        "--sweep",
        "ricci-exponent",
        "--steps",
        "3",
        "--size",
        "24x16",
        "--methods",
        "segment",
        "--json",
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let report = parse_json(&text(&out.stdout));
    assert_eq!(report["param"], "ricci-exponent");
    assert_eq!(report["targets"], 1);
    assert_eq!(report["frames"], 3);
    assert!(report.get("pipelines_compiled").is_none(), "{report}");
    assert_eq!(report["max_pixel_difference_to_cpu"], 0.0, "{report}");
    assert_eq!(report["min_hit_mask_agreement"], 1.0, "{report}");
    assert_eq!(names(&report, "methods"), ["segment"]);

    let out = skeletrace(&["bench", &blobs, "--sweep", "smooth-width", "--steps", "2"]);
    assert!(!out.status.success());
    let stderr = text(&out.stderr);
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(
        stderr.contains("--sweep smooth-width")
            && stderr.contains("no smooth union or intersection"),
        "{stderr}"
    );
    let out = skeletrace(&["bench", operators, "--steps", "4"]);
    assert!(!out.status.success(), "--steps needs --sweep");
}

/// An SWC file drawn from a seed: a soma, dendrites and an axon growing from it with random
/// branching and radii, and a second tree of dendrite samples with no soma (a root of its own),
/// ids shuffled by gaps; `import` makes one group per type and one skeleton per tree, every
/// sample a vertex with the file's radius (a branch leaving the soma starts from a copy of it),
/// every parent link a segment.
#[test]
fn import_reads_a_generated_swc_file_into_groups_skeletons_and_radii() {
    use skeletrace_core::model::rng::SplitMix64;
    for seed in [3_u64, 17, 40] {
        let mut rng = SplitMix64::new(seed);
        // (id, type, position, radius, parent)
        let mut samples: Vec<(i64, i64, [f64; 3], f64, i64)> = Vec::new();
        samples.push((1, 1, [0.0; 3], 1.0, -1));
        let mut next_id = 2_i64;
        let mut add = |kind, parent: i64, from: [f64; 3], rng: &mut SplitMix64| {
            let id = next_id;
            next_id += 1 + rng.below(3) as i64;
            let d = rng.direction();
            let position = [from[0] + d[0], from[1] + d[1], from[2] + d[2]];
            (id, kind, position, rng.range(0.05, 0.4), parent)
        };
        for (kind, branches) in [(3_i64, 2 + rng.below(3)), (2, 1)] {
            for _ in 0..branches {
                let (mut parent, mut at) = (1_i64, [0.0; 3]);
                for _ in 0..2 + rng.below(6) {
                    let s = add(kind, parent, at, &mut rng);
                    samples.push(s);
                    // Sometimes branch from an earlier sample of this branch.
                    if rng.unit() < 0.7 {
                        (parent, at) = (s.0, s.2);
                    }
                }
            }
        }
        let mut parent = -1;
        let mut at = [5.0, 0.0, 0.0];
        for _ in 0..4 {
            let s = add(3, parent, at, &mut rng);
            samples.push(s);
            (parent, at) = (s.0, s.2);
        }
        let mut file_text = format!("# generated from seed {seed}\n");
        for (id, kind, p, r, parent) in &samples {
            file_text += &format!("{id} {kind} {} {} {} {r} {parent}\n", p[0], p[1], p[2]);
        }
        let dir = temp_dir(&format!("swc-{seed}"));
        let (swc, ron) = (dir.join("cell.swc"), dir.join("cell.ron"));
        std::fs::write(&swc, &file_text).unwrap_or_else(|e| panic!("{e}"));
        let out = skeletrace(&[
            "import",
            &swc.display().to_string(),
            "-o",
            &ron.display().to_string(),
        ]);
        assert!(out.status.success(), "{}", text(&out.stderr));
        let scene = skeletrace_core::Scene::load(&ron).unwrap_or_else(|e| panic!("{e}"));
        let names: Vec<&str> = scene.groups.iter().map(|g| g.name.as_str()).collect();
        assert_eq!(names, ["soma", "axon", "basal dendrite"], "seed {seed}");
        let c = scene.counts();
        let links = samples.iter().filter(|s| s.4 != -1).count();
        assert_eq!(c.segments, links, "seed {seed}: a segment per parent link");
        // Branches leaving the soma start from a copy of it: one per branch root.
        let from_soma = samples.iter().filter(|s| s.4 == 1).count();
        assert_eq!(c.vertices, samples.len() + from_soma, "seed {seed}");
        // Skeletons: the soma, one per branch from it, the separate tree.
        assert_eq!(c.skeletons, 1 + from_soma + 1, "seed {seed}");
        for (_, _, p, r, _) in &samples {
            let found = scene
                .groups
                .iter()
                .flat_map(|g| &g.skeletons)
                .flat_map(|s| &s.vertices)
                .any(|v| v.position == *p && v.radius == *r);
            assert!(found, "seed {seed}: the sample at {p:?} keeps radius {r}");
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
}

/// A bad SWC line is one error naming the file, the line and the value; nothing is written.
#[test]
fn import_of_a_bad_swc_line_names_it_and_writes_nothing() {
    let dir = temp_dir("swc-bad");
    let (swc, ron) = (dir.join("bad.swc"), dir.join("bad.ron"));
    std::fs::write(&swc, "# soma\n1 1 0 0 0 1 -1\n2 3 1 0 zero 0.5 1\n")
        .unwrap_or_else(|e| panic!("{e}"));
    let out = skeletrace(&[
        "import",
        &swc.display().to_string(),
        "-o",
        &ron.display().to_string(),
    ]);
    assert!(!out.status.success());
    let stderr = text(&out.stderr);
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(
        stderr.contains("bad.swc:3") && stderr.contains("'zero'"),
        "{stderr}"
    );
    assert!(!ron.exists(), "nothing written");
    let _ = std::fs::remove_dir_all(&dir);
}
