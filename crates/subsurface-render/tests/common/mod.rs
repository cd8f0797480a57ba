//! Shared helpers of the GPU tests.
#![allow(dead_code)]

use std::path::{Path, PathBuf};

use subsurface_render::passes::util;
use subsurface_render::scene::SceneDesc;
use subsurface_render::{GpuContext, RenderOptions, Scene, gpu_required, readback};

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

/// The `[camera]` table of a test scene: on the +z axis at `z`, looking at the origin with a
/// vertical field of view of `fov_y_deg`, and the `key = value` lines of `more` (near, far).
pub fn camera_toml(z: f32, fov_y_deg: f32, more: &str) -> String {
    format!(
        "[camera]\nposition = [0.0, 0.0, {z:?}]\ntarget = [0.0, 0.0, 0.0]\nfov_y_deg = {fov_y_deg:?}\n{more}\n"
    )
}

/// A `[[lights]]` table: a `kind` light at `position` aimed at the origin with `intensity`,
/// and the `key = value` lines of `more` (angles, shadow map).
pub fn light_toml(kind: &str, position: [f32; 3], intensity: f32, more: &str) -> String {
    format!(
        "[[lights]]\nkind = \"{kind}\"\nposition = {position:?}\ntarget = [0.0, 0.0, 0.0]\nintensity = {intensity:?}\n{more}\n"
    )
}

/// A test scene without ambient light: `camera` ([`camera_toml`]), `light` ([`light_toml`])
/// and the `[[objects]]` tables of `objects`.
pub fn dark_scene(camera: &str, light: &str, objects: &str) -> Scene {
    scene(&format!(
        "{camera}\n[render]\nambient = [0.0, 0.0, 0.0]\n{light}\n{objects}"
    ))
}

/// One white object (`mesh`, 1000 mm per unit, no specular, material `profile`) seen by
/// `camera` ([`camera_toml`]) and lit only by a shadowed directional light of irradiance 1
/// from `light` towards the origin (shadow bias 0.05 mm); no ambient light, and shaded points
/// move 0.1 mm inward for the shadow lookup.
pub fn white_object_scene(
    camera: &str,
    light: [f32; 3],
    shadow_map_size: u32,
    mesh: &str,
    profile: &str,
) -> Scene {
    let light = light_toml(
        "directional",
        light,
        1.0,
        &format!("shadow_map_size = {shadow_map_size}\nshadow_bias = 0.00005"),
    );
    scene(&format!(
        r#"
        {camera}
        [render]
        ambient = [0.0, 0.0, 0.0]
        transmittance = {{ normal_shrink = 0.0001 }}
        {light}
        [[objects]]
        mesh = {mesh}
        mm_per_unit = 1000.0
        [objects.material]
        albedo = [1.0, 1.0, 1.0]
        specular = 0.0
        medium = "{profile}"
        "#
    ))
}

/// The scene's own options at `width` x `height`.
pub fn options(scene: &Scene, width: u32, height: u32) -> RenderOptions {
    let mut o = RenderOptions::from_scene(scene);
    o.settings = high(scene);
    (o.settings.width, o.settings.height) = (width, height);
    o
}

/// The diffuse target (irradiance x albedo, before any blur is applied by the caller's
/// settings) of one frame of `scene` at `width` x `height`, at `Quality::High` with `edit`
/// applied to the settings.
pub fn diffuse_with(
    scene: &Scene,
    width: u32,
    height: u32,
    edit: impl FnOnce(&mut subsurface_render::RenderSettings),
) -> Vec<[f32; 4]> {
    let ctx = context().unwrap();
    let mut opts = options(scene, width, height);
    edit(&mut opts.settings);
    let mut r = subsurface_render::Renderer::new(&ctx, scene, opts).unwrap();
    r.render().unwrap();
    r.read_diffuse().unwrap()
}

/// `scene`'s settings at `Quality::High`: every term of the renderer, each checked here
/// against its oracle (the cheaper presets are held to the path tracer by subsurface-cli's
/// tests/fidelity.rs). The scene file's keys and a test's own edits of the settings are kept.
pub fn high(scene: &Scene) -> subsurface_render::RenderSettings {
    use subsurface_render::settings::{Quality, value_text};
    let desc = &scene.desc;
    let mut as_loaded = desc.clone();
    as_loaded.set_quality(desc.render.quality).unwrap();
    let mut high = desc.clone();
    high.set_quality(Quality::High).unwrap();
    let mut settings = high.render;
    for ((key, now), (_, loaded)) in desc
        .render
        .entries()
        .into_iter()
        .zip(as_loaded.render.entries())
    {
        if key != "quality" && now != loaded {
            settings.set_unchecked(&key, &value_text(&now)).unwrap();
        }
    }
    settings
}

/// A `w` x `h` texture of `format` holding `bytes` (rows packed tightly), which passes can
/// sample and render to and which can be copied and read back.
pub fn upload_texture(
    ctx: &GpuContext,
    w: u32,
    h: u32,
    format: wgpu::TextureFormat,
    bytes: &[u8],
) -> wgpu::Texture {
    upload_texture_with(ctx, w, h, format, bytes, wgpu::TextureUsages::empty())
}

/// As `upload_texture`, with `extra` usages.
pub fn upload_texture_with(
    ctx: &GpuContext,
    w: u32,
    h: u32,
    format: wgpu::TextureFormat,
    bytes: &[u8],
    extra: wgpu::TextureUsages,
) -> wgpu::Texture {
    let t = util::render_target_with(&ctx.device, "test input", w, h, format, extra);
    let texel = format.block_copy_size(None).unwrap();
    ctx.queue.write_texture(
        t.as_image_copy(),
        bytes,
        wgpu::TexelCopyBufferLayout {
            offset: 0,
            bytes_per_row: Some(w * texel),
            rows_per_image: None,
        },
        t.size(),
    );
    t
}

