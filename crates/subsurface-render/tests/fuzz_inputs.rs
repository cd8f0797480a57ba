//! Fuzzing of the other inputs a user hands us: scene files (TOML parsing and validation,
//! then loading when the scene names no external file) and images (PNG, JPEG, EXR through
//! `scene::load_image`). Deterministic mutants of real seeds; no mutant may panic or take
//! longer than [`TIME_LIMIT`], and a rejected one must give one line naming the file.
//!
//! In `cargo test` a fixed replay runs; `SUBSURFACE_FUZZ_SECONDS=N` (tools/fuzz.sh) runs
//! fresh mutants for N seconds per target and reports the executions.

use crate::common;

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use common::{Rng, fuzz_budget, named_in_order, repo_root};
use subsurface_render::Scene;
use subsurface_render::scene::{MeshDesc, SceneDesc, load_image};

const TIME_LIMIT: Duration = Duration::from_secs(5);

/// The fixed replay's count, or a time budget and a fresh seed from the environment.
fn plan(replay: usize) -> (usize, Option<Duration>, u64) {
    match fuzz_budget() {
        Some((budget, seed)) => (usize::MAX, Some(budget), seed),
        None => (replay, None, 0x51ed_270b_9a3c_44e1),
    }
}

/// Values on the validator's edges: zero, negatives, overflow, denormals, non-numbers, limits.
const EXTREMES: &[&str] = &[
    "0",
    "-1",
    "1",
    "3",
    "0.0",
    "-0.0",
    "1e38",
    "-1e38",
    "3.5e38",
    "1e-30",
    "1e-45",
    "nan",
    "inf",
    "-inf",
    "16385",
    "16384",
    "8193",
    "65",
    "4294967296",
    "-4294967296",
    "99999999999999999999",
    "1e308",
    "1e39",
    "1e-40",
    "1e300",
    "3e38",
    "0, 0, nan",
    "\"x\"",
    "[]",
    "{}",
    "true",
];

fn mutate_text(rng: &mut Rng, seed: &str) -> String {
    let mut lines: Vec<String> = seed.lines().map(str::to_string).collect();
    for _ in 0..1 + rng.below(3) {
        if lines.is_empty() {
            break;
        }
        let i = rng.below(lines.len());
        match rng.below(7) {
            // A number (or a whole value) replaced by an extreme.
            0..=2 => {
                let line = &lines[i];
                let spans: Vec<(usize, usize)> = line
                    .char_indices()
                    .filter(|(_, c)| c.is_ascii_digit())
                    .map(|(p, _)| {
                        let end = line[p..]
                            .find(|c: char| !(c.is_ascii_alphanumeric() || c == '.' || c == '-'))
                            .map_or(line.len(), |e| p + e);
                        (p, end)
                    })
                    .collect();
                if let Some(&(a, b)) = spans.get(rng.below(spans.len())) {
                    let v = EXTREMES[rng.below(EXTREMES.len())];
                    lines[i] = format!("{}{}{}", &line[..a], v, &line[b..]);
                }
            }
            3 => {
                lines.remove(i);
            }
            4 => {
                let l = lines[i].clone();
                lines.insert(i, l);
            }
            5 => {
                let j = rng.below(lines.len());
                lines.swap(i, j);
            }
            _ => {
                let mut bytes = lines[i].clone().into_bytes();
                if !bytes.is_empty() {
                    let k = rng.below(bytes.len());
                    bytes[k] = b"=[]{}\",.#\n\\x0\x00\xff"[rng.below(15)];
                }
                lines[i] = String::from_utf8_lossy(&bytes).into_owned();
            }
        }
    }
    lines.join("\n")
}

fn scene_seeds() -> Vec<(String, String)> {
    let root = repo_root();
    let mut seeds = vec![(
        "default.toml".to_string(),
        subsurface_render::scene::DEFAULT_SCENE_TOML.to_string(),
    )];
    // The repository's scenes, and the crafted inputs of issue 41 (extra array elements,
    // eta = 4, extreme media, +-3e38 geometry, nine lights) in fuzz-corpus/scenes.
    let corpus = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz-corpus/scenes");
    for dir in [
        root.join("scenes"),
        root.join("scenes/canonical"),
        root.join("scenes/experiments"),
        corpus,
    ] {
        let files: Vec<_> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|e| e == "toml"))
            .collect();
        seeds.extend(named_in_order(files, |p| std::fs::read_to_string(p)));
    }
    seeds
}

