//! Shared helpers of the GPU tests.
#![allow(dead_code)]

use std::path::{Path, PathBuf};

use subsurface_render::scene::SceneDesc;
use subsurface_render::{GpuContext, Scene, gpu_required};

/// The GPU context, or None (test skipped with a message) when no adapter exists and
/// `SUBSURFACE_REQUIRE_GPU` is not 1. With it set, a missing adapter fails the test.
pub fn context() -> Option<GpuContext> {
    match GpuContext::new_headless() {
        Ok(c) => {
            eprintln!("adapter: {}", c.adapter_name());
            Some(c)
        }
        Err(e) if gpu_required() => panic!("SUBSURFACE_REQUIRE_GPU=1 but {e}"),
        Err(e) => {
            eprintln!("skipping GPU test: {e}");
            None
        }
    }
}

pub fn scene(toml: &str) -> Scene {
    let desc = SceneDesc::from_toml_str(toml, "test.toml").unwrap();
    Scene::from_desc(desc, Path::new("."), "test.toml").unwrap()
}

/// `../shared/assets` (or `SUBSURFACE_ASSETS`), or None when the head model is absent and the
/// run does not require it. CI sets SUBSURFACE_ASSETS and SUBSURFACE_REQUIRE_GPU=1.
pub fn assets_dir() -> Option<PathBuf> {
    let dir = std::env::var_os("SUBSURFACE_ASSETS")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/assets"));
    if dir.join("LeePerrySmith/LeePerrySmith.glb").is_file() {
        Some(dir)
    } else if gpu_required() {
        panic!(
            "{}: the Lee Perry-Smith head is missing (set SUBSURFACE_ASSETS)",
            dir.display()
        );
    } else {
        eprintln!("skipping: no head model at {}", dir.display());
        None
    }
}

pub fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// Where failing image tests write their actual and difference images.
pub fn output_dir() -> PathBuf {
    let d = repo_root().join("target/test-output");
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// FLIP between a reference PNG and an image. Returns (mean, 95th percentile). With
/// `SUBSURFACE_BLESS=1` a missing or differing reference is (re)written instead.
pub fn flip_against_reference(name: &str, actual: &image::RgbaImage, mean_max: f32, p95_max: f32) {
    let reference_path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/reference")
        .join(format!("{name}.png"));
    let bless = std::env::var("SUBSURFACE_BLESS").is_ok_and(|v| v == "1");
    if bless {
        actual.save(&reference_path).unwrap();
        eprintln!("blessed {}", reference_path.display());
        return;
    }
    let reference = image::open(&reference_path)
        .unwrap_or_else(|e| {
            panic!(
                "{}: {e} (run with SUBSURFACE_BLESS=1 to create it)",
                reference_path.display()
            )
        })
        .to_rgba8();
    assert_eq!(
        reference.dimensions(),
        actual.dimensions(),
        "{name}: size differs from the reference"
    );
    let (mean, p95, err) = flip(&reference, actual);
    eprintln!("{name}: FLIP mean {mean:.4}, p95 {p95:.4}");
    if mean > mean_max || p95 > p95_max {
        let out = output_dir();
        actual.save(out.join(format!("{name}.actual.png"))).unwrap();
        err.save(out.join(format!("{name}.diff.png"))).unwrap();
        panic!(
            "{name}: FLIP mean {mean:.4} (max {mean_max}), p95 {p95:.4} (max {p95_max}); actual and difference images in {}",
            out.display()
        );
    }
}

/// FLIP (NVIDIA's perceptual image difference) of two sRGB images: (mean, p95, heat map).
pub fn flip(reference: &image::RgbaImage, test: &image::RgbaImage) -> (f32, f32, image::RgbImage) {
    let (w, h) = reference.dimensions();
    let rgb = |i: &image::RgbaImage| {
        image::DynamicImage::ImageRgba8(i.clone())
            .to_rgb8()
            .into_raw()
    };
    let r = nv_flip::FlipImageRgb8::with_data(w, h, &rgb(reference));
    let t = nv_flip::FlipImageRgb8::with_data(w, h, &rgb(test));
    let err = nv_flip::flip(r, t, nv_flip::DEFAULT_PIXELS_PER_DEGREE);
    let mut pool = nv_flip::FlipPool::from_image(&err);
    let heat = err.apply_color_lut(&nv_flip::magma_lut());
    let heat = image::RgbImage::from_raw(w, h, heat.to_vec()).unwrap();
    (pool.mean(), pool.get_percentile(0.95, true), heat)
}

/// Mean of `values` over the pixels where `keep` is true.
pub fn masked_mean(values: &[f32], keep: impl Fn(usize) -> bool) -> f32 {
    let (mut s, mut n) = (0.0f64, 0usize);
    for (i, v) in values.iter().enumerate() {
        if keep(i) {
            s += *v as f64;
            n += 1;
        }
    }
    assert!(n > 0, "no pixels selected");
    (s / n as f64) as f32
}

/// Per-pixel FLIP error of two sRGB images.
pub fn flip_errors(reference: &image::RgbaImage, test: &image::RgbaImage) -> Vec<f32> {
    let (w, h) = reference.dimensions();
    let rgb = |i: &image::RgbaImage| {
        image::DynamicImage::ImageRgba8(i.clone())
            .to_rgb8()
            .into_raw()
    };
    let r = nv_flip::FlipImageRgb8::with_data(w, h, &rgb(reference));
    let t = nv_flip::FlipImageRgb8::with_data(w, h, &rgb(test));
    nv_flip::flip(r, t, nv_flip::DEFAULT_PIXELS_PER_DEGREE).to_vec()
}

/// The value below which `q` (0..1) of `values` lie.
pub fn percentile(values: &[f32], q: f32) -> f32 {
    let mut v = values.to_vec();
    v.sort_by(f32::total_cmp);
    v[((v.len() - 1) as f32 * q) as usize]
}
