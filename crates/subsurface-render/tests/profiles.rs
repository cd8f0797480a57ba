//! A profile per material in one frame: skin, marble and ketchup side by side, each blurred
//! with its own kernel by every screen-space method, on the pass alone and in the renderer,
//! against the CPU oracles with the same profile table.

use crate::common;
use crate::sss_util;

use common::{camera_toml, context, light_toml, scene};
use sss_util::*;
use subsurface_profile::oracle::{self, ScreenInput};
use subsurface_render::{DebugView, RenderOptions, Renderer, SssMethod, SssSettings};

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
    to_f16_exact(&mut input);
    input
}

/// Every method blurs each pixel with its own material's kernel: GPU equals the oracle's
/// per-material result everywhere.
#[test]
fn each_material_is_blurred_with_its_own_profile() {
    let Some(ctx) = context() else { return };
    let input = three_material_card();
    let table = three_materials(17);
    for (method, fetch, config) in methods_and_fetches() {
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
        eprintln!(
            "{method:?}, {fetch} fetch, skin | marble | ketchup: max |GPU - oracle| = {d:.2e}"
        );
        assert!(d < 1e-3, "{method:?}, {fetch} fetch: {d}");
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
fn three_slabs() -> String {
    let light = light_toml(
        "spot",
        [0.02, 0.1, 0.3],
        0.02,
        "inner_angle_deg = 10.0\nouter_angle_deg = 12.0\nshadow_map_size = 512\nshadow_bias = 0.0002",
    );
    format!(
        r#"
{camera}
[render]
width = 192
height = 96
ambient = [0.02, 0.02, 0.02]
{light}
[[objects]]
name = "skin"
mesh = {{ shape = "slab", width = 0.04, height = 0.06, thickness = 0.02 }}
translation = [-0.045, 0.0, 0.0]
material = {{ albedo = [0.75, 0.5, 0.4], medium = "skin" }}
[[objects]]
name = "marble"
mesh = {{ shape = "slab", width = 0.04, height = 0.06, thickness = 0.02 }}
material = {{ medium = "marble" }}   # colour: the medium's own R_d
[[objects]]
name = "ketchup"
mesh = {{ shape = "slab", width = 0.04, height = 0.06, thickness = 0.02 }}
translation = [0.045, 0.0, 0.0]
material = {{ medium = "ketchup" }}
"#,
        camera = camera_toml(0.25, 30.0, "near = 0.05\nfar = 2.0"),
    )
}

/// The whole renderer, three materials in one frame: the lighting pass writes each pixel's
/// profile row, and every pixel of the blurred image equals the oracle run with the
/// renderer's own profile table on the unblurred image (read back from the same frame
/// rendered without the SSS passes).
#[test]
fn renderer_blurs_skin_marble_and_ketchup_each_with_its_own_profile() {
    let Some(ctx) = context() else { return };
    let s = scene(&three_slabs());
    let render = |method, view| {
        let mut opts = RenderOptions::from_scene(&s);
        // Fixed taps: the oracle has no jitter.
        opts.settings = common::high(&s);
        opts.settings.sss.method = method;
        opts.view = view;
        let mut r = Renderer::new(&ctx, &s, opts).unwrap();
        r.render().unwrap();
        r
    };
    // The lit image the blur starts from: with SSS on (the lighting looks the diffuse light's
    // shadow up where the diffusion source was lit), the SSS passes skipped.
    let plain = render(SssMethod::Separable, DebugView::DiffuseBeforeSss);
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
        let r = render(method, DebugView::Final);
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
