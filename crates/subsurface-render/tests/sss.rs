//! Screen-space SSS on the GPU against the CPU oracles of `subsurface-profile`, and the
//! measured properties users rely on: energy kept, no bleeding, perspective-correct size.
//! The passes are driven through their public API on textures made here, as another wgpu
//! application would.

mod common;

use common::{context, scene};
use subsurface_profile::oracle::{self, ScreenInput};
use subsurface_profile::{KernelParams, ScreenKernels};
use subsurface_render::passes::sss::{SssInputs, SssPass};
use subsurface_render::{
    DebugView, GpuContext, RenderOptions, RenderSettings, Renderer, SssMethod, SssSettings,
    readback,
};

const FOCAL: f32 = 300.0;

fn texture(
    ctx: &GpuContext,
    w: u32,
    h: u32,
    format: wgpu::TextureFormat,
    bytes: &[u8],
) -> wgpu::Texture {
    let t = ctx.device.create_texture(&wgpu::TextureDescriptor {
        label: Some("test input"),
        size: wgpu::Extent3d {
            width: w,
            height: h,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: wgpu::TextureUsages::TEXTURE_BINDING
            | wgpu::TextureUsages::RENDER_ATTACHMENT
            | wgpu::TextureUsages::COPY_SRC
            | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    });
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

/// Rounds colours to f16 as the GPU stores them, so oracle and GPU start from the same input.
fn to_f16_exact(input: &mut ScreenInput) {
    for c in &mut input.color {
        *c = c.map(|v| half::f16::from_f32(v).to_f32());
    }
}

/// The skin kernels for `samples` taps: a one-row profile table.
fn skin(samples: u32) -> Vec<ScreenKernels> {
    vec![
        ScreenKernels::skin(&KernelParams {
            samples,
            ..Default::default()
        })
        .unwrap(),
    ]
}

/// Skin, marble and ketchup (Jensen et al. 2001's measured coefficients, fitted with six
/// Gaussians): the table the renderer builds for a scene with the three side by side.
fn three_materials(samples: u32) -> Vec<ScreenKernels> {
    let mut table = skin(samples);
    for name in ["marble", "ketchup"] {
        let fit = subsurface_profile::material(name).unwrap().fit(6).unwrap();
        let params = KernelParams {
            samples,
            strength: [1.0; 3],
            falloff: [1.0; 3],
        };
        table.push(ScreenKernels::for_profile(&fit.profile, &params).unwrap());
    }
    table
}

fn settings(method: SssMethod) -> SssSettings {
    SssSettings {
        method,
        ..Default::default()
    }
}

/// Runs the SSS pass with a skin-only table.
fn run_gpu(ctx: &GpuContext, input: &ScreenInput, settings: &SssSettings) -> Vec<[f32; 3]> {
    run_gpu_with(ctx, input, settings, &skin(settings.samples))
}

/// Runs the SSS pass on the GPU over `input` with this profile table and returns the
/// blurred colour.
fn run_gpu_with(
    ctx: &GpuContext,
    input: &ScreenInput,
    config: &SssSettings,
    table: &[ScreenKernels],
) -> Vec<[f32; 3]> {
    let (w, h) = (input.width, input.height);
    let colour: Vec<half::f16> = input
        .color
        .iter()
        .flat_map(|c| [c[0], c[1], c[2], 1.0])
        .map(half::f16::from_f32)
        .collect();
    let diffuse = texture(
        ctx,
        w,
        h,
        wgpu::TextureFormat::Rgba16Float,
        bytemuck::cast_slice(&colour),
    );
    let depth = texture(
        ctx,
        w,
        h,
        wgpu::TextureFormat::R32Float,
        bytemuck::cast_slice(&input.depth),
    );
    let sss_data: Vec<f32> = (0..input.strength.len())
        .flat_map(|i| {
            [
                input.strength[i],
                input.world_per_mm[i],
                input.profile[i] as f32,
                0.0,
            ]
        })
        .collect();
    let sss = texture(
        ctx,
        w,
        h,
        wgpu::TextureFormat::Rgba32Float,
        bytemuck::cast_slice(&sss_data),
    );
    let view = |t: &wgpu::Texture| t.create_view(&Default::default());
    let mut pass = SssPass::new(&ctx.device, config, table).unwrap();
    pass.resize(
        &ctx.device,
        &SssInputs {
            diffuse: &diffuse,
            depth: &view(&depth),
            sss: &view(&sss),
        },
    );
    pass.prepare(&ctx.queue, FOCAL);
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    pass.encode(&mut encoder, None);
    ctx.queue.submit([encoder.finish()]);
    ctx.check().unwrap();
    let (v, c) = readback::read_float(ctx, &diffuse).unwrap();
    assert_eq!(c, 4);
    v.chunks_exact(4).map(|p| [p[0], p[1], p[2]]).collect()
}

/// A 96x64 test card: smooth colour waves (so bilinear weight precision does not matter),
/// a near and a far surface with a depth step, a non-skin square, and varying strength.
fn test_card() -> ScreenInput {
    let (w, h) = (96u32, 64u32);
    let mut input = ScreenInput::uniform(w, h, [0.0; 3], 1.0, 1.0, 0.004);
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            let (fx, fy) = (x as f32, y as f32);
            input.color[i] = [
                0.2 + 0.1 * (fx * 0.35).sin() + 0.05 * (fx * 1.3).sin(),
                0.2 + 0.1 * (fy * 0.3).cos(),
                0.15 + 0.1 * ((fx + fy) * 0.25).sin(),
            ];
            input.depth[i] = if x < 60 { 0.5 } else { 0.8 };
            input.strength[i] = if x > 70 { 0.5 } else { 1.0 };
            if (20..34).contains(&x) && (20..40).contains(&y) {
                input.strength[i] = 0.0;
                input.color[i] = [0.1, 0.4, 0.45];
            }
        }
    }
    to_f16_exact(&mut input);
    input
}

