//! Texture-space diffusion (`--sss texture`) and translucent shadow maps (`--transmittance
//! tsm`): the GPU blur against its CPU mirror and against the exact sum-of-Gaussians
//! convolution, the head against its reference image, seams on the head, and TSM.

use crate::common;

use common::{
    camera_toml, context, flip_against_reference, head_scene, options, read4, upload_texture,
    white_object_scene,
};
use subsurface_profile::{SumOfGaussians, gaussian};
use subsurface_render::SssMethod;
use subsurface_render::TransmittanceMethod;
use subsurface_render::passes::texture_space::{
    BlurKernel, MAP_FORMAT, STRETCH_FORMAT, TextureBlur, cpu_blur, cpu_dilate,
};
use subsurface_render::{GpuContext, RenderOptions, Renderer, Scene};

/// GPU blur vs its CPU mirror: largest absolute difference over the map, relative to the
/// largest value (Rgba16Float intermediates; the mirror rounds at the same points, so what
/// remains is the order of float operations and the rounding of blending).
const GPU_VS_CPU_MAX: f32 = 5e-3;

/// Runs the GPU blur on `irradiance` / `stretch`; returns (accum, widest, padded result,
/// padded widest).
#[allow(clippy::type_complexity)]
fn gpu_blur(
    ctx: &GpuContext,
    size: u32,
    irradiance: &[[f32; 4]],
    stretch: &[[f32; 2]],
    kernel: &BlurKernel,
    padding: u32,
) -> (Vec<[f32; 4]>, Vec<[f32; 4]>, Vec<[f32; 4]>) {
    let e: Vec<half::f16> = irradiance
        .iter()
        .flatten()
        .map(|v| half::f16::from_f32(*v))
        .collect();
    let e = upload_texture(ctx, size, size, MAP_FORMAT, bytemuck::cast_slice(&e));
    let s = upload_texture(
        ctx,
        size,
        size,
        STRETCH_FORMAT,
        bytemuck::cast_slice(stretch),
    );
    let blur = TextureBlur::new(&ctx.device);
    let targets = blur.bind(&ctx.device, &e, &s, kernel, padding);
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    blur.encode(&mut encoder, &targets, None);
    ctx.queue.submit([encoder.finish()]);
    ctx.check().unwrap();
    (
        read4(ctx, &targets.accum),
        read4(ctx, &targets.result),
        read4(ctx, &targets.widest),
    )
}

/// A synthetic irradiance map: three UV islands (a rectangle, a disc, a thin strip) holding
/// sharp light/shadow edges, points and a gradient; the rest empty. Stretch varies across the
/// map (0.12..0.4 mm per texel along u, 0.2..0.3 along v) as on a real head.
fn synthetic(size: u32) -> (Vec<[f32; 4]>, Vec<[f32; 2]>) {
    let n = size as usize;
    let mut e = vec![[0.0f32; 4]; n * n];
    let mut s = vec![[0.0f32; 2]; n * n];
    for y in 0..n {
        for x in 0..n {
            let (fx, fy) = (x as f32 / n as f32, y as f32 / n as f32);
            s[y * n + x] = [0.12 + 0.28 * fx, 0.2 + 0.1 * fy];
            let rect = (0.05..0.55).contains(&fx) && (0.05..0.45).contains(&fy);
            let disc = (fx - 0.72).powi(2) + (fy - 0.7).powi(2) < 0.2f32.powi(2);
            let strip = (0.1..0.45).contains(&fx) && (0.6..0.64).contains(&fy);
            if !(rect || disc || strip) {
                continue;
            }
            let mut c = if fx < 0.3 {
                [1.0, 0.8, 0.6]
            } else {
                [0.1, 0.05, 0.02]
            };
            if disc {
                c = [0.5 + fy, 0.4, 0.3 * fx];
            }
            if (x % 17 == 5) && (y % 13 == 7) {
                c = [4.0, 3.0, 2.0];
            }
            e[y * n + x] = [c[0], c[1], c[2], 1.0];
        }
    }
    (e, s)
}

