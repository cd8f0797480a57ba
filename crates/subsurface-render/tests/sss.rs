//! Screen-space SSS on the GPU against the CPU oracles of `subsurface-profile`, and the
//! measured properties users rely on: energy kept, no bleeding, perspective-correct size.
//! The passes are driven through their public API on textures made here, as another wgpu
//! application would.

use crate::common;
use crate::sss_util;

use common::{context, scene};
use sss_util::*;
use subsurface_profile::oracle::{self, ScreenInput};
use subsurface_render::passes::sss::SssPass;
use subsurface_render::{
    DebugView, GpuContext, RenderOptions, RenderSettings, Renderer, SssFetch, SssMethod,
    SssSettings,
};

// Stated tolerances: max absolute difference for colours in 0.05..0.35 stored as Rgba16Float
// (the GPU keeps intermediates in f16, the oracle in f32; f16's step is 2.4e-4 there).
const TOL_SEPARABLE: f32 = 1e-3;
const TOL_GAUSSIAN6: f32 = 1e-3;
const TOL_HABLE13: f32 = 1e-3;

/// The pass run with `config` on `input` on the GPU, with each way of fetching texels, is
/// within `tol` of the oracle's `cpu` everywhere, and blurs.
fn assert_blurs_as_oracle(
    ctx: &GpuContext,
    input: &ScreenInput,
    config: &SssSettings,
    cpu: &[[f32; 3]],
    tol: f32,
    name: &str,
) {
    for fetch in SssFetch::ALL {
        let config = SssSettings {
            fetch,
            ..config.clone()
        };
        let gpu = run_gpu(ctx, input, &config);
        let d = max_abs_diff(&gpu, cpu);
        eprintln!("{name}, {fetch} fetch: max |GPU - oracle| = {d:.2e}");
        assert!(d < tol, "{name}, {fetch} fetch: {d}");
        assert!(
            max_abs_diff(&gpu, &input.color) > 0.01,
            "{name}, {fetch} fetch did not blur"
        );
    }
}

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
        let cpu = oracle::separable(&input, &skin(samples), &params(&config)).unwrap();
        let name = format!("separable N={samples}");
        assert_blurs_as_oracle(&ctx, &input, &config, &cpu, TOL_SEPARABLE, &name);
    }
}

#[test]
fn jittered_separable_matches_oracle() {
    let Some(ctx) = context() else { return };
    let input = test_card();
    for samples in [7, 17] {
        let config = SssSettings {
            method: SssMethod::Separable,
            samples,
            jitter: true,
            ..Default::default()
        };
        let cpu = oracle::separable_jittered(&input, &skin(samples), &params(&config)).unwrap();
        let name = format!("jittered separable N={samples}");
        assert_blurs_as_oracle(&ctx, &input, &config, &cpu, TOL_SEPARABLE, &name);
    }
    // The per-pixel profile table: each material's taps with its own widths.
    let mut input = test_card();
    for (i, p) in input.profile.iter_mut().enumerate() {
        *p = (i % 96 / 32) as u32;
    }
    let config = SssSettings {
        samples: 7,
        jitter: true,
        ..Default::default()
    };
    let table = three_materials(7);
    let cpu = oracle::separable_jittered(&input, &table, &params(&config)).unwrap();
    for fetch in SssFetch::ALL {
        let config = SssSettings {
            fetch,
            ..config.clone()
        };
        let gpu = run_gpu_with(&ctx, &input, &config, &table);
        let d = max_abs_diff(&gpu, &cpu);
        eprintln!(
            "jittered separable, three profiles, {fetch} fetch: max |GPU - oracle| = {d:.2e}"
        );
        assert!(d < TOL_SEPARABLE, "{fetch} fetch: {d}");
    }
}