fn max_abs_diff(a: &[[f32; 3]], b: &[[f32; 3]]) -> f32 {
    a.iter()
        .zip(b)
        .flat_map(|(x, y)| (0..3).map(move |c| (x[c] - y[c]).abs()))
        .fold(0.0, f32::max)
}

fn params(config: &SssSettings) -> oracle::ScreenParams {
    oracle::ScreenParams {
        focal_px: FOCAL,
        follow_surface: config.follow_surface,
        edge_mm: config.edge_mm,
    }
}

// Stated tolerances: max absolute difference for colours in 0.05..0.35 stored as Rgba16Float
// (the GPU keeps intermediates in f16, the oracle in f32; f16's step is 2.4e-4 there).
const TOL_SEPARABLE: f32 = 1e-3;
const TOL_GAUSSIAN6: f32 = 1e-3;
const TOL_HABLE13: f32 = 1e-3;

#[test]
fn separable_matches_oracle() {
    let Some(ctx) = context() else { return };
    let input = test_card();
    for samples in [7, 17, 25] {
        let config = SssSettings {
            method: SssMethod::Separable,
            samples,
            ..Default::default()
        };
        let gpu = run_gpu(&ctx, &input, &config);
        let cpu = oracle::separable(&input, &skin(samples), &params(&config)).unwrap();
        let d = max_abs_diff(&gpu, &cpu);
        eprintln!("separable N={samples}: max |GPU - oracle| = {d:.2e}");
        assert!(d < TOL_SEPARABLE, "separable N={samples}: {d}");
        assert!(
            max_abs_diff(&gpu, &input.color) > 0.01,
            "separable N={samples} did not blur"
        );
    }
}

#[test]
fn gaussian6_matches_oracle() {
    let Some(ctx) = context() else { return };
    let input = test_card();
    let config = settings(SssMethod::Gaussian6);
    let gpu = run_gpu(&ctx, &input, &config);
    let cpu = oracle::gaussian6(
        &input,
        &skin(config.samples),
        config.gaussians,
        &params(&config),
        config.min_sigma_px,
    )
    .unwrap();
    let d = max_abs_diff(&gpu, &cpu);
    eprintln!("gaussian6: max |GPU - oracle| = {d:.2e}");
    assert!(d < TOL_GAUSSIAN6, "gaussian6: {d}");
    assert!(
        max_abs_diff(&gpu, &input.color) > 0.01,
        "gaussian6 did not blur"
    );
}

