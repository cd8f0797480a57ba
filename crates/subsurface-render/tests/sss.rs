//! Screen-space SSS on the GPU against the CPU oracles of `subsurface-profile`, and the
//! measured properties users rely on: energy kept, no bleeding, perspective-correct size.
//! The passes are driven through their public API on textures made here, as another wgpu
//! application would.

mod common;
mod sss_util;

use common::{context, scene};
use sss_util::*;
use subsurface_profile::oracle::{self, ScreenInput};
use subsurface_render::passes::sss::SssPass;
use subsurface_render::{
    DebugView, GpuContext, RenderOptions, RenderSettings, Renderer, SssMethod, SssSettings,
};

// Stated tolerances: max absolute difference for colours in 0.05..0.35 stored as Rgba16Float
// (the GPU keeps intermediates in f16, the oracle in f32; f16's step is 2.4e-4 there).
const TOL_SEPARABLE: f32 = 1e-3;
const TOL_GAUSSIAN6: f32 = 1e-3;
const TOL_HABLE13: f32 = 1e-3;

/// The pass run with `config` on `input` on the GPU is within `tol` of the oracle's `cpu`
/// everywhere, and blurs.
fn assert_blurs_as_oracle(
    ctx: &GpuContext,
    input: &ScreenInput,
    config: &SssSettings,
    cpu: &[[f32; 3]],
    tol: f32,
    name: &str,
) {
    let gpu = run_gpu(ctx, input, config);
    let d = max_abs_diff(&gpu, cpu);
    eprintln!("{name}: max |GPU - oracle| = {d:.2e}");
    assert!(d < tol, "{name}: {d}");
    assert!(
        max_abs_diff(&gpu, &input.color) > 0.01,
        "{name} did not blur"
    );
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
