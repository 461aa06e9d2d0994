//! The marches do not change when the tracer gets faster: every method traces a fixed
//! set of rays on every asset and on generated scenes, and each (scene, method) pair's outcome —
//! steps, evaluations and every crossing's exact bits, opaque and transparent — is folded into a
//! fingerprint held in `core/tests/golden/marches.txt`. An optimisation that changes one step
//! count or one bit of one depth fails here, naming the scene and method and the totals before
//! and after.
//!
//! After a deliberate change of the marches, regenerate the file with
//! `SKELETRACE_BLESS=1 cargo test -p skeletrace-core --test march_fingerprints` and say why in
//! the commit.
//!
//! The fingerprints are exact, so they hold for one system math library (`exp`, `ln` and `powf`
//! come from it; glibc picks its routines by CPU). The golden file's first line fingerprints
//! those functions on fixed arguments: where this machine's differ, the marches cannot be
//! compared bit for bit, and the test says so and holds them to hits, steps within 0.1 % and
//! depth sums within 10⁻⁹ instead.

mod common;

use std::collections::BTreeMap;
use std::fmt::Write as _;

use common::assets;
use rayon::prelude::*;
use skeletrace_core::frame::{PinholeCamera, far_distance};
use skeletrace_core::methods::{self, Method, TraceMode, TraceSettings};
use skeletrace_core::model::generate::{GenerateOptions, GeneratorKind, generate};
use skeletrace_core::model::rng::SplitMix64;
use skeletrace_core::model::scene::Scene;
use skeletrace_core::{FieldProgram, Interval, Ray};

/// Camera rays per side of the grid, and rays aimed at random primitives.
const GRID: usize = 16;
const AIMED: usize = 64;

/// A scene's name, compiled program and fixed rays.
type Job = (String, FieldProgram, Vec<(Ray, Interval)>);

/// One (scene, method) pair's outcome over the fixed rays.
#[derive(Debug)]
struct Fingerprint {
    rays: usize,
    steps: u64,
    hits: usize,
    /// Sum of the first crossings' parameters: where a change moves depths, by how much.
    depths: f64,
    /// FNV-1a over every ray's steps, evaluations and crossings (bits of `t`, direction).
    hash: u64,
}

impl Fingerprint {
    fn line(&self, key: &str) -> String {
        format!(
            "{key} rays={} steps={} hits={} depths={:.17e} hash={:016x}",
            self.rays, self.steps, self.hits, self.depths, self.hash
        )
    }
}

fn fnv(hash: &mut u64, word: u64) {
    for byte in word.to_le_bytes() {
        *hash ^= u64::from(byte);
        *hash = hash.wrapping_mul(0x0100_0000_01b3);
    }
}

/// The scenes: every asset, and generated scenes of each generator from fixed seeds.
fn scenes() -> Vec<(String, Scene)> {
    let mut out: Vec<(String, Scene)> = assets()
        .into_iter()
        .map(|path| {
            let name = path
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default();
            let scene = Scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
            (name, scene)
        })
        .collect();
    let generated = [
        (GeneratorKind::Blobs, "blobs", 7, 300),
        (GeneratorKind::Tree, "tree", 11, 4),
        (GeneratorKind::RandomSkeleton, "random-skeleton", 5, 60),
        (GeneratorKind::Truss, "truss", 3, 2),
        (GeneratorKind::Foam, "foam", 9, 6),
        (GeneratorKind::Molecule, "molecule", 13, 200),
    ];
    for (kind, name, seed, size) in generated {
        let options = GenerateOptions {
            seed,
            size: Some(size),
            ..GenerateOptions::default()
        };
        let scene = generate(kind, &options).unwrap_or_else(|e| panic!("generate {name}: {e}"));
        out.push((format!("generated-{name}-{seed}-{size}"), scene));
    }
    out
}

/// The fixed rays of a scene: a grid of its camera's rays, then rays through random primitives.
fn rays(scene: &Scene, program: &FieldProgram) -> Vec<(Ray, Interval)> {
    let camera = PinholeCamera::new(&scene.camera);
    let far = far_distance(program, &scene.camera);
    let mut out: Vec<(Ray, Interval)> = (0..GRID * GRID)
        .map(|i| {
            let ray = camera.ray(i % GRID, i / GRID, GRID, GRID);
            (ray, Interval::new(0.0, far))
        })
        .collect();
    let mut rng = SplitMix64::new(0x5eed);
    out.extend((0..AIMED).map(|_| common::aimed_ray(program, &mut rng)));
    out
}

