//! LDR-FLIP (Andersson et al. 2020, "FLIP: A Difference Evaluator for Alternating Images"),
//! following NVIDIA's reference implementation: CSF-filtered YCxCz colour difference
//! (Hunt-adjusted HyAB), edge and point feature differences, default 67.02 pixels per degree.
//! Implemented here (the nv-flip crate is only a dev-dependency); tests/fidelity.rs checks it
//! against nv-flip.
const QC: f32 = 0.7;
const QF: f32 = 0.5;
const PC: f32 = 0.4;
const PT: f32 = 0.95;
const GW: f32 = 0.082;
pub const PPD: f32 = 67.02;

const RGB2XYZ: [[f32; 3]; 3] = [
    [0.412_390_8, 0.357_584_33, 0.180_480_8],
    [0.212_639, 0.715_168_65, 0.072_192_32],
    [0.019_330_818, 0.119_194_78, 0.950_532_15],
];
const XYZ2RGB: [[f32; 3]; 3] = [
    [3.240_97, -1.537_383_2, -0.498_610_76],
    [-0.969_243_6, 1.875_967_5, 0.041_555_06],
    [0.055_630_08, -0.203_976_96, 1.056_971_5],
];

fn mul(m: &[[f32; 3]; 3], v: [f32; 3]) -> [f32; 3] {
    std::array::from_fn(|i| m[i][0] * v[0] + m[i][1] * v[1] + m[i][2] * v[2])
}

fn white() -> [f32; 3] {
    mul(&RGB2XYZ, [1.0; 3])
}

fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

fn xyz_to_ycxcz(x: [f32; 3]) -> [f32; 3] {
    let w = white();
    let (xx, yy, zz) = (x[0] / w[0], x[1] / w[1], x[2] / w[2]);
    [116.0 * yy - 16.0, 500.0 * (xx - yy), 200.0 * (yy - zz)]
}

fn ycxcz_to_xyz(c: [f32; 3]) -> [f32; 3] {
    let w = white();
    let yy = (c[0] + 16.0) / 116.0;
    [
        (c[1] / 500.0 + yy) * w[0],
        yy * w[1],
        (yy - c[2] / 200.0) * w[2],
    ]
}

fn xyz_to_lab(x: [f32; 3]) -> [f32; 3] {
    let w = white();
    let d = 6.0f32 / 29.0;
    let f = |t: f32| {
        if t > d * d * d {
            t.cbrt()
        } else {
            t / (3.0 * d * d) + 4.0 / 29.0
        }
    };
    let (fx, fy, fz) = (f(x[0] / w[0]), f(x[1] / w[1]), f(x[2] / w[2]));
    [116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)]
}

fn hunt(lab: [f32; 3]) -> [f32; 3] {
    [lab[0], 0.01 * lab[0] * lab[1], 0.01 * lab[0] * lab[2]]
}