#[test]
fn hable13_matches_oracle() {
    let Some(ctx) = context() else { return };
    let input = test_card();
    let config = settings(SssMethod::Hable13);
    let gpu = run_gpu(&ctx, &input, &config);
    let cpu = oracle::hable13(&input, &skin(config.samples), &params(&config)).unwrap();
    let d = max_abs_diff(&gpu, &cpu);
    eprintln!("hable13: max |GPU - oracle| = {d:.2e}");
    assert!(d < TOL_HABLE13, "hable13: {d}");
    assert!(
        max_abs_diff(&gpu, &input.color) > 0.01,
        "hable13 did not blur"
    );
}

const METHODS: [SssMethod; 3] = [
    SssMethod::Separable,
    SssMethod::Gaussian6,
    SssMethod::Hable13,
];

#[test]
fn uniformly_lit_flat_skin_keeps_its_energy() {
    let Some(ctx) = context() else { return };
    let input = ScreenInput::uniform(64, 64, [0.4, 0.3, 0.25], 0.5, 1.0, 0.001);
    for method in METHODS {
        let out = run_gpu(&ctx, &input, &settings(method));
        for c in 0..3 {
            let mean = out.iter().map(|p| p[c] as f64).sum::<f64>() / out.len() as f64;
            let want = input.color[0][c] as f64;
            assert!(
                (mean / want - 1.0).abs() < 0.01,
                "{method:?} channel {c}: mean {mean} vs {want}"
            );
        }
    }
}

/// Skin on the left at depth 0.5, a bright blue sky on the right (not skin, far away).
fn skin_against_sky() -> ScreenInput {
    let (w, h) = (64u32, 32u32);
    let mut input = ScreenInput::uniform(w, h, [0.5, 0.35, 0.3], 0.5, 1.0, 0.002);
    for y in 0..h {
        for x in 32..w {
            let i = (y * w + x) as usize;
            input.color[i] = [0.2, 0.4, 4.0];
            input.depth[i] = 1000.0;
            input.strength[i] = 0.0;
        }
    }
    to_f16_exact(&mut input);
    input
}

/// Largest relative change of a skin pixel's colour at the silhouette, by method. The only
/// leak is bilinear filtering of taps that land within half a texel of the silhouette.
const SILHOUETTE_BOUND: f32 = 0.03;

#[test]
fn no_bleeding_between_skin_and_background() {
    let Some(ctx) = context() else { return };
    let input = skin_against_sky();
    for method in METHODS {
        let out = run_gpu(&ctx, &input, &settings(method));
        let mut worst = 0.0f32;
        for (i, (o, c)) in out.iter().zip(&input.color).enumerate() {
            if input.strength[i] == 0.0 {
                // Background pixels: bit-identical (no glow or halo around the silhouette).
                assert_eq!(o, c, "{method:?}: background pixel {i} changed");
            } else {
                for ch in 0..3 {
                    worst = worst.max((o[ch] - c[ch]).abs() / c[ch]);
                }
            }
        }
        eprintln!("{method:?}: worst relative change of skin next to the sky {worst:.4}");
        assert!(
            worst < SILHOUETTE_BOUND,
            "{method:?}: skin tinted by the sky by {worst}"
        );
    }
}

/// Standard deviation, in pixels along x and y, of the response to one bright pixel.
fn impulse_spread(ctx: &GpuContext, w: u32, h: u32, depth: f32, method: SssMethod) -> (f32, f32) {
    let mut input = ScreenInput::uniform(w, h, [0.0; 3], depth, 1.0, 0.005);
    let (cx, cy) = (w / 2, h / 2);
    input.color[(cy * w + cx) as usize] = [1.0, 1.0, 1.0];
    let out = run_gpu(ctx, &input, &settings(method));
    let (mut s, mut sx, mut sy) = (0.0f64, 0.0f64, 0.0f64);
    for y in 0..h {
        for x in 0..w {
            let v = out[(y * w + x) as usize][0] as f64;
            let (dx, dy) = (x as f64 - cx as f64, y as f64 - cy as f64);
            s += v;
            sx += v * dx * dx;
            sy += v * dy * dy;
        }
    }
    (((sx / s).sqrt()) as f32, ((sy / s).sqrt()) as f32)
}

#[test]
fn blur_radius_halves_when_distance_doubles() {
    let Some(ctx) = context() else { return };
    for method in [SssMethod::Separable, SssMethod::Gaussian6] {
        let (near, _) = impulse_spread(&ctx, 128, 128, 0.25, method);
        let (far, _) = impulse_spread(&ctx, 128, 128, 0.5, method);
        eprintln!("{method:?}: spread {near:.3} px at d, {far:.3} px at 2d");
        assert!(near > 2.0, "{method:?}: blur too small to measure: {near}");
        assert!(
            (near / far - 2.0).abs() < 0.1,
            "{method:?}: ratio {}",
            near / far
        );
    }
}