#[test]
fn blur_matches_cpu_mirror() {
    let Some(ctx) = context() else { return };
    let size = 128;
    let (e, s) = synthetic(size);
    let kernel = BlurKernel::from_profile(&SumOfGaussians::skin());
    let (accum, result, widest) = gpu_blur(&ctx, size, &e, &s, &kernel, 4);
    let (cpu_accum, cpu_widest) = cpu_blur(size, &e, &s, &kernel);
    let cpu_result = cpu_dilate(size, &cpu_accum, 4);
    let cpu_widest = cpu_dilate(size, &cpu_widest, 4);
    let peak = cpu_accum
        .iter()
        .flat_map(|c| c[..3].to_vec())
        .fold(0.0f32, f32::max);
    let max_diff = |a: &[[f32; 4]], b: &[[f32; 4]]| {
        a.iter()
            .zip(b)
            .flat_map(|(x, y)| (0..4).map(move |k| (x[k] - y[k]).abs()))
            .fold(0.0f32, f32::max)
    };
    let d_accum = max_diff(&accum, &cpu_accum) / peak;
    let d_result = max_diff(&result, &cpu_result) / peak;
    let d_widest = max_diff(&widest, &cpu_widest) / peak;
    eprintln!(
        "GPU vs CPU mirror, max |diff| / peak ({peak:.3}): accum {d_accum:.2e}, padded {d_result:.2e}, widest {d_widest:.2e}"
    );
    assert!(d_accum < GPU_VS_CPU_MAX, "accum {d_accum}");
    assert!(d_result < GPU_VS_CPU_MAX, "padded result {d_result}");
    assert!(d_widest < GPU_VS_CPU_MAX, "widest {d_widest}");
    // The blur really blurs: the points lose most of their peak.
    let i = 7 * size as usize + 22;
    assert!(e[i][0] == 4.0 && accum[i][0] < 2.5, "{:?}", accum[i]);
}

/// The exact texture-space diffusion of one covered map with constant stretch: the
/// irradiance convolved with sum_k w_k G(v_k - v_0) (the narrowest Gaussian is the map
/// itself), evaluated by brute force in f64.
fn exact_convolution(
    size: u32,
    e: &[[f32; 4]],
    mm: [f32; 2],
    profile: &SumOfGaussians,
) -> Vec<[f32; 3]> {
    let n = size as i64;
    let terms = profile.terms();
    let total = profile.total_weight();
    let v0 = terms[0].variance;
    let reach = 12i64;
    let mut out = vec![[0.0f32; 3]; (n * n) as usize];
    for y in 0..n {
        for x in 0..n {
            let mut acc = [0.0f64; 3];
            for t in terms {
                let v = t.variance - v0;
                if v <= 0.0 {
                    let c = e[(y * n + x) as usize];
                    for k in 0..3 {
                        acc[k] += t.weight[k] / total[k] * c[k] as f64;
                    }
                    continue;
                }
                let mut sum = [0.0f64; 3];
                let mut wsum = 0.0;
                for dy in -reach..=reach {
                    for dx in -reach..=reach {
                        let (qx, qy) = ((x + dx).clamp(0, n - 1), (y + dy).clamp(0, n - 1));
                        let r = ((dx as f64 * mm[0] as f64).powi(2)
                            + (dy as f64 * mm[1] as f64).powi(2))
                        .sqrt();
                        let g = gaussian(v, r);
                        let c = e[(qy * n + qx) as usize];
                        for k in 0..3 {
                            sum[k] += g * c[k] as f64;
                        }
                        wsum += g;
                    }
                }
                for k in 0..3 {
                    acc[k] += t.weight[k] / total[k] * sum[k] / wsum;
                }
            }
            out[(y * n + x) as usize] = acc.map(|v| v as f32);
        }
    }
    out
}

/// Largest error of the 7-tap cascade against the exact convolution, relative to the peak,
/// for a smooth-edged spot of light (a 3 mm disc) on a fully covered map.
const EXACT_MAX: f32 = 0.05;

