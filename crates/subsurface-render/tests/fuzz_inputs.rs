//! Fuzzing of the other inputs a user hands us: scene files (TOML parsing and validation,
//! then loading when the scene names no external file) and images (PNG, JPEG, EXR through
//! `scene::load_image`). Deterministic mutants of real seeds; no mutant may panic or take
//! longer than [`TIME_LIMIT`], and a rejected one must give one line naming the file.
//!
//! In `cargo test` a fixed replay runs; `SUBSURFACE_FUZZ_SECONDS=N` (tools/fuzz.sh) runs
//! fresh mutants for N seconds per target and reports the executions.

use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use subsurface_render::Scene;
use subsurface_render::scene::{MeshDesc, SceneDesc, load_image};

const TIME_LIMIT: Duration = Duration::from_secs(5);

struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

/// The fixed replay's count, or a time budget and a fresh seed from the environment.
fn plan(replay: usize) -> (usize, Option<Duration>, u64) {
    match std::env::var("SUBSURFACE_FUZZ_SECONDS")
        .ok()
        .and_then(|s| s.parse::<f64>().ok())
    {
        Some(secs) => {
            let seed = std::env::var("SUBSURFACE_FUZZ_SEED")
                .ok()
                .and_then(|s| s.parse().ok())
                .unwrap_or_else(|| {
                    std::time::SystemTime::now()
                        .duration_since(std::time::UNIX_EPOCH)
                        .map_or(7, |d| d.as_nanos() as u64)
                });
            (usize::MAX, Some(Duration::from_secs_f64(secs)), seed | 1)
        }
        None => (replay, None, 0x51ed_270b_9a3c_44e1),
    }
}

fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
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
    for dir in ["scenes", "scenes/canonical"] {
        let mut files: Vec<_> = std::fs::read_dir(root.join(dir))
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|e| e == "toml"))
            .collect();
        files.sort();
        for p in files {
            let name = p.file_name().unwrap().to_string_lossy().into_owned();
            seeds.push((name, std::fs::read_to_string(&p).unwrap()));
        }
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

#[test]
fn scene_files_never_panic_and_errors_are_one_line() {
    let (count, budget, seed) = plan(3000);
    let seeds = scene_seeds();
    let mut rng = Rng(seed);
    let start = Instant::now();
    let (mut ok, mut rejected, mut loaded) = (0usize, 0usize, 0usize);
    let mut failures = Vec::new();
    for i in 0..count {
        if budget.is_some_and(|b| start.elapsed() > b) {
            break;
        }
        let (seed_name, seed_text) = &seeds[i % seeds.len()];
        let text = mutate_text(&mut rng, seed_text);
        let name = format!("{seed_name}#{i}");
        let t0 = Instant::now();
        let r = catch_unwind(AssertUnwindSafe(|| {
            let desc = SceneDesc::from_toml_str(&text, &name)?;
            if self_contained(&desc) {
                Scene::from_desc(desc, Path::new("."), &name).map(|_| true)
            } else {
                Ok(false)
            }
        }));
        let problem = match r {
            Err(_) => Some("panicked".to_string()),
            Ok(_) if t0.elapsed() > TIME_LIMIT => Some(format!("took {:?}", t0.elapsed())),
            Ok(Err(e)) => {
                rejected += 1;
                let e = e.to_string();
                (!one_line_naming(&e, &name)).then(|| format!("bad message {e:?}"))
            }
            Ok(Ok(l)) => {
                ok += 1;
                loaded += l as usize;
                None
            }
        };
        if let Some(p) = problem {
            let file = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("scene_fuzz_{i}.toml"));
            let _ = std::fs::write(&file, &text);
            failures.push(format!("{name}: {p} (saved to {})", file.display()));
        }
    }
    eprintln!(
        "scene files: {} executions ({ok} valid, {loaded} loaded, {rejected} rejected) in {:?}",
        ok + rejected,
        start.elapsed()
    );
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    assert!(ok > 50 && rejected > 500, "{ok} valid, {rejected} rejected");
}

fn image_seeds() -> Vec<(&'static str, Vec<u8>)> {
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
    vec![
        ("seed.png", encode(image::ImageFormat::Png)),
        ("seed.jpg", encode(image::ImageFormat::Jpeg)),
        ("seed.exr", encode(image::ImageFormat::OpenExr)),
    ]
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
    let (count, budget, seed) = plan(1500);
    let seeds = image_seeds();
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("image_fuzz");
    std::fs::create_dir_all(&dir).unwrap();
    for (name, bytes) in &seeds {
        let p = dir.join(name);
        std::fs::write(&p, bytes).unwrap();
        load_image(&p).unwrap_or_else(|e| panic!("seed {name}: {e}"));
    }
    let mut rng = Rng(seed);
    let start = Instant::now();
    let (mut ok, mut rejected) = (0usize, 0usize);
    let mut failures = Vec::new();
    for i in 0..count {
        if budget.is_some_and(|b| start.elapsed() > b) {
            break;
        }
        let (seed_name, seed_bytes) = &seeds[i % seeds.len()];
        let bytes = mutate_bytes(&mut rng, seed_bytes);
        let path = dir.join(format!("m{}_{seed_name}", i % 64));
        std::fs::write(&path, &bytes).unwrap();
        let t0 = Instant::now();
        let r = catch_unwind(|| load_image(&path));
        let file = path.display().to_string();
        let problem = match r {
            Err(_) => Some("panicked".to_string()),
            Ok(_) if t0.elapsed() > TIME_LIMIT => Some(format!("took {:?}", t0.elapsed())),
            Ok(Err(e)) => {
                rejected += 1;
                let e = e.to_string();
                (!one_line_naming(&e, &file)).then(|| format!("bad message {e:?}"))
            }
            Ok(Ok(_)) => {
                ok += 1;
                None
            }
        };
        if let Some(p) = problem {
            let keep = dir.join(format!("failure_{i}_{seed_name}"));
            let _ = std::fs::write(&keep, &bytes);
            failures.push(format!(
                "{seed_name}#{i}: {p} (saved to {})",
                keep.display()
            ));
        }
    }
    eprintln!(
        "images: {} executions ({ok} decoded, {rejected} rejected) in {:?}",
        ok + rejected,
        start.elapsed()
    );
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    assert!(
        ok > 20 && rejected > 100,
        "{ok} decoded, {rejected} rejected"
    );
}