#[test]
fn circular_kernel_is_round_at_any_aspect_ratio() {
    let Some(ctx) = context() else { return };
    for method in [SssMethod::Separable, SssMethod::Gaussian6] {
        let (sx, sy) = impulse_spread(&ctx, 192, 64, 0.3, method);
        eprintln!("{method:?}: spread x {sx:.3} px, y {sy:.3} px at 3:1");
        assert!((sx / sy - 1.0).abs() < 0.03, "{method:?}: x {sx} vs y {sy}");
    }
}

fn render_scene_diffuse(ctx: &GpuContext, method: SssMethod) -> (Vec<[f32; 4]>, Vec<[f32; 4]>) {
    let s = subsurface_render::Scene::default_scene();
    let opts = RenderOptions {
        settings: RenderSettings {
            width: 128,
            height: 96,
            sss: settings(method),
            ..s.desc.render.clone()
        },
        view: DebugView::Final,
        ..Default::default()
    };
    let mut r = Renderer::new(ctx, &s, opts).unwrap();
    r.render().unwrap();
    (r.read_diffuse().unwrap(), r.read_sss().unwrap())
}

#[test]
fn non_skin_pixels_are_bit_identical_with_and_without_sss() {
    let Some(ctx) = context() else { return };
    let (plain, mask) = render_scene_diffuse(&ctx, SssMethod::None);
    assert!(mask.iter().any(|m| m[0] > 0.0) && mask.iter().any(|m| m[0] == 0.0));
    for method in METHODS {
        let (blurred, _) = render_scene_diffuse(&ctx, method);
        let mut changed_skin = 0;
        for i in 0..plain.len() {
            if mask[i][0] == 0.0 {
                assert_eq!(
                    plain[i], blurred[i],
                    "{method:?}: non-skin pixel {i} changed"
                );
            } else if plain[i] != blurred[i] {
                changed_skin += 1;
            }
        }
        assert!(changed_skin > 0, "{method:?}: no skin pixel changed");
    }
}

/// The blur has the same physical size at any resolution: 256 px and 512 px downsampled agree.
/// Compared on skin pixels away from silhouettes, whose aliasing (there is no MSAA) differs
/// between the two resolutions whatever SSS does.
#[test]
fn same_image_at_256_and_512_after_downsampling() {
    let Some(ctx) = context() else { return };
    let s = subsurface_render::Scene::default_scene();
    let render = |w: u32, h: u32| {
        let opts = RenderOptions {
            settings: RenderSettings {
                width: w,
                height: h,
                ..s.desc.render.clone()
            },
            ..Default::default()
        };
        let mut r = Renderer::new(&ctx, &s, opts).unwrap();
        let img = r.render().unwrap().image;
        (img, r.read_sss().unwrap())
    };
    let (small, mask) = render(256, 256);
    let (large, _) = render(512, 512);
    let down = image::imageops::resize(&large, 256, 256, image::imageops::FilterType::Triangle);
    let errors = common::flip_errors(&small, &down);
    let w = 256i32;
    let interior = |i: usize| {
        let (x, y) = (i as i32 % w, i as i32 / w);
        (-2..=2).all(|dy| {
            (-2..=2).all(|dx| {
                let (xx, yy) = ((x + dx).clamp(0, w - 1), (y + dy).clamp(0, w - 1));
                mask[(yy * w + xx) as usize][0] > 0.0
            })
        })
    };
    let skin: Vec<f32> = errors
        .iter()
        .enumerate()
        .filter(|(i, _)| interior(*i))
        .map(|(_, e)| *e)
        .collect();
    assert!(
        skin.len() > 2000,
        "too few interior skin pixels: {}",
        skin.len()
    );
    let mean = skin.iter().sum::<f32>() / skin.len() as f32;
    let p95 = common::percentile(&skin, 0.95);
    eprintln!(
        "256 vs 512 downsampled, {} interior skin pixels: FLIP mean {mean:.4}, p95 {p95:.4}",
        skin.len()
    );
    assert!(mean < 0.05 && p95 < 0.12, "FLIP mean {mean}, p95 {p95}");
}