/// The workgroup fetch on a line longer than a workgroup's stretch, with a kernel wider than
/// its apron: taps past the apron read the texture, and the result is still the oracle's; as
/// it is where the vertical pass cannot write the diffuse texture (a fragment pass then).
#[test]
fn workgroup_fetch_past_the_apron_and_without_storage_matches_oracle() {
    let Some(ctx) = context() else { return };
    let (w, h) = (384u32, 24u32);
    let mut input = ScreenInput::uniform(w, h, [0.0; 3], 0.5, 1.0, 0.1);
    for y in 0..h {
        for x in 0..w {
            let (fx, fy) = (x as f32, y as f32);
            input.color[(y * w + x) as usize] = [
                0.2 + 0.1 * (fx * 0.11).sin(),
                0.2 + 0.1 * (fy * 0.3).cos(),
                0.15 + 0.1 * ((fx + fy) * 0.07).sin(),
            ];
        }
    }
    to_f16_exact(&mut input);
    let table = skin(17);
    let px_per_mm = input.world_per_mm[0] * FOCAL / input.depth[0];
    let widest = table[0]
        .separable
        .iter()
        .map(|k| k[3].abs())
        .fold(0.0, f32::max);
    assert!(
        widest * px_per_mm > 64.0,
        "the test needs taps past the 64-texel apron ({} px)",
        widest * px_per_mm
    );
    for jitter in [false, true] {
        let config = SssSettings {
            fetch: SssFetch::Workgroup,
            jitter,
            ..Default::default()
        };
        let cpu = if jitter {
            oracle::separable_jittered(&input, &table, &params(&config))
        } else {
            oracle::separable(&input, &table, &params(&config))
        }
        .unwrap();
        // Packing as the first pass loads (GPUs) or in a pack step first (CPU adapters).
        for (storage, on_load) in [(true, true), (false, true), (true, false), (false, false)] {
            let gpu = run_gpu_packing(&ctx, &input, &config, &table, storage, on_load);
            let d = max_abs_diff(&gpu, &cpu);
            let case = format!("jitter {jitter}, storage {storage}, pack on load {on_load}");
            eprintln!("workgroup, {case}: max |GPU - oracle| = {d:.2e}");
            assert!(d < TOL_SEPARABLE, "{case}: {d}");
            assert!(max_abs_diff(&gpu, &input.color) > 0.01, "did not blur");
        }
    }
}

#[test]
fn gaussian6_matches_oracle() {
    let Some(ctx) = context() else { return };
    let input = test_card();
    let config = settings(SssMethod::Gaussian6);
    let cpu = oracle::gaussian6(
        &input,
        &skin(config.samples),
        config.gaussians,
        &params(&config),
        config.min_sigma_px,
    )
    .unwrap();
    assert_blurs_as_oracle(&ctx, &input, &config, &cpu, TOL_GAUSSIAN6, "gaussian6");
}

#[test]
fn hable13_matches_oracle() {
    let Some(ctx) = context() else { return };
    let input = test_card();
    let config = settings(SssMethod::Hable13);
    let cpu = oracle::hable13(&input, &skin(config.samples), &params(&config)).unwrap();
    assert_blurs_as_oracle(&ctx, &input, &config, &cpu, TOL_HABLE13, "hable13");
}

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

#[test]
fn jittered_flat_lit_skin_keeps_its_energy() {
    let Some(ctx) = context() else { return };
    let input = ScreenInput::uniform(64, 64, [0.4, 0.3, 0.25], 0.5, 1.0, 0.001);
    let config = SssSettings {
        samples: 7,
        jitter: true,
        ..Default::default()
    };
    let out = run_gpu(&ctx, &input, &config);
    for c in 0..3 {
        let mean = out.iter().map(|p| p[c] as f64).sum::<f64>() / out.len() as f64;
        let worst = out
            .iter()
            .map(|p| (p[c] - input.color[0][c]).abs())
            .fold(0.0, f32::max);
        let want = input.color[0][c] as f64;
        eprintln!("jittered 7 taps, channel {c}: mean {mean} vs {want}, worst pixel {worst:.1e}");
        // The weights sum to 1 per pixel: every pixel keeps its value up to f16 rounding.
        assert!(
            (mean / want - 1.0).abs() < 1e-3 && worst < 1e-3,
            "channel {c}"
        );
    }
}