#[test]
fn blur_approximates_the_exact_sum_of_gaussians() {
    let Some(ctx) = context() else { return };
    let size = 64;
    let mm = [0.25f32, 0.25];
    let n = size as usize;
    let mut e = vec![[0.0f32, 0.0, 0.0, 1.0]; n * n];
    for y in 0..n {
        for x in 0..n {
            let r =
                (((x as f32 - 31.5) * mm[0]).powi(2) + ((y as f32 - 31.5) * mm[1]).powi(2)).sqrt();
            let v = (1.0 - (r - 1.5).max(0.0) / 0.5).clamp(0.0, 1.0);
            e[y * n + x] = [v, v, v, 1.0];
        }
    }
    let s = vec![mm; n * n];
    let profile = SumOfGaussians::skin();
    let kernel = BlurKernel::from_profile(&profile);
    let (accum, _, _) = gpu_blur(&ctx, size, &e, &s, &kernel, 0);
    let exact = exact_convolution(size, &e, mm, &profile);
    let mut worst = 0.0f32;
    for (a, x) in accum.iter().zip(&exact) {
        for k in 0..3 {
            worst = worst.max((a[k] - x[k]).abs());
        }
    }
    eprintln!("7-tap cascade vs exact sum of Gaussians: max |diff| {worst:.4} of peak 1.0");
    assert!(worst < EXACT_MAX, "{worst}");
}

fn texture_options(scene: &Scene, padding: u32) -> RenderOptions {
    let mut opts = options(scene, 256, 256);
    opts.settings.sss.method = SssMethod::Texture;
    opts.settings.sss.texture_padding = padding;
    opts
}

#[test]
fn head_texture_matches_reference() {
    let Some(ctx) = context() else { return };
    let Some(scene) = head_scene() else { return };
    let mut r = Renderer::new(&ctx, &scene, texture_options(&scene, 4)).unwrap();
    let frame = r.render().unwrap();
    let timings: Vec<String> = frame
        .timings
        .iter()
        .map(|t| format!("{} {:.2} ms", t.name, t.ms))
        .collect();
    eprintln!(
        "head --sss texture 256x256, 1024^2 maps: {}",
        timings.join(", ")
    );
    flip_against_reference("head-texture", &frame.image, 0.02, 0.1);
    let mut opts = texture_options(&scene, 4);
    opts.settings.transmittance.method = TransmittanceMethod::Tsm;
    let mut r = Renderer::new(&ctx, &scene, opts).unwrap();
    let frame = r.render().unwrap();
    flip_against_reference("head-texture-tsm", &frame.image, 0.02, 0.1);
}

/// Seam darkness on the head, measured where the lighting pass reads the blurred map. For
/// each covered texel at an island border (an empty texel beside it), the bilinear value
/// halfway towards the empty neighbour (what a fragment at the island's edge reads) is divided
/// by the unblurred irradiance of that border texel; the same ratio (blurred / unblurred) is
/// taken at every interior texel. Real lighting gradients change both alike; a dark seam line
/// (black read at the border, or black pulled in by the blur) makes the border ratios smaller
/// (about half without padding). Bound: the border ratios' 1st percentile is at least
/// `SEAM_P1_MIN` times the interior ratios' 1st percentile, and their median at least
/// `SEAM_MEDIAN_MIN` times the interior median.
const SEAM_P1_MIN: f32 = 0.9;
const SEAM_MEDIAN_MIN: f32 = 0.95;

/// (border ratios, interior ratios), sorted.
fn seam_ratios(blurred: &[[f32; 4]], irradiance: &[[f32; 4]], size: usize) -> (Vec<f32>, Vec<f32>) {
    let lum = |c: [f32; 4]| 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
    let n = size as i64;
    let covered = |x: i64, y: i64| {
        x >= 0 && y >= 0 && x < n && y < n && irradiance[(y * n + x) as usize][3] > 0.5
    };
    let i = |x: i64, y: i64| (y * n + x) as usize;
    let (mut border, mut interior) = (Vec::new(), Vec::new());
    for y in 0..n {
        for x in 0..n {
            if !covered(x, y) {
                continue;
            }
            let irr = lum(irradiance[i(x, y)]);
            if irr < 1e-4 {
                continue;
            }
            let mut on_border = false;
            for (dx, dy) in [(1i64, 0i64), (-1, 0), (0, 1), (0, -1)] {
                let (ox, oy) = (x + dx, y + dy);
                if ox < 0 || oy < 0 || ox >= n || oy >= n || covered(ox, oy) {
                    continue;
                }
                on_border = true;
                let edge = 0.5 * (lum(blurred[i(x, y)]) + lum(blurred[i(ox, oy)]));
                border.push(edge / irr);
            }
            if !on_border {
                interior.push(lum(blurred[i(x, y)]) / irr);
            }
        }
    }
    border.sort_by(f32::total_cmp);
    interior.sort_by(f32::total_cmp);
    (border, interior)
}