#[test]
fn bad_sss_settings_are_errors() {
    let Some(ctx) = context() else { return };
    for (config, table, field) in [
        (
            SssSettings {
                samples: 4,
                ..Default::default()
            },
            skin(17),
            "samples",
        ),
        (
            SssSettings {
                samples: 65,
                ..Default::default()
            },
            skin(17),
            "samples",
        ),
        (
            SssSettings {
                edge_mm: f32::NAN,
                ..Default::default()
            },
            skin(17),
            "edge_mm",
        ),
        // A table built for another tap count than the settings ask for.
        (settings(SssMethod::Separable), skin(9), "samples"),
        (settings(SssMethod::Separable), Vec::new(), "profiles"),
    ] {
        let err = SssPass::new(&ctx.device, &config, &table)
            .err()
            .expect("accepted bad settings");
        assert!(err.to_string().contains(field), "{err}");
    }
    let _ = scene;
}

/// Three materials side by side, each with its own profile row: a 96x64 card split into skin
/// (left), marble (middle) and ketchup (right), at one depth so only the profile boundary
/// separates them. Colours are the test card's halved (0.025..0.18): the six-Gaussian chain
/// stores twelve passes and six sums in half floats, whose step here is half of 2.4e-4.
fn three_material_card() -> ScreenInput {
    let mut input = test_card();
    for c in &mut input.color {
        *c = c.map(|v| 0.5 * v);
    }
    let w = input.width as usize;
    for (i, p) in input.profile.iter_mut().enumerate() {
        *p = ((i % w) / 32) as u32;
    }
    input.depth.fill(0.5);
    input.strength.fill(1.0);
    input
}

/// Every method blurs each pixel with its own material's kernel: GPU equals the oracle's
/// per-material result everywhere.
#[test]
fn each_material_is_blurred_with_its_own_profile() {
    let Some(ctx) = context() else { return };
    let input = three_material_card();
    let table = three_materials(17);
    for method in METHODS {
        let config = settings(method);
        let gpu = run_gpu_with(&ctx, &input, &config, &table);
        let p = params(&config);
        let cpu = match method {
            SssMethod::Separable => oracle::separable(&input, &table, &p),
            SssMethod::Gaussian6 => {
                oracle::gaussian6(&input, &table, config.gaussians, &p, config.min_sigma_px)
            }
            _ => oracle::hable13(&input, &table, &p),
        }
        .unwrap();
        let d = max_abs_diff(&gpu, &cpu);
        eprintln!("{method:?}, skin | marble | ketchup: max |GPU - oracle| = {d:.2e}");
        assert!(d < 1e-3, "{method:?}: {d}");
        // One kernel for all would not do: skin's kernel on the whole card differs.
        let one = run_gpu_with(&ctx, &input, &config, &vec![table[0].clone(); 3]);
        assert!(
            max_abs_diff(&one, &gpu) > 1e-2,
            "{method:?}: the profiles made no difference"
        );
    }
}

/// Constant colour per material, a sharp step at each boundary: after the blur every pixel
/// keeps its own material's colour (no tap reads across a skin/marble boundary).
#[test]
fn no_kernel_mixes_across_a_material_boundary() {
    let Some(ctx) = context() else { return };
    let mut input = three_material_card();
    let colours = [[0.4, 0.25, 0.2], [0.3, 0.3, 0.28], [0.35, 0.05, 0.03]];
    for (c, p) in input.color.iter_mut().zip(&input.profile) {
        *c = colours[*p as usize];
    }
    to_f16_exact(&mut input);
    let table = three_materials(17);
    for method in METHODS {
        let gpu = run_gpu_with(&ctx, &input, &settings(method), &table);
        let d = max_abs_diff(&gpu, &input.color);
        eprintln!("{method:?}: largest change at the material boundaries {d:.2e}");
        assert!(d < 1e-3, "{method:?}: a kernel crossed a boundary by {d}");
    }
}