fn hyab(a: [f32; 3], b: [f32; 3]) -> f32 {
    (a[0] - b[0]).abs() + ((a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// Separable convolution of one channel with clamped borders.
fn convolve(src: &[f32], w: usize, h: usize, kx: &[f32], ky: &[f32]) -> Vec<f32> {
    let (rx, ry) = (kx.len() / 2, ky.len() / 2);
    let rows = convolve_1d(src, w, h, kx, |x, y, i| {
        y * w + (x + i).saturating_sub(rx).min(w - 1)
    });
    convolve_1d(&rows, w, h, ky, |x, y, i| {
        (y + i).saturating_sub(ry).min(h - 1) * w + x
    })
}

/// One pass of [`convolve`]: pixel (x, y) is the sum of `k[i] * src[tap(x, y, i)]`.
fn convolve_1d(
    src: &[f32],
    w: usize,
    h: usize,
    k: &[f32],
    tap: impl Fn(usize, usize, usize) -> usize,
) -> Vec<f32> {
    let mut out = vec![0.0; w * h];
    for y in 0..h {
        for x in 0..w {
            let mut s = 0.0;
            for (i, k) in k.iter().enumerate() {
                s += k * src[tap(x, y, i)];
            }
            out[y * w + x] = s;
        }
    }
    out
}

/// The contrast sensitivity functions as sums of two Gaussians per YCxCz channel
/// (a1, b1, a2, b2), evaluated on the pixel grid and normalised to sum 1.
const CSF: [[f32; 4]; 3] = [
    [1.0, 0.0047, 0.0, 1e-5],
    [1.0, 0.0053, 0.0, 1e-5],
    [34.1, 0.04, 13.5, 0.025],
];

/// Filters the YCxCz channels (planar) with the CSF.
fn csf_filter(ycxcz: &[Vec<f32>; 3], w: usize, h: usize) -> [Vec<f32>; 3] {
    let radius =
        (3.0 * (0.04f32 / (2.0 * std::f32::consts::PI.powi(2))).sqrt() * PPD).ceil() as i32;
    let dx = 1.0 / PPD;
    let pi = std::f32::consts::PI;
    std::array::from_fn(|c| {
        let [a1, b1, a2, b2] = CSF[c];
        // Each term a sqrt(pi/b) exp(-pi^2 r^2 / b) factors as e(x) e(y); the 2-D
        // kernel's sum is sum_i a_i sqrt(pi/b_i) (sum_x e_i(x))^2.
        let terms: Vec<(f32, Vec<f32>)> = [(a1, b1), (a2, b2)]
            .into_iter()
            .filter(|(a, _)| *a != 0.0)
            .map(|(a, b)| {
                let e: Vec<f32> = (-radius..=radius)
                    .map(|i| (-pi * pi * (i as f32 * dx).powi(2) / b).exp())
                    .collect();
                (a * (pi / b).sqrt(), e)
            })
            .collect();
        let total: f32 = terms
            .iter()
            .map(|(k, e)| k * e.iter().sum::<f32>().powi(2))
            .sum();
        let mut out = vec![0.0; w * h];
        for (k, e) in &terms {
            let f = convolve(&ycxcz[c], w, h, e, e);
            for (o, v) in out.iter_mut().zip(f) {
                *o += k / total * v;
            }
        }
        out
    })
}

/// Edge (first derivative) and point (second derivative) kernels of a Gaussian, positive
/// and negative weights each normalised to +-1 as in the reference implementation.
fn feature_kernels() -> (Vec<f32>, Vec<f32>, Vec<f32>) {
    let sd = 0.5 * GW * PPD;
    let r = (3.0 * sd).ceil() as i32;
    let xs: Vec<f32> = (-r..=r).map(|i| i as f32).collect();
    let g: Vec<f32> = xs
        .iter()
        .map(|x| (-x * x / (2.0 * sd * sd)).exp())
        .collect();
    let gsum: f32 = g.iter().sum();
    let norm = |k: Vec<f32>| {
        let pos: f32 = k.iter().filter(|v| **v > 0.0).sum();
        let neg: f32 = -k.iter().filter(|v| **v < 0.0).sum::<f32>();
        k.into_iter()
            .map(|v| {
                if v > 0.0 {
                    v / pos
                } else if v < 0.0 {
                    v / neg
                } else {
                    0.0
                }
            })
            .collect::<Vec<f32>>()
    };
    let edge = norm(xs.iter().zip(&g).map(|(x, g)| -x * g).collect());
    let point = norm(
        xs.iter()
            .zip(&g)
            .map(|(x, g)| (x * x / (sd * sd) - 1.0) * g)
            .collect(),
    );
    (edge, point, g.iter().map(|v| v / gsum).collect())
}

/// Per-pixel FLIP error of two sRGB 8-bit images of the same size.
pub fn flip(reference: &image::RgbImage, test: &image::RgbImage) -> Vec<f32> {
    let (w, h) = (reference.width() as usize, reference.height() as usize);
    let planes = |img: &image::RgbImage| -> [Vec<f32>; 3] {
        let ycc: Vec<[f32; 3]> = img
            .pixels()
            .map(|p| {
                xyz_to_ycxcz(mul(
                    &RGB2XYZ,
                    p.0.map(|c| srgb_to_linear(f32::from(c) / 255.0)),
                ))
            })
            .collect();
        std::array::from_fn(|c| ycc.iter().map(|v| v[c]).collect())
    };
    let (pr, pt) = (planes(reference), planes(test));
    let (fr, ft) = (csf_filter(&pr, w, h), csf_filter(&pt, w, h));
    let to_hunt = |f: &[Vec<f32>; 3], i: usize| {
        let rgb =
            mul(&XYZ2RGB, ycxcz_to_xyz([f[0][i], f[1][i], f[2][i]])).map(|v| v.clamp(0.0, 1.0));
        hunt(xyz_to_lab(mul(&RGB2XYZ, rgb)))
    };
    let green = hunt(xyz_to_lab(mul(&RGB2XYZ, [0.0, 1.0, 0.0])));
    let blue = hunt(xyz_to_lab(mul(&RGB2XYZ, [0.0, 0.0, 1.0])));
    let cmax = hyab(green, blue).powf(QC);
    let pccmax = PC * cmax;
    // Features on the achromatic channel, L* scaled to 0..1.
    let (edge, point, g) = feature_kernels();
    let features = |p: &[Vec<f32>; 3]| {
        let grey: Vec<f32> = p[0].iter().map(|y| (y + 16.0) / 116.0).collect();
        let ex = convolve(&grey, w, h, &edge, &g);
        let ey = convolve(&grey, w, h, &g, &edge);
        let px = convolve(&grey, w, h, &point, &g);
        let py = convolve(&grey, w, h, &g, &point);
        let e: Vec<f32> = ex.iter().zip(&ey).map(|(a, b)| a.hypot(*b)).collect();
        let q: Vec<f32> = px.iter().zip(&py).map(|(a, b)| a.hypot(*b)).collect();
        (e, q)
    };
    let ((er, qr), (et, qt)) = (features(&pr), features(&pt));
    (0..w * h)
        .map(|i| {
            let dc = hyab(to_hunt(&fr, i), to_hunt(&ft, i)).powf(QC);
            let ec = if dc < pccmax {
                PT / pccmax * dc
            } else {
                PT + (dc - pccmax) / (cmax - pccmax) * (1.0 - PT)
            };
            let df = (er[i] - et[i]).abs().max((qr[i] - qt[i]).abs());
            let ef = (df / std::f32::consts::SQRT_2).powf(QF);
            ec.powf(1.0 - ef)
        })
        .collect()
}