/// A scene that names no file outside the binary: safe and fast to load in a loop.
fn self_contained(d: &SceneDesc) -> bool {
    d.objects.iter().all(|o| {
        let m = &o.material;
        !matches!(&o.mesh, MeshDesc::Gltf { path } if path != "builtin:hand")
            && m.albedo_texture.is_none()
            && m.normal_texture.is_none()
            && m.specular_texture.is_none()
    })
}

fn one_line_naming(e: &str, file: &str) -> bool {
    e.starts_with(file) && !e.contains('\n')
}

/// What a run of mutants did.
struct Outcome<T> {
    /// What each accepted mutant gave.
    accepted: Vec<T>,
    rejected: usize,
    failures: Vec<String>,
    elapsed: Duration,
}

/// Feeds `plan`'s count of mutants (fewer when its budget runs out) to `run`: mutant `i`,
/// "{seed name}#{i}" in reports, is `mutate` of seed `i` (in turn) with an [`Rng`] started
/// at `plan`'s seed; `file(i, seed name, mutant)` puts it where `run(file, mutant)` reads it
/// and gives the name its errors must start with. A panic, a run longer than [`TIME_LIMIT`]
/// or an error that is not one line naming the file is a failure; its mutant is saved to
/// `keep(i, seed name)`.
fn run_mutants<S, D: AsRef<[u8]>, T, E: std::fmt::Display>(
    (count, budget, seed): (usize, Option<Duration>, u64),
    seeds: &[(String, S)],
    mutate: impl Fn(&mut Rng, &S) -> D,
    file: impl Fn(usize, &str, &D) -> String,
    run: impl Fn(&str, &D) -> Result<T, E>,
    keep: impl Fn(usize, &str) -> PathBuf,
) -> Outcome<T> {
    let mut rng = Rng(seed);
    let start = Instant::now();
    let (mut accepted, mut rejected, mut failures) = (Vec::new(), 0, Vec::new());
    for i in 0..count {
        if budget.is_some_and(|b| start.elapsed() > b) {
            break;
        }
        let (seed_name, seed_content) = &seeds[i % seeds.len()];
        let mutant = mutate(&mut rng, seed_content);
        let file = file(i, seed_name, &mutant);
        let t0 = Instant::now();
        let r = catch_unwind(AssertUnwindSafe(|| run(&file, &mutant)));
        let problem = match r {
            Err(_) => Some("panicked".to_string()),
            Ok(_) if t0.elapsed() > TIME_LIMIT => Some(format!("took {:?}", t0.elapsed())),
            Ok(Err(e)) => {
                rejected += 1;
                let e = e.to_string();
                (!one_line_naming(&e, &file)).then(|| format!("bad message {e:?}"))
            }
            Ok(Ok(v)) => {
                accepted.push(v);
                None
            }
        };
        if let Some(p) = problem {
            let saved = keep(i, seed_name);
            let _ = std::fs::write(&saved, mutant.as_ref());
            failures.push(format!(
                "{seed_name}#{i}: {p} (saved to {})",
                saved.display()
            ));
        }
    }
    Outcome {
        accepted,
        rejected,
        failures,
        elapsed: start.elapsed(),
    }
}