/// Skin, marble and ketchup slabs side by side in one frame, lit with a hard shadow edge
/// across all three so each has something to blur.
const THREE_SLABS: &str = r#"
[camera]
position = [0.0, 0.0, 0.25]
target = [0.0, 0.0, 0.0]
fov_y_deg = 30.0
near = 0.05
far = 2.0
[render]
width = 192
height = 96
ambient = [0.02, 0.02, 0.02]
[[lights]]
kind = "spot"
position = [0.02, 0.1, 0.3]
target = [0.0, 0.0, 0.0]
intensity = 0.02
inner_angle_deg = 10.0
outer_angle_deg = 12.0
shadow_map_size = 512
shadow_bias = 0.0002
[[objects]]
name = "skin"
mesh = { shape = "slab", width = 0.04, height = 0.06, thickness = 0.02 }
translation = [-0.045, 0.0, 0.0]
material = { albedo = [0.75, 0.5, 0.4], profile = "skin" }
[[objects]]
name = "marble"
mesh = { shape = "slab", width = 0.04, height = 0.06, thickness = 0.02 }
material = { albedo = [0.83, 0.79, 0.75], profile = "marble" }
[[objects]]
name = "ketchup"
mesh = { shape = "slab", width = 0.04, height = 0.06, thickness = 0.02 }
translation = [0.045, 0.0, 0.0]
material = { albedo = [0.16, 0.01, 0.0], profile = "ketchup" }
"#;

/// The whole renderer, three materials in one frame: the lighting pass writes each pixel's
/// profile row, and every pixel of the blurred image equals the oracle run with the
/// renderer's own profile table on the unblurred image (read back from the same frame
/// rendered without SSS).
#[test]
fn renderer_blurs_skin_marble_and_ketchup_each_with_its_own_profile() {
    let Some(ctx) = context() else { return };
    let s = scene(THREE_SLABS);
    let render = |method| {
        let mut opts = RenderOptions::from_scene(&s);
        opts.settings.sss.method = method;
        let mut r = Renderer::new(&ctx, &s, opts).unwrap();
        r.render().unwrap();
        r
    };
    let plain = render(SssMethod::None);
    let sss = plain.read_sss().unwrap();
    let (w, h) = (192u32, 96u32);
    let mut input = ScreenInput::uniform(w, h, [0.0; 3], 1.0, 0.0, 1.0);
    input.color = plain
        .read_diffuse()
        .unwrap()
        .iter()
        .map(|c| [c[0], c[1], c[2]])
        .collect();
    input.depth = plain.read_linear_depth().unwrap();
    for (i, t) in sss.iter().enumerate() {
        input.strength[i] = t[0];
        input.world_per_mm[i] = if t[0] > 0.0 { t[1] } else { 1.0 };
        input.profile[i] = t[2].round() as u32;
    }
    // Three rows, one per material, each present on screen.
    for row in 0..3 {
        let n = input.profile.iter().zip(&input.strength);
        let count = n.filter(|(p, s)| **p == row && **s > 0.0).count();
        assert!(count > 500, "profile row {row} covers {count} pixels");
    }
    for method in METHODS {
        let r = render(method);
        let table = &r.profile_table().kernels;
        assert_eq!(table.len(), 3);
        let config = &r_settings(&s, method);
        let p = oracle::ScreenParams {
            focal_px: 0.5 * h as f32 / (0.5 * 30f32.to_radians()).tan(),
            follow_surface: config.follow_surface,
            edge_mm: config.edge_mm,
        };
        let cpu = match method {
            SssMethod::Separable => oracle::separable(&input, table, &p),
            SssMethod::Gaussian6 => {
                oracle::gaussian6(&input, table, config.gaussians, &p, config.min_sigma_px)
            }
            _ => oracle::hable13(&input, table, &p),
        }
        .unwrap();
        let gpu: Vec<[f32; 3]> = r
            .read_diffuse()
            .unwrap()
            .iter()
            .map(|c| [c[0], c[1], c[2]])
            .collect();
        // The light is set so the lit slabs stay below ~0.2, the card tests' colour range,
        // where the half-float targets' step is 1.2e-4.
        let peak = input.color.iter().flatten().fold(0.0f32, |a, &b| a.max(b));
        assert!((0.05..0.3).contains(&peak), "brightest pixel {peak}");
        let d = max_abs_diff(&gpu, &cpu);
        eprintln!("{method:?}, skin | marble | ketchup in one frame: max |GPU - oracle| = {d:.2e}");
        assert!(d < 1e-3, "{method:?}: {d}");
    }
}

fn r_settings(s: &subsurface_render::Scene, method: SssMethod) -> SssSettings {
    SssSettings {
        method,
        ..s.desc.render.sss.clone()
    }
}