fn fingerprint(
    program: &FieldProgram,
    method: &dyn Method,
    rays: &[(Ray, Interval)],
) -> Fingerprint {
    let tracer = method.prepare(program, TraceSettings::for_program(program));
    let mut print = Fingerprint {
        rays: rays.len(),
        steps: 0,
        hits: 0,
        depths: 0.0,
        hash: 0xcbf2_9ce4_8422_2325,
    };
    for (k, (ray, span)) in rays.iter().enumerate() {
        // Every fourth ray is traced through every crossing.
        let mode = if k % 4 == 3 {
            TraceMode::Transparent
        } else {
            TraceMode::Opaque
        };
        let trace = tracer.trace(ray, *span, mode);
        print.steps += u64::from(trace.steps);
        print.hits += usize::from(!trace.crossings.is_empty());
        print.depths += trace.first().map_or(0.0, |c| c.t);
        fnv(&mut print.hash, u64::from(trace.steps));
        fnv(&mut print.hash, u64::from(trace.evaluations));
        for crossing in &trace.crossings {
            fnv(&mut print.hash, crossing.t.to_bits());
            fnv(&mut print.hash, u64::from(crossing.entering));
        }
    }
    print
}

/// The system math library's answers on fixed arguments of the functions the field uses.
fn libm_fingerprint() -> String {
    let mut hash = 0xcbf2_9ce4_8422_2325_u64;
    for k in 0..2000 {
        let x = f64::from(k) * 0.017_320_508_075_688_77;
        fnv(&mut hash, (-x).exp().to_bits());
        fnv(&mut hash, (x * 0.5 - 8.0).exp().to_bits());
        fnv(&mut hash, (1e-6 + x).ln().to_bits());
        fnv(&mut hash, (0.01 + x).powf(-1.5 + x * 0.01).to_bits());
    }
    format!("libm {hash:016x}")
}

/// The fields of a fingerprint line after its key.
fn fields(line: &str) -> BTreeMap<&str, &str> {
    line.split(' ').filter_map(|w| w.split_once('=')).collect()
}

/// Whether two lines agree on hits, on steps within 0.1 % and on depth sums within 10⁻⁹.
fn close(was: &str, now: &str) -> bool {
    let (a, b) = (fields(was), fields(now));
    let number = |m: &BTreeMap<&str, &str>, k: &str| -> f64 {
        m.get(k).and_then(|v| v.parse().ok()).unwrap_or(f64::NAN)
    };
    let near = |k: &str, tolerance: f64| {
        let (x, y) = (number(&a, k), number(&b, k));
        (x - y).abs() <= tolerance * x.abs().max(y.abs()).max(1.0)
    };
    a.get("hits") == b.get("hits") && near("steps", 1e-3) && near("depths", 1e-9)
}

fn golden_path() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/golden/marches.txt")
}

#[test]
fn every_march_is_unchanged_on_the_fixed_rays() {
    let scenes = scenes();
    let jobs: Vec<Job> = scenes
        .iter()
        .map(|(name, scene)| {
            let program = FieldProgram::new(scene);
            let rays = rays(scene, &program);
            (name.clone(), program, rays)
        })
        .collect();
    let all = methods::all();
    let pairs: Vec<(usize, &dyn Method)> = jobs
        .iter()
        .enumerate()
        .flat_map(|(j, (_, program, _))| {
            all.iter()
                .filter(|m| m.supports(program).is_ok())
                .map(move |m| (j, m.as_ref()))
        })
        .collect();
    let got: BTreeMap<String, String> = pairs
        .par_iter()
        .map(|&(j, method)| {
            let (name, program, rays) = &jobs[j];
            let key = format!("{name} {}", method.name());
            let line = fingerprint(program, method, rays).line(&key);
            (key, line)
        })
        .collect();
    let libm = libm_fingerprint();
    let mut text = format!("{libm}\n");
    for line in got.values() {
        let _ = writeln!(text, "{line}");
    }
    let path = golden_path();
    if std::env::var_os("SKELETRACE_BLESS").is_some() {
        if let Some(dir) = path.parent() {
            std::fs::create_dir_all(dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
        }
        std::fs::write(&path, &text).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        return;
    }
    let golden = std::fs::read_to_string(&path)
        .unwrap_or_else(|e| panic!("{}: {e} (SKELETRACE_BLESS=1 writes it)", path.display()));
    let exact = golden.lines().next() == Some(libm.as_str());
    if !exact {
        eprintln!(
            "march fingerprints: this machine's math library ({libm}) is not the one the golden \
             file was blessed with ({:?}): marches are held to hits, steps within 0.1 % and \
             depth sums within 1e-9, not bit for bit",
            golden.lines().next()
        );
    }
    let want: BTreeMap<String, String> = golden
        .lines()
        .skip(1)
        .filter_map(|line| {
            let mut words = line.splitn(3, ' ');
            let key = format!("{} {}", words.next()?, words.next()?);
            Some((key, line.to_owned()))
        })
        .collect();
    let mut differences = Vec::new();
    for (key, line) in &got {
        match want.get(key) {
            Some(old) if old == line || (!exact && close(old, line)) => {}
            Some(old) => differences.push(format!("changed:\n  was {old}\n  now {line}")),
            None => differences.push(format!("new (not in the golden file): {line}")),
        }
    }
    for (key, old) in &want {
        if !got.contains_key(key) {
            differences.push(format!("gone: {old}"));
        }
    }
    assert!(
        differences.is_empty(),
        "{} of {} marches differ from {}:\n{}",
        differences.len(),
        got.len(),
        path.display(),
        differences.join("\n")
    );
}
