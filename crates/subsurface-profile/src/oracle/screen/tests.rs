//! Unit tests of the screen-space oracles: conventions, energy, edges, per-pixel profiles.

use super::*;
use crate::kernel::KernelParams;

const PARAMS: ScreenParams = ScreenParams {
    focal_px: 40.0,
    follow_surface: true,
    edge_mm: 1.0,
};

fn skin() -> Vec<ScreenKernels> {
    vec![ScreenKernels::skin(&KernelParams::default()).unwrap()]
}

type Method = fn(&ScreenInput) -> Vec<[f32; 3]>;

fn methods() -> [(&'static str, Method); 3] {
    [
        ("separable", |i| separable(i, &skin(), &PARAMS).unwrap()),
        ("gaussian6", |i| {
            gaussian6(i, &skin(), [true; 5], &PARAMS, 0.0).unwrap()
        }),
        ("hable13", |i| hable13(i, &skin(), &PARAMS).unwrap()),
    ]
}

/// `result` is an error whose message starts with `field` (the offending input's name).
fn assert_error_names(result: Result<Vec<[f32; 3]>>, field: &str) {
    let e = result.unwrap_err().to_string();
    assert!(e.starts_with(field), "{e}");
}

fn sum(img: &[[f32; 3]]) -> [f64; 3] {
    let mut s = [0.0; 3];
    for p in img {
        for k in 0..3 {
            s[k] += p[k] as f64;
        }
    }
    s
}

#[test]
fn sampling_conventions() {
    let img = [[0.0, 0.0, 0.0], [1.0, 2.0, 4.0]];
    // Between the two texel centres: the average.
    assert_eq!(sample_bilinear(&img, 2, 1, [1.0, 0.5]), [0.5, 1.0, 2.0]);
    // At a texel centre: that texel exactly.
    assert_eq!(sample_bilinear(&img, 2, 1, [1.5, 0.5]), [1.0, 2.0, 4.0]);
    // Left of the first centre and far outside: clamped.
    assert_eq!(sample_bilinear(&img, 2, 1, [0.2, -7.0]), [0.0; 3]);
    assert_eq!(sample_bilinear(&img, 2, 1, [9.0, 3.0]), [1.0, 2.0, 4.0]);
    assert_eq!(nearest_index(2, 1, [0.99, 0.5]), 0);
    assert_eq!(nearest_index(2, 1, [1.0, 0.5]), 1);
    assert_eq!(nearest_index(2, 1, [-3.0, 9.0]), 0);
    assert_eq!(nearest_index(2, 1, [f32::NAN, f32::NAN]), 0);
}

#[test]
fn constant_image_stays_constant_everywhere() {
    let color = [0.7, 0.4, 0.2];
    let input = ScreenInput::uniform(24, 20, color, 1.5, 1.0, 2.0);
    for (name, run) in methods() {
        for (i, p) in run(&input).iter().enumerate() {
            for k in 0..3 {
                assert!((p[k] - color[k]).abs() < 1e-5, "{name}: pixel {i} {p:?}");
            }
        }
    }
}

#[test]
fn impulse_energy_is_preserved_and_spread() {
    // A uniform surface makes every pass a convolution, so the total is kept.
    // px_per_mm = 0.05 * 40 = 2: the widest skin Gaussian (sigma 2.7 mm) is
    // 5.4 px, so 32 px to the border keeps the clamp-to-edge out of play.
    let mut input = ScreenInput::uniform(64, 64, [0.0; 3], 1.0, 1.0, 0.05);
    let centre = 32 * 64 + 32;
    input.color[centre] = [100.0, 100.0, 100.0];
    for (name, run) in methods() {
        let out = run(&input);
        let s = sum(&out);
        for k in 0..3 {
            assert!(
                (s[k] - 100.0).abs() < 1e-3,
                "{name}: channel {k} sums to {}",
                s[k]
            );
        }
        assert!(out[centre][0] < 99.0, "{name} did not blur");
    }
}

#[test]
fn gaussian6_red_spreads_widest() {
    let mut input = ScreenInput::uniform(64, 64, [0.0; 3], 1.0, 1.0, 0.1);
    input.color[32 * 64 + 32] = [1.0; 3];
    let out = gaussian6(&input, &skin(), [true; 5], &PARAMS, 0.0).unwrap();
    let mut m2 = [0.0f64; 3];
    for (i, p) in out.iter().enumerate() {
        let (dx, dy) = ((i % 64) as f64 - 32.0, (i / 64) as f64 - 32.0);
        for k in 0..3 {
            m2[k] += p[k] as f64 * (dx * dx + dy * dy);
        }
    }
    assert!(m2[0] > 2.0 * m2[1] && m2[1] > m2[2], "{m2:?}");
    // Per axis, the profile's variance is sum_k w_k (v_k - v_0) px^2, up to
    // the 7-tap kernel's own variance (1.08 sigma^2) and bilinear spreading.
    let ppm = 0.1 * 40.0;
    let skin = crate::SumOfGaussians::skin();
    let v0 = skin.terms()[0].variance;
    let expect: f64 = skin
        .terms()
        .iter()
        .map(|t| t.weight[0] * (t.variance - v0))
        .sum::<f64>()
        * ppm
        * ppm;
    let got = m2[0] / 2.0;
    assert!(
        (got / expect - 1.0).abs() < 0.2,
        "red variance {got} vs {expect}"
    );
}

#[test]
fn separable_pass_hand_computed() {
    // N = 3: offsets 0, -2, +2 mm. px_per_mm = 1 * 3 / 2 * m.
    let table = vec![
        ScreenKernels::skin(&KernelParams {
            samples: 3,
            strength: [1.0; 3],
            falloff: [1.0; 3],
        })
        .unwrap(),
    ];
    let k = table[0].separable.clone();
    let w = 9;
    let mut input = ScreenInput::uniform(w, 1, [0.0; 3], 2.0, 1.0, 1.0);
    for x in 0..w as usize {
        input.color[x] = [x as f32, (x * x) as f32, 1.0];
    }
    let params = ScreenParams {
        focal_px: 3.0,
        follow_surface: false,
        edge_mm: 1.0,
    };
    // m = 1: taps at exactly +-3 px land on texel centres.
    let out = separable_pass(&input, &table, [1.0, 0.0], &params).unwrap();
    let x = 4usize;
    let c = |i: usize| input.color[i];
    for ch in 0..3 {
        let want = k[0][ch] * c(x)[ch] + k[1][ch] * c(x - 3)[ch] + k[2][ch] * c(x + 3)[ch];
        assert!(
            (out[x][ch] - want).abs() < 1e-5,
            "ch {ch}: {} vs {want}",
            out[x][ch]
        );
    }
    // m = 0.5 halves the footprint: taps at +-1.5 px average two texels.
    input.strength = vec![0.5; w as usize];
    let out = separable_pass(&input, &table, [1.0, 0.0], &params).unwrap();
    let mid = |a: usize, b: usize, ch: usize| 0.5 * (c(a)[ch] + c(b)[ch]);
    for ch in 0..3 {
        let want = k[0][ch] * c(x)[ch] + k[1][ch] * mid(2, 3, ch) + k[2][ch] * mid(5, 6, ch);
        assert!(
            (out[x][ch] - want).abs() < 1e-5,
            "ch {ch}: {} vs {want}",
            out[x][ch]
        );
    }
}

/// Left half: skin colour A at depth 1. Right half: colour B at depth
/// `right_depth` with `right_strength`.
fn split(right_depth: f32, right_strength: f32) -> ScreenInput {
    let (w, h) = (32u32, 8u32);
    let mut input = ScreenInput::uniform(w, h, [1.0, 0.5, 0.25], 1.0, 1.0, 0.1);
    for y in 0..h as usize {
        for x in 16..w as usize {
            let i = y * w as usize + x;
            input.color[i] = [0.0, 10.0, 20.0];
            input.depth[i] = right_depth;
            input.strength[i] = right_strength;
        }
    }
    input
}

/// Largest fraction of the way from A to B among left-half pixels.
fn worst_leak(input: &ScreenInput, out: &[[f32; 3]]) -> f32 {
    let (a, b) = ([1.0f32, 0.5, 0.25], [0.0f32, 10.0, 20.0]);
    let mut worst = 0.0f32;
    for (i, p) in out.iter().enumerate() {
        if (i % input.width as usize) < 16 {
            worst = worst.max((p[2] - a[2]) / (b[2] - a[2]));
        }
    }
    worst
}

#[test]
fn depth_edges_are_not_crossed() {
    let far = split(10.0, 1.0);
    let mut flat_params = PARAMS;
    flat_params.follow_surface = false;
    type WithParams = fn(&ScreenInput, &ScreenParams) -> Vec<[f32; 3]>;
    let runs: [(&str, WithParams); 3] = [
        ("separable", |i, p| separable(i, &skin(), p).unwrap()),
        ("gaussian6", |i, p| {
            gaussian6(i, &skin(), [true; 5], p, 0.0).unwrap()
        }),
        ("hable13", |i, p| hable13(i, &skin(), p).unwrap()),
    ];
    for (name, run) in runs {
        let leak_off = worst_leak(&far, &run(&far, &flat_params));
        let leak_on = worst_leak(&far, &run(&far, &PARAMS));
        // Without correction the far surface bleeds in heavily; with it only
        // the half-texel linear-filtering footprint at the edge remains.
        assert!(leak_off > 0.03, "{name}: {leak_off}");
        assert!(leak_on < 0.2 * leak_off, "{name}: {leak_on} vs {leak_off}");
        // And the near side does not reach the far side's interior: right
        // pixels more than 1 px from the edge see only B.
        let out = run(&far, &PARAMS);
        for (i, p) in out.iter().enumerate() {
            if (i % 32) >= 18 {
                assert!((p[2] - 20.0).abs() < 1e-4, "{name}: pixel {i} {p:?}");
            }
        }
    }
}

#[test]
fn background_is_copied_and_does_not_bleed() {
    let input = split(1.0, 0.0);
    for (name, run) in methods() {
        let out = run(&input);
        for (i, p) in out.iter().enumerate() {
            if input.strength[i] == 0.0 {
                assert_eq!(
                    p.map(f32::to_bits),
                    input.color[i].map(f32::to_bits),
                    "{name}"
                );
            }
        }
        let leak = worst_leak(&input, &out);
        // Same depth and follow_surface on: only the strength mask stops B,
        // again up to the half-texel filtering footprint.
        assert!(leak < 0.02, "{name}: {leak}");
    }
}

#[test]
fn sub_pixel_gaussians_are_skipped() {
    let mut input = ScreenInput::uniform(16, 16, [0.0; 3], 1.0, 1.0, 0.1);
    input.color[8 * 16 + 8] = [1.0; 3];
    let skin = skin();
    let out = gaussian6(&input, &skin, [true; 5], &PARAMS, 1e6).unwrap();
    for (a, b) in out.iter().zip(&input.color) {
        for k in 0..3 {
            assert!((a[k] - b[k]).abs() < 1e-6);
        }
    }
    // px_per_mm = 4 here: sigma_px of the first step is sqrt(0.0484 - 0.0064) * 4 = 0.82,
    // of the second 2.0; a threshold of 1 px keeps only the wider steps.
    let all = gaussian6(&input, &skin, [true; 5], &PARAMS, 0.0).unwrap();
    let some = gaussian6(&input, &skin, [true; 5], &PARAMS, 1.0).unwrap();
    assert!(all[8 * 16 + 8][2] < some[8 * 16 + 8][2]);
}

#[test]
fn bad_inputs_are_errors_not_panics() {
    let mut input = ScreenInput::uniform(4, 4, [1.0; 3], 1.0, 1.0, 1.0);
    let k = skin();
    input.depth.pop();
    let e = separable(&input, &k, &PARAMS).unwrap_err().to_string();
    assert_eq!(e, "depth: expected length 16 (got 15)");
    let mut input = ScreenInput::uniform(4, 4, [1.0; 3], 1.0, 1.0, 1.0);
    input.depth[5] = 0.0;
    assert_error_names(hable13(&input, &k, &PARAMS), "depth[5]: ");
    input.depth[5] = 1.0;
    input.strength[3] = 1.5;
    assert_error_names(
        gaussian6(&input, &skin(), [true; 5], &PARAMS, 0.0),
        "strength[3]: ",
    );
    input.strength[3] = 1.0;
    let bad = ScreenParams {
        focal_px: -1.0,
        ..PARAMS
    };
    assert_error_names(hable13(&input, &k, &bad), "focal_px: ");
    let bad = ScreenParams {
        edge_mm: f32::NAN,
        ..PARAMS
    };
    assert_error_names(hable13(&input, &k, &bad), "edge_mm: ");
    assert_error_names(separable(&input, &[], &PARAMS), "kernels: ");
    // Background pixels may carry any depth (e.g. 0 or infinity).
    input.strength[0] = 0.0;
    input.depth[0] = f32::INFINITY;
    assert!(separable(&input, &k, &PARAMS).is_ok());
    // A pixel naming a profile the table does not have.
    input.profile[2] = 1;
    assert_error_names(separable(&input, &k, &PARAMS), "profile[2]: ");
}

/// Two materials side by side at the same depth: each half is blurred with its own
/// profile, and a constant colour stays constant right up to the boundary (no tap takes
/// the other material's colour).
#[test]
fn profiles_do_not_mix_across_a_material_boundary() {
    let (w, h) = (48u32, 8u32);
    let mut input = ScreenInput::uniform(w, h, [1.0, 0.5, 0.25], 1.0, 1.0, 0.1);
    for i in 0..(w * h) as usize {
        if i % w as usize >= 24 {
            input.color[i] = [0.2, 0.9, 0.6];
            input.profile[i] = 1;
        }
    }
    let wide = crate::gaussian::widened_skin(9.0);
    let mut table = skin();
    table.push(ScreenKernels::for_profile(&wide, &KernelParams::default()).unwrap());
    for (name, out) in [
        ("separable", separable(&input, &table, &PARAMS).unwrap()),
        (
            "gaussian6",
            gaussian6(&input, &table, [true; 5], &PARAMS, 0.0).unwrap(),
        ),
        ("hable13", hable13(&input, &table, &PARAMS).unwrap()),
    ] {
        for (o, c) in out.iter().zip(&input.color) {
            for k in 0..3 {
                assert!((o[k] - c[k]).abs() < 1e-5, "{name}: {o:?} vs {c:?}");
            }
        }
    }
    // With an impulse on each side, the wider profile spreads its light further: 11 to 15
    // px (2.75 to 3.75 mm) from the impulse only the right half's kernel (3x as wide) reaches.
    let mut input = ScreenInput::uniform(w, h, [0.0; 3], 1.0, 1.0, 0.1);
    for i in 0..(w * h) as usize {
        input.profile[i] = (i % w as usize >= 24) as u32;
    }
    input.color[4 * w as usize + 8] = [1.0; 3];
    input.color[4 * w as usize + 32] = [1.0; 3];
    let out = separable(&input, &table, &PARAMS).unwrap();
    let row = 4 * w as usize;
    let red = |from: usize| (from..from + 4).map(|x| out[row + x][0]).sum::<f32>();
    assert_eq!(red(19), 0.0);
    assert!(red(43) > 1e-4, "{:?}", &out[row + 43..row + 47]);
}

fn jittered7() -> (Vec<ScreenKernels>, Method) {
    let table = vec![
        ScreenKernels::skin(&KernelParams {
            samples: 7,
            ..Default::default()
        })
        .unwrap(),
    ];
    (table, |i| {
        let table = jittered7().0;
        separable_jittered(i, &table, &PARAMS).unwrap()
    })
}

#[test]
fn jitter_widths_are_a_quarter_of_each_footprint() {
    let kernel = &jittered7().0[0].separable;
    // Offsets of 7 taps over 2 mm: 0, -2, -8/9, -2/9, 2/9, 8/9, 2.
    let widths = crate::kernel::separable_jitter_widths(kernel);
    let want = [0.0, 0.25 * 10.0 / 9.0, 0.25 * 16.0 / 9.0, 0.25 * 8.0 / 9.0];
    for (i, w) in want.iter().enumerate() {
        assert!((widths[i] - w).abs() < 1e-6, "tap {i}: {}", widths[i]);
    }
    assert_eq!(widths[1], widths[6]);
    assert_eq!(widths[3], widths[4]);
    // No jittered tap crosses the centre to the other side of the kernel.
    for (t, w) in kernel.iter().zip(&widths).skip(1) {
        assert!(t[3].abs() - w >= -1e-6, "{t:?} +- {w}");
    }
}

#[test]
fn jitter_values_are_uniform_and_differ_per_pass_and_tap() {
    let mut hist = [0u32; 10];
    for y in 0..100 {
        for x in 0..100 {
            let v = jitter_value(jitter_seed(x, y, 0), 1);
            assert!((0.0..1.0).contains(&v));
            hist[(v * 10.0) as usize] += 1;
        }
    }
    // 1000 per bin expected; 4 standard deviations is about 120.
    assert!(hist.iter().all(|&n| n.abs_diff(1000) < 130), "{hist:?}");
    let v = |x, y, pass, tap| jitter_value(jitter_seed(x, y, pass), tap);
    assert_ne!(v(3, 4, 0, 1), v(3, 4, 1, 1));
    assert_ne!(v(3, 4, 0, 1), v(3, 4, 0, 2));
    assert_ne!(v(3, 4, 0, 1), v(4, 3, 0, 1));
}

#[test]
fn jittered_separable_keeps_flat_colour_and_background() {
    let (_, run) = jittered7();
    let color = [0.7, 0.4, 0.2];
    let input = ScreenInput::uniform(24, 20, color, 1.5, 1.0, 2.0);
    for p in run(&input) {
        for k in 0..3 {
            assert!((p[k] - color[k]).abs() < 1e-5, "{p:?}");
        }
    }
    let input = split(1.0, 0.0);
    let out = run(&input);
    for (i, p) in out.iter().enumerate() {
        if input.strength[i] == 0.0 {
            assert_eq!(p.map(f32::to_bits), input.color[i].map(f32::to_bits));
        }
    }
    assert!(worst_leak(&input, &out) < 0.02);
}

/// A gather with per-pixel positions is not a convolution, so an impulse's total is kept
/// only on average: one impulse is off by up to ~8 % (the few pixels that gather from it each
/// draw their own positions), 64 impulses 16 px apart (kernel +-4 px) by well under 2 %.
#[test]
fn jittered_impulse_energy_is_kept_on_average() {
    let (_, run) = jittered7();
    let mut input = ScreenInput::uniform(128, 128, [0.0; 3], 1.0, 1.0, 0.05);
    for y in 0..8 {
        for x in 0..8 {
            input.color[(16 * y + 8) * 128 + 16 * x + 8] = [100.0; 3];
        }
    }
    let out = run(&input);
    for (k, s) in sum(&out).iter().enumerate() {
        assert!((s / 6400.0 - 1.0).abs() < 0.02, "channel {k} sums to {s}");
    }
    assert!(out[8 * 128 + 8][0] < 99.0, "did not blur");
}