fn quantile(v: &[f32], q: f32) -> f32 {
    v[((v.len() - 1) as f32 * q) as usize]
}

#[test]
fn head_seams_are_not_dark() {
    let Some(ctx) = context() else { return };
    let Some(scene) = head_scene() else { return };
    let measure = |padding: u32| {
        let mut opts = texture_options(&scene, padding);
        opts.settings.sss.texture_size = 512;
        // The seams alone: light through the ear (the back light) changes faster across a
        // texel than anything the blur does and would stand in the border statistics.
        opts.settings.transmittance.method = TransmittanceMethod::Off;
        let mut r = Renderer::new(&ctx, &scene, opts).unwrap();
        r.render().unwrap();
        let (irradiance, _, blurred) = r.texture_space_maps(0).unwrap();
        let irradiance = read4(&ctx, irradiance);
        let result = read4(&ctx, &blurred.result);
        let (border, interior) = seam_ratios(&result, &irradiance, 512);
        let p1 = quantile(&border, 0.01) / quantile(&interior, 0.01);
        let median = quantile(&border, 0.5) / quantile(&interior, 0.5);
        eprintln!(
            "padding {padding}: {} border samples, blurred/unblurred 1st percentile {:.3} (interior {:.3}), median {:.3} (interior {:.3}); border/interior: p1 {p1:.3}, median {median:.3}",
            border.len(),
            quantile(&border, 0.01),
            quantile(&interior, 0.01),
            quantile(&border, 0.5),
            quantile(&interior, 0.5),
        );
        (p1, median)
    };
    let (p1, median) = measure(4);
    assert!(
        p1 >= SEAM_P1_MIN && median >= SEAM_MEDIAN_MIN,
        "p1 {p1}, median {median}"
    );
    // Without padding the seams do read half black: the measure sees them.
    let (p1, median) = measure(0);
    assert!(
        p1 < 0.7 && median < 0.7,
        "unpadded: p1 {p1}, median {median}"
    );
}

/// A 4 mm skin sphere seen from 3 cm, lit by one shadowed directional light from `light`
/// (towards the origin), no ambient light.
fn small_sphere(light: [f32; 3]) -> Scene {
    white_object_scene(
        &camera_toml(0.03, 20.0, "near = 0.005\nfar = 1.0"),
        light,
        512,
        r#"{ shape = "sphere", radius = 0.002, segments = 64 }"#,
        "skin",
    )
}

/// TSM: a small sphere (4 mm across) lit from behind transmits the back side's blurred
/// irradiance; lit from the front, TSM adds nothing where the light sees the surface.
#[test]
fn tsm_transmits_through_a_backlit_sphere() {
    let Some(ctx) = context() else { return };
    let scene_with_light = |z: f32| small_sphere([0.0, 0.0, z]);
    let render = |scene: &Scene, method: TransmittanceMethod| {
        let mut opts = options(scene, 64, 64);
        opts.settings.sss.method = SssMethod::Texture;
        opts.settings.sss.texture_size = 256;
        opts.settings.transmittance.method = method;
        let mut r = Renderer::new(&ctx, scene, opts).unwrap();
        r.render().unwrap();
        r.read_diffuse().unwrap()
    };
    let back = scene_with_light(-1.0);
    let tsm = render(&back, TransmittanceMethod::Tsm);
    let paper = render(&back, TransmittanceMethod::Paper);
    let off = render(&back, TransmittanceMethod::Off);
    let row = 32 * 64;
    let xs = [32usize, 36, 40, 42];
    let red = |d: &[[f32; 4]]| xs.iter().map(|&x| d[row + x][0]).collect::<Vec<f32>>();
    let (t, p, o) = (red(&tsm), red(&paper), red(&off));
    eprintln!("backlit sphere, red from the centre out: tsm {t:?}, paper {p:?}, off {o:?}");
    assert!(t.iter().zip(&o).all(|(t, o)| t >= o), "{t:?} vs {o:?}");
    assert!(
        t.iter().zip(&o).any(|(t, o)| *t > o + 1e-3),
        "{t:?} vs {o:?}"
    );
    // Red goes through more than blue (the profile's T(s)).
    let blue = tsm[row + 36][2];
    assert!(t[1] > blue, "red {} vs blue {blue}", t[1]);

    let front = scene_with_light(1.0);
    let tsm = render(&front, TransmittanceMethod::Tsm);
    let off = render(&front, TransmittanceMethod::Off);
    let c = row + 32;
    eprintln!("front-lit centre: tsm {:?}, off {:?}", tsm[c], off[c]);
    assert!((tsm[c][0] - off[c][0]).abs() <= 1e-3 * off[c][0].max(1e-3));
}