/// The default scene at 256x256 with `samples` taps, jittered or not, and every scattering
/// material's width times `widen`: the frame, the diffuse radiance after SSS and the SSS mask.
fn default_scene_with(ctx: &GpuContext, samples: u32, jitter: bool, widen: f32) -> Rendered {
    let mut s = subsurface_render::Scene::default_scene();
    // The paper's own skin kernel, which its few-sample mode was made for. The default
    // scene's measured skin1 spreads 17 taps over 13 mm of red tail: there 7 taps of either
    // kind stand far apart (7 fixed FLIP 0.011, 7 jittered 0.013 and relative RMSE 0.16 on
    // skin against 33), which docs/lab/performance.md reports.
    s.edit_materials(|m| {
        m.medium = subsurface_profile::Medium::default();
        m.albedo = subsurface_render::scene::SKIN_ALBEDO;
        m.sss_width *= widen;
    });
    let mut settings = RenderSettings {
        width: 256,
        height: 256,
        ..s.desc.render.clone()
    };
    settings.sss.samples = samples;
    settings.sss.jitter = jitter;
    let opts = RenderOptions {
        settings,
        ..Default::default()
    };
    let mut r = Renderer::new(ctx, &s, opts).unwrap();
    let image = r.render().unwrap().image;
    (image, r.read_diffuse().unwrap(), r.read_sss().unwrap())
}

type Rendered = (image::RgbaImage, Vec<[f32; 4]>, Vec<[f32; 4]>);

/// FLIP mean over the skin pixels, and the RMSE of the diffuse radiance over the skin
/// relative to its mean, of `test` against `reference`.
fn skin_errors(reference: &Rendered, test: &Rendered) -> (f32, f32) {
    let skin = |i: usize| reference.2[i][0] > 0.0;
    let flip = common::masked_mean(&common::flip_errors(&reference.0, &test.0), skin);
    let (mut sq, mut sum, mut n) = (0.0f64, 0.0f64, 0usize);
    for (i, (a, b)) in reference.1.iter().zip(&test.1).enumerate() {
        if skin(i) {
            for c in 0..3 {
                sq += f64::from(a[c] - b[c]).powi(2);
                sum += f64::from(a[c]);
            }
            n += 3;
        }
    }
    (flip, ((sq / n as f64).sqrt() / (sum / n as f64)) as f32)
}

/// Measured (lavapipe, default scene with the `skin` preset at 256x256, skin pixels) against 33 taps: 7 jittered
/// taps FLIP 0.0042, relative RMSE 0.0207; 7 fixed taps 0.0040 and 0.0176; 17 fixed taps
/// 0.0024 and 0.0106. In one frame the jitter's noise costs a little per pixel (the paper
/// leaves it to temporal antialiasing); what it buys is no banding. The bounds are about 1.5x
/// the measured figures.
const JITTER7_FLIP_BOUND: f32 = 0.0065;
const JITTER7_REL_RMSE_BOUND: f32 = 0.03;