/// A four-channel float texture read back, one `[f32; 4]` per texel.
pub fn read4(ctx: &GpuContext, t: &wgpu::Texture) -> Vec<[f32; 4]> {
    let (v, c) = readback::read_float(ctx, t).unwrap();
    assert_eq!(c, 4);
    v.chunks_exact(4)
        .map(|c| [c[0], c[1], c[2], c[3]])
        .collect()
}

/// scenes/head.toml, reading the head from SUBSURFACE_ASSETS.
pub fn head_scene() -> Option<Scene> {
    let assets = assets_dir()?;
    // scenes/head.toml points at ../../shared/assets; tests honour SUBSURFACE_ASSETS instead.
    let path = repo_root().join("scenes/head.toml");
    let text = std::fs::read_to_string(&path)
        .unwrap()
        .replace("../../shared/assets", &assets.to_string_lossy());
    let desc = SceneDesc::from_toml_str(&text, "scenes/head.toml").unwrap();
    Some(Scene::from_desc(desc, &repo_root().join("scenes"), "scenes/head.toml").unwrap())
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

/// xorshift64*: tiny, deterministic, good enough to pick mutations.
pub struct Rng(pub u64);

impl Rng {
    pub fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }
    /// Uniform in `0..n` (0 when `n` is 0).
    pub fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
    pub fn pick<T: Copy>(&mut self, items: &[T]) -> T {
        items[self.below(items.len())]
    }
}

/// `paths` in name order, each as (file name, `read` of the file): fuzzing seeds, whose order
/// fixes what the seeded mutations do.
pub fn named_in_order<T>(
    mut paths: Vec<PathBuf>,
    read: impl Fn(&Path) -> std::io::Result<T>,
) -> Vec<(String, T)> {
    paths.sort();
    paths
        .into_iter()
        .map(|p| {
            let name = p.file_name().unwrap().to_string_lossy().into_owned();
            (name, read(&p).unwrap())
        })
        .collect()
}

/// `SUBSURFACE_FUZZ_SECONDS=N` turns a fixed replay into a fuzzing run: the time budget and a
/// fresh odd seed (`SUBSURFACE_FUZZ_SEED`, else the clock), for tools/fuzz.sh. None without it.
pub fn fuzz_budget() -> Option<(std::time::Duration, u64)> {
    let secs: f64 = std::env::var("SUBSURFACE_FUZZ_SECONDS")
        .ok()?
        .parse()
        .ok()?;
    let seed = std::env::var("SUBSURFACE_FUZZ_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| {
            std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(1, |d| d.as_nanos() as u64)
        });
    Some((std::time::Duration::from_secs_f64(secs), seed | 1))
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
    let err = flip_image(reference, test);
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
    flip_image(reference, test).to_vec()
}

/// The FLIP error image of two sRGB images.
fn flip_image(reference: &image::RgbaImage, test: &image::RgbaImage) -> nv_flip::FlipImageFloat {
    let (w, h) = reference.dimensions();
    let rgb = |i: &image::RgbaImage| {
        image::DynamicImage::ImageRgba8(i.clone())
            .to_rgb8()
            .into_raw()
    };
    let r = nv_flip::FlipImageRgb8::with_data(w, h, &rgb(reference));
    let t = nv_flip::FlipImageRgb8::with_data(w, h, &rgb(test));
    nv_flip::flip(r, t, nv_flip::DEFAULT_PIXELS_PER_DEGREE)
}

/// The value below which `q` (0..1) of `values` lie.
pub fn percentile(values: &[f32], q: f32) -> f32 {
    let mut v = values.to_vec();
    v.sort_by(f32::total_cmp);
    v[((v.len() - 1) as f32 * q) as usize]
}

/// The frame `r` draws after `update(scene, opts)`, and the frame a new renderer draws from the
/// same scene and options.
pub fn update_and_fresh(
    ctx: &GpuContext,
    r: &mut subsurface_render::Renderer,
    scene: &Scene,
    opts: &RenderOptions,
) -> (image::RgbaImage, image::RgbaImage) {
    r.update(scene, opts).unwrap();
    let updated = r.render().unwrap().image;
    let fresh = subsurface_render::Renderer::new(ctx, scene, opts.clone())
        .unwrap()
        .render()
        .unwrap()
        .image;
    (updated, fresh)
}

/// [`update_and_fresh`], asserting that the two images are the same (`what` names the edit);
/// the image.
pub fn update_matches_fresh(
    ctx: &GpuContext,
    r: &mut subsurface_render::Renderer,
    scene: &Scene,
    opts: &RenderOptions,
    what: &str,
) -> image::RgbaImage {
    let (updated, fresh) = update_and_fresh(ctx, r, scene, opts);
    assert!(
        updated == fresh,
        "{what}: update() and a new Renderer differ"
    );
    fresh
}

/// Updates `r` to `scene` and `opts` and asserts that it renders `image` again (`what` names
/// the edit).
pub fn assert_update_gives(
    r: &mut subsurface_render::Renderer,
    scene: &Scene,
    opts: &RenderOptions,
    image: &image::RgbaImage,
    what: &str,
) {
    r.update(scene, opts).unwrap();
    assert!(r.render().unwrap().image == *image, "{what}");
}