/// The irradiance debug view with texture-space diffusion shows the UV-space irradiance map
/// itself, as the largest centred square (black bars beside it), texel for texel where the
/// map is lit.
#[test]
fn irradiance_view_shows_the_uv_map() {
    let Some(ctx) = context() else { return };
    let scene = small_sphere([1.0, 0.5, 1.0]);
    let (w, h, size) = (128u32, 64u32, 64u32);
    let mut opts = options(&scene, w, h);
    opts.view = subsurface_render::DebugView::Irradiance;
    opts.settings.sss.method = SssMethod::Texture;
    opts.settings.sss.texture_size = size;
    let mut r = Renderer::new(&ctx, &scene, opts).unwrap();
    let image = r.render().unwrap().image;
    let map = read4(&ctx, r.texture_space_maps(0).unwrap().0);
    let (mut lit, mut agree, mut n) = (0, 0, 0);
    for y in 0..h {
        for x in 0..w {
            let p = image.get_pixel(x, y).0;
            let bright = p[0] as u32 + p[1] as u32 + p[2] as u32;
            if !(32..96).contains(&x) {
                assert_eq!(bright, 0, "letterbox bar at ({x}, {y}): {p:?}");
                continue;
            }
            let t = map[(y * size + (x - 32)) as usize];
            // Texels too dim to survive 8 bits are left out.
            if t[0] > 0.0 && t[0] < 0.02 {
                continue;
            }
            let map_lit = t[0] > 0.0;
            lit += map_lit as u32;
            agree += ((bright > 0) == map_lit) as u32;
            n += 1;
        }
    }
    assert!(lit > n / 8, "too little of the map is lit: {lit} of {n}");
    assert_eq!(agree, n, "image and map disagree on {} texels", n - agree);
}

/// A skin object without UVs (a glTF without TEXCOORD_0 has every uv at the origin) cannot be
/// laid out in texture space: it rendered black with exit 0. Both texture-space methods are
/// now an error naming the object, from `Renderer::new` and from `Renderer::update` (the
/// viewer switching the method on), and the renderer keeps working after the refused update.
#[test]
fn texture_space_needs_uvs() {
    let Some(ctx) = context() else { return };
    let mut scene = small_sphere([0.0, 0.0, 1.0]);
    for v in &mut scene.objects[0].mesh.vertices {
        v.uv = [0.0, 0.0];
    }
    let base = options(&scene, 32, 32);
    let with = |sss: SssMethod, t: TransmittanceMethod| {
        let mut o = base.clone();
        o.settings.sss.method = sss;
        o.settings.sss.texture_size = 64;
        o.settings.transmittance.method = t;
        o
    };
    let expected = "objects[0].mesh: object0 has no texture coordinates";
    for (sss, t) in [
        (SssMethod::Texture, TransmittanceMethod::Paper),
        (SssMethod::Separable, TransmittanceMethod::Tsm),
    ] {
        let e = Renderer::new(&ctx, &scene, with(sss, t))
            .err()
            .unwrap()
            .to_string();
        assert!(e.starts_with(expected), "{e}");
    }
    let screen = with(SssMethod::Separable, TransmittanceMethod::Paper);
    let mut r = Renderer::new(&ctx, &scene, screen.clone()).unwrap();
    let e = r
        .update(
            &scene,
            &with(SssMethod::Texture, TransmittanceMethod::Paper),
        )
        .unwrap_err()
        .to_string();
    assert!(e.starts_with(expected), "{e}");
    r.update(&scene, &screen).unwrap();
    r.render().unwrap();
    // Non-skin objects need no maps, so no UVs either.
    scene.edit_materials(|m| m.sss_strength = 0.0);
    Renderer::new(
        &ctx,
        &scene,
        with(SssMethod::Texture, TransmittanceMethod::Tsm),
    )
    .unwrap();
}