#[test]
fn jittered_7_taps_look_like_33_taps() {
    let Some(ctx) = context() else { return };
    let reference = default_scene_with(&ctx, 33, false, 1.0);
    let (flip, rmse) = skin_errors(&reference, &default_scene_with(&ctx, 7, true, 1.0));
    for (name, samples, jitter) in [("7 fixed", 7, false), ("17 fixed", 17, false)] {
        let (f, r) = skin_errors(&reference, &default_scene_with(&ctx, samples, jitter, 1.0));
        eprintln!("{name} vs 33 taps on skin: FLIP {f:.4}, relative RMSE {r:.4}");
    }
    eprintln!("7 jittered vs 33 taps on skin: FLIP {flip:.4}, relative RMSE {rmse:.4}");
    assert!(flip < JITTER7_FLIP_BOUND, "FLIP {flip}");
    assert!(rmse < JITTER7_REL_RMSE_BOUND, "relative RMSE {rmse}");
    // Four times as wide (a close-up): 7 fixed taps now lie pixels apart.
    let reference = default_scene_with(&ctx, 33, false, 4.0);
    for (name, jitter) in [("7 fixed", false), ("7 jittered", true)] {
        let (f, r) = skin_errors(&reference, &default_scene_with(&ctx, 7, jitter, 4.0));
        eprintln!("4x wide, {name} vs 33 taps on skin: FLIP {f:.4}, relative RMSE {r:.4}");
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
    for (method, fetch, config) in methods_and_fetches() {
        let out = run_gpu(&ctx, &input, &config);
        let mut worst = 0.0f32;
        for (i, (o, c)) in out.iter().zip(&input.color).enumerate() {
            if input.strength[i] == 0.0 {
                // Background pixels: bit-identical (no glow or halo around the silhouette).
                assert_eq!(o, c, "{method:?}, {fetch}: background pixel {i} changed");
            } else {
                for ch in 0..3 {
                    worst = worst.max((o[ch] - c[ch]).abs() / c[ch]);
                }
            }
        }
        eprintln!("{method:?}, {fetch}: worst relative change of skin next to the sky {worst:.4}");
        assert!(
            worst < SILHOUETTE_BOUND,
            "{method:?}, {fetch}: skin tinted by the sky by {worst}"
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

/// The renderer blurs only the skin's part of the frame (`frame_plan::sss_region`): its
/// pixels come out bit for bit as the pass run over the whole frame on the same inputs gives
/// them, and the part is well under the frame.
#[test]
fn the_skin_region_blurs_as_the_whole_frame_does() {
    let Some(ctx) = context() else { return };
    let s = subsurface_render::Scene::default_scene();
    let (w, h) = (256, 144);
    let settings = RenderSettings {
        width: w,
        height: h,
        ..s.desc.render.clone()
    };
    let render = |view| {
        let options = RenderOptions {
            settings: settings.clone(),
            view,
            ..Default::default()
        };
        let mut r = Renderer::new(&ctx, &s, options).unwrap();
        r.render().unwrap();
        r
    };
    let before = render(DebugView::DiffuseBeforeSss);
    let after = render(DebugView::Final);
    let table = after.profile_table();
    let region = subsurface_render::frame_plan::sss_region(
        &s,
        (w, h),
        &table.kernels,
        &table.object_rows,
        settings.sss.jitter,
    );
    let area = region[2].saturating_sub(region[0]) * region[3].saturating_sub(region[1]);
    eprintln!("region {region:?}: {area} of {} pixels", w * h);
    assert!(area > 0 && area < w * h / 2, "region {region:?}");
    let sss = after.read_sss().unwrap();
    let rgb = |v: Vec<[f32; 4]>| v.into_iter().map(|p| [p[0], p[1], p[2]]).collect();
    let input = ScreenInput {
        width: w,
        height: h,
        color: rgb(before.read_diffuse().unwrap()),
        depth: after.read_linear_depth().unwrap(),
        strength: sss.iter().map(|p| p[0]).collect(),
        world_per_mm: sss.iter().map(|p| p[1]).collect(),
        profile: sss.iter().map(|p| p[2] as u32).collect(),
    };
    let focal = subsurface_render::gpu_scene::camera_uniform(&s, w, h).focal_px;
    let whole = run_gpu_at(&ctx, &input, &settings.sss, &table.kernels, true, focal);
    let ours: Vec<[f32; 3]> = rgb(after.read_diffuse().unwrap());
    assert!(
        max_abs_diff(&whole, &input.color) > 0.01,
        "nothing was blurred"
    );
    assert_eq!(max_abs_diff(&whole, &ours), 0.0);
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