#[test]
fn scene_files_never_panic_and_errors_are_one_line() {
    let out = run_mutants(
        plan(3000),
        &scene_seeds(),
        |rng, text| mutate_text(rng, text),
        |i, seed_name, _| format!("{seed_name}#{i}"),
        |name, text| {
            let desc = SceneDesc::from_toml_str(text, name)?;
            if self_contained(&desc) {
                Scene::from_desc(desc, Path::new("."), name).map(|_| true)
            } else {
                Ok(false)
            }
        },
        |i, _| Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("scene_fuzz_{i}.toml")),
    );
    let (ok, rejected) = (out.accepted.len(), out.rejected);
    let loaded = out.accepted.iter().filter(|&&l| l).count();
    eprintln!(
        "scene files: {} executions ({ok} valid, {loaded} loaded, {rejected} rejected) in {:?}",
        ok + rejected,
        out.elapsed
    );
    assert!(out.failures.is_empty(), "{}", out.failures.join("\n"));
    assert!(ok > 50 && rejected > 500, "{ok} valid, {rejected} rejected");
}

fn image_seeds() -> Vec<(String, Vec<u8>)> {
    let img = image::RgbaImage::from_fn(16, 12, |x, y| {
        image::Rgba([(x * 16) as u8, (y * 20) as u8, ((x + y) * 7) as u8, 255])
    });
    let encode = |format| {
        let mut bytes = Vec::new();
        let rgb = image::DynamicImage::ImageRgba8(img.clone()).to_rgb8();
        let dynamic = if format == image::ImageFormat::Jpeg {
            image::DynamicImage::ImageRgb8(rgb)
        } else if format == image::ImageFormat::OpenExr {
            image::DynamicImage::ImageRgba32F(
                image::DynamicImage::ImageRgba8(img.clone()).to_rgba32f(),
            )
        } else {
            image::DynamicImage::ImageRgba8(img.clone())
        };
        dynamic
            .write_to(&mut std::io::Cursor::new(&mut bytes), format)
            .unwrap();
        bytes
    };
    [
        ("seed.png", image::ImageFormat::Png),
        ("seed.jpg", image::ImageFormat::Jpeg),
        ("seed.exr", image::ImageFormat::OpenExr),
    ]
    .map(|(name, format)| (name.to_string(), encode(format)))
    .into()
}

fn mutate_bytes(rng: &mut Rng, seed: &[u8]) -> Vec<u8> {
    let mut b = seed.to_vec();
    for _ in 0..1 + rng.below(4) {
        if b.is_empty() {
            break;
        }
        // Headers hold the sizes and counts that matter: aim half the edits at them.
        let hot = if rng.below(2) == 0 {
            64.min(b.len())
        } else {
            b.len()
        };
        let i = rng.below(hot);
        match rng.below(5) {
            0 => b[i] ^= 1 << rng.below(8),
            1 => b[i] = [0u8, 0xff, 0x7f, 0x80, 1][rng.below(5)],
            2 => b.truncate(i.max(1)),
            3 => {
                let end = (i + 4).min(b.len());
                b[i..end].fill(0xff);
            }
            _ => {
                let j = rng.below(b.len());
                b.insert(i, b[j]);
            }
        }
    }
    b
}

#[test]
fn images_never_panic_and_errors_are_one_line() {
    let seeds = image_seeds();
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("image_fuzz");
    std::fs::create_dir_all(&dir).unwrap();
    for (name, bytes) in &seeds {
        let p = dir.join(name);
        std::fs::write(&p, bytes).unwrap();
        load_image(&p).unwrap_or_else(|e| panic!("seed {name}: {e}"));
    }
    let out = run_mutants(
        plan(1500),
        &seeds,
        |rng, bytes| mutate_bytes(rng, bytes),
        |i, seed_name, bytes| {
            let path = dir.join(format!("m{}_{seed_name}", i % 64));
            std::fs::write(&path, bytes).unwrap();
            path.display().to_string()
        },
        |path, _| load_image(Path::new(path)).map(|_| ()),
        |i, seed_name| dir.join(format!("failure_{i}_{seed_name}")),
    );
    let (ok, rejected) = (out.accepted.len(), out.rejected);
    eprintln!(
        "images: {} executions ({ok} decoded, {rejected} rejected) in {:?}",
        ok + rejected,
        out.elapsed
    );
    assert!(out.failures.is_empty(), "{}", out.failures.join("\n"));
    assert!(
        ok > 20 && rejected > 100,
        "{ok} decoded, {rejected} rejected"
    );
}
