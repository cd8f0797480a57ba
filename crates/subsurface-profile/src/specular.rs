//! The skin boundary's specular reflection: the reference the lighting pass's specular term
//! (lighting.wgsl, `boundary_specular`) is tested against.
//!
//! The path tracer renders skin as a medium inside a rough dielectric (Beckmann facets of
//! slope `alpha`, index `eta`), so the real-time reflection is that boundary's: Cook-Torrance
//! with Beckmann's distribution, Smith's masking of both directions (Walter et al. 2007's
//! rational fit, the one Mitsuba evaluates) and Schlick's Fresnel of the boundary. Kelemen and
//! Szirmay-Kalos's skin specular (d'Eon and Luebke 2007) replaces `G / (N.L N.V)` by
//! `4 / |L + V|^2`; on the same side of the surface the two agree (see the tests), but where a
//! back light grazes a rim toward the camera `|L + V|` goes to 0 while `G` does not let the
//! lobe reflect more than arrives.
//!
//! Units: the renderer's radiance is pi times Mitsuba's for the same emitter (its diffuse
//! radiance is `albedo x irradiance`), so [`beckmann`] is pi times the normalised
//! distribution and [`boundary_reflection`] is pi times `f_r cos(theta_l)`.

use std::f64::consts::PI;

/// Beckmann's distribution of facet normals at cosine `cos_h` to the normal, times pi
/// (`exp(-tan^2 / alpha^2) / (alpha^2 cos^4)`).
pub fn beckmann(cos_h: f64, alpha: f64) -> f64 {
    let c2 = (cos_h * cos_h).max(1e-4);
    let tan2 = (1.0 - c2) / c2;
    (-tan2 / (alpha * alpha)).exp() / (alpha * alpha * c2 * c2)
}

/// Smith's masking of a Beckmann surface seen at cosine `cos_theta` to its normal (Walter et
/// al. 2007's rational fit, within 0.35 % of the exact `erf` form).
pub fn beckmann_smith_g1(cos_theta: f64, alpha: f64) -> f64 {
    let c = cos_theta.clamp(1e-4, 1.0);
    let a = c / (alpha * (1.0 - c * c).max(1e-8).sqrt());
    if a >= 1.6 {
        1.0
    } else {
        (3.535 * a + 2.181 * a * a) / (1.0 + 2.276 * a + 2.577 * a * a)
    }
}

/// Schlick's reflectance of the boundary of index `eta` at cosine `cos_theta`.
pub fn schlick(cos_theta: f64, eta: f64) -> f64 {
    let e = (1.0 - cos_theta.clamp(0.0, 1.0)).powi(5);
    let r = (eta - 1.0) / (eta + 1.0);
    e + r * r * (1.0 - e)
}

/// The boundary's reflection toward `v` of light from `l` at a surface of normal `n` (unit
/// vectors, pointing away from the surface), in the renderer's units: radiance per unit light
/// radiance-intensity, pi `f_r N.L` = `D F G / (4 N.V)` with [`beckmann`]'s `D`. Zero where
/// either direction is below the surface.
pub fn boundary_reflection(n: [f64; 3], l: [f64; 3], v: [f64; 3], alpha: f64, eta: f64) -> f64 {
    let (nl, nv) = (dot(n, l), dot(n, v));
    let h = [l[0] + v[0], l[1] + v[1], l[2] + v[2]];
    let len = dot(h, h).sqrt();
    if nl <= 0.0 || nv <= 0.0 || len < 1e-6 {
        return 0.0;
    }
    let h = h.map(|x| x / len);
    let g = beckmann_smith_g1(nv, alpha) * beckmann_smith_g1(nl, alpha);
    beckmann(dot(n, h).max(0.0), alpha) * schlick(dot(v, h), eta) * g / (4.0 * nv)
}

/// The share of a collimated beam arriving from outside at cosine `cos_theta` to the normal
/// that the rough boundary (Beckmann facets of slope `alpha`, index `eta` inside) lets into
/// the medium: Walter et al. 2007's microfacet transmission, as Mitsuba's `roughdielectric`
/// evaluates it (Smith's masking of both directions, each facet's exact dielectric Fresnel),
/// integrated over the facets the beam sees. By reciprocity it is also what leaves toward
/// `cos_theta` of light arriving at the boundary from inside evenly from every direction, so
/// it replaces a smooth boundary's `1 - F` wherever multiply scattered light enters or leaves.
///
/// Unlike `1 - F` it stays high at grazing: facets tilted toward a grazing direction see it
/// far less obliquely. For `alpha` 0.3 and `eta` 1.3 it is 0.73 at 89 degrees, where a smooth
/// boundary passes 0.05; at the rim of a backlit finger, where the camera grazes the surface,
/// that is most of the light that leaves.
pub fn rough_transmittance(cos_theta: f64, alpha: f64, eta: f64) -> f64 {
    // Held off exact grazing, where G1 (clamped at 1e-4 in [`beckmann_smith_g1`]) / mu loses
    // its limit.
    let mu = cos_theta.clamp(1e-3, 1.0);
    let wi = [(1.0 - mu * mu).sqrt(), 0.0, mu];
    // Slopes (x, y) of the facets, m = (-x, -y, 1) / |.|, Beckmann-distributed with density
    // exp(-(x^2 + y^2) / alpha^2) / (pi alpha^2); the beam meets a facet in proportion to
    // wi . (-x, -y, 1) (its projected area toward the beam, per unit of the surface's
    // projected area), which over all slopes integrates to mu / G1(mu), hence the factor in
    // front. A midpoint grid of 4 alpha either way leaves out e^-16 of the facets.
    let n = 96;
    let half = 4.0 * alpha;
    let h = 2.0 * half / n as f64;
    let mut sum = 0.0;
    for i in 0..n {
        let x = -half + (i as f64 + 0.5) * h;
        for j in 0..n {
            let y = -half + (j as f64 + 0.5) * h;
            let facing = wi[0] * -x + wi[2];
            if facing <= 0.0 {
                continue;
            }
            let density = (-(x * x + y * y) / (alpha * alpha)).exp() / (PI * alpha * alpha);
            let len = (x * x + y * y + 1.0).sqrt();
            let m = [-x / len, -y / len, 1.0 / len];
            let c = dot(wi, m);
            // Snell's law across the facet, into the denser side.
            let sin2 = (1.0 - c * c) / (eta * eta);
            let ct = (1.0 - sin2).sqrt();
            let t = [0, 1, 2].map(|k| -wi[k] / eta + (c / eta - ct) * m[k]);
            // The refracted ray must leave the facet downward and go below the surface.
            if t[2] >= 0.0 {
                continue;
            }
            let f = crate::transport::fresnel_inside(1.0 / eta, c);
            sum += density * facing * (1.0 - f) * beckmann_smith_g1(-t[2], alpha);
        }
    }
    sum * h * h * beckmann_smith_g1(mu, alpha) / mu
}

/// Coefficients of a degree-7 polynomial in the cosine, `sum c[k] mu^k`, that stands in for
/// [`rough_transmittance`] on 0..=1 (least squares on 65 cosines). It is what
/// the GPU evaluates instead of reading a LUT row: on lavapipe those reads were 14 of the
/// `diffusion` lighting pass's 117 ms at 640x360 (its taps, single scattering and exit each
/// read it; docs/lab/performance.md). Within 0.003 of the integral for roughness 0.15 to 1 and
/// eta 1.1 to 1.6, 0.007 at roughness 0.05 and 0.02 at 0.01, where a smooth boundary's curve
/// falls within a degree of grazing (the LUT row it replaced held 0.006 there); within 0.001
/// head-on (see the tests).
pub fn rough_transmittance_fit(alpha: f64, eta: f64) -> [f64; 8] {
    const NODES: usize = 65;
    const N: usize = 8;
    // Normal equations in the monomials of mu on 0..=1, solved by Gaussian elimination with
    // partial pivoting (their Gram matrix at degree 7 is conditioned to about 1e10: f64 keeps
    // the coefficients to 1e-6).
    let mut a = [[0.0f64; N + 1]; N];
    for i in 0..NODES {
        // Chebyshev-spaced, denser at both ends: toward grazing a smooth boundary's curve bends,
        // and head-on sets every `1 / T(1)` normalisation.
        let mu = 0.5 - 0.5 * (std::f64::consts::PI * i as f64 / (NODES - 1) as f64).cos();
        let t = rough_transmittance(mu, alpha, eta);
        let powers: [f64; N] = std::array::from_fn(|k| mu.powi(k as i32));
        // Head-on weighs as much as all the others: it is what the normalisations divide by.
        let w = if i == NODES - 1 { NODES as f64 } else { 1.0 };
        for r in 0..N {
            for c in 0..N {
                a[r][c] += w * powers[r] * powers[c];
            }
            a[r][N] += w * powers[r] * t;
        }
    }
    for col in 0..N {
        let pivot = (col..N)
            .max_by(|&x, &y| a[x][col].abs().total_cmp(&a[y][col].abs()))
            .unwrap_or(col);
        a.swap(col, pivot);
        for r in 0..N {
            if r != col {
                let f = a[r][col] / a[col][col];
                for c in col..=N {
                    a[r][c] -= f * a[col][c];
                }
            }
        }
    }
    std::array::from_fn(|k| a[k][N] / a[k][k])
}

/// [`rough_transmittance_fit`]'s polynomial at `mu` (clamped to 0..=1), as the GPU evaluates it.
pub fn eval_fit(c: &[f64; 8], mu: f64) -> f64 {
    let mu = mu.clamp(0.0, 1.0);
    c.iter().rev().fold(0.0, |acc, &k| acc * mu + k)
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    const ALPHA: f64 = 0.3;
    const ETA: f64 = 1.3;

    /// The polynomial the GPU evaluates stays within 0.003 of the integral for roughness 0.15
    /// to 1 and eta 1.1 to 1.6, 0.007 at roughness 0.05 and 0.02 at 0.01 (smooth boundaries,
    /// whose curve falls within a degree of grazing; worst at grazing), and within 0.001
    /// head-on, which every `1 / T(1)` normalisation divides by.
    #[test]
    fn the_fit_follows_the_rough_transmittance() {
        for alpha in [0.01, 0.02, 0.05, 0.15, 0.3, 1.0] {
            for eta in [1.1, 1.3, 1.6] {
                let c = rough_transmittance_fit(alpha, eta);
                let bound = match alpha {
                    a if a < 0.03 => 0.02,
                    a if a < 0.1 => 7e-3,
                    _ => 3e-3,
                };
                // Finer toward grazing, where the curve bends.
                for i in 0..=100 {
                    let mu = (i as f64 / 100.0).powf(1.5);
                    let off = (eval_fit(&c, mu) - rough_transmittance(mu, alpha, eta)).abs();
                    assert!(off < bound, "alpha {alpha} eta {eta} mu {mu}: off by {off}");
                }
                let head_on = (eval_fit(&c, 1.0) - rough_transmittance(1.0, alpha, eta)).abs();
                assert!(
                    head_on < 1e-3,
                    "alpha {alpha} eta {eta} head-on: off by {head_on}"
                );
            }
        }
    }

    fn dir(theta: f64, phi: f64) -> [f64; 3] {
        [
            theta.sin() * phi.cos(),
            theta.sin() * phi.sin(),
            theta.cos(),
        ]
    }

    /// The share of light from every direction of the hemisphere that the lobe sends toward
    /// `v` (by reciprocity, the directional albedo): `1 / pi` of the renderer's units
    /// integrated over the hemisphere (midpoint rule in theta and phi).
    fn albedo(v: [f64; 3], alpha: f64) -> f64 {
        let (nt, np) = (400, 400);
        let mut sum = 0.0;
        for i in 0..nt {
            let theta = (i as f64 + 0.5) / nt as f64 * PI / 2.0;
            for j in 0..np {
                let phi = (j as f64 + 0.5) / np as f64 * 2.0 * PI;
                let l = dir(theta, phi);
                sum += boundary_reflection([0.0, 0.0, 1.0], l, v, alpha, ETA) * theta.sin();
            }
        }
        sum * (PI / 2.0 / nt as f64) * (2.0 * PI / np as f64) / PI
    }

    #[test]
    fn the_distribution_is_normalised() {
        // Projected facet area: the integral of D cos(theta_h) over the hemisphere is 1 (pi in
        // these units).
        let n = 20000;
        let sum: f64 = (0..n)
            .map(|i| {
                let t = (i as f64 + 0.5) / n as f64 * PI / 2.0;
                beckmann(t.cos(), ALPHA) * t.cos() * t.sin()
            })
            .sum::<f64>()
            * (PI / 2.0 / n as f64)
            * 2.0
            * PI;
        assert!((sum / PI - 1.0).abs() < 1e-3, "{}", sum / PI);
    }

    #[test]
    fn the_lobe_never_reflects_more_than_arrives() {
        // From the normal to 89 degrees, the boundary reflects at least Schlick's F0 (0.017)
        // and at most all of the light; without G's masking the grazing views would exceed it.
        for deg in [0.0f64, 30.0, 60.0, 80.0, 85.0, 89.0] {
            let v = dir(deg.to_radians(), 0.0);
            let a = albedo(v, ALPHA);
            assert!((0.015..1.0).contains(&a), "{deg} deg: albedo {a}");
        }
        // Toward the normal it is little more than F0: the lobe is narrow and G near 1.
        let a0 = albedo([0.0, 0.0, 1.0], ALPHA);
        assert!((0.015..0.03).contains(&a0), "{a0}");
    }

    #[test]
    fn kelemen_szirmay_kalos_agrees_where_light_and_camera_share_a_side() {
        // d'Eon and Luebke's skin specular, P_H F / |L + V|^2 N.L, with the same P_H and F.
        let ks = |n: [f64; 3], l: [f64; 3], v: [f64; 3]| {
            let h = [l[0] + v[0], l[1] + v[1], l[2] + v[2]];
            let len2 = dot(h, h);
            let h = h.map(|x| x / len2.sqrt());
            beckmann(dot(n, h), ALPHA) * schlick(dot(v, h), ETA) / len2 * dot(n, l)
        };
        let n = [0.0, 0.0, 1.0];
        // At the highlight (mirror directions) Kelemen/Szirmay-Kalos's |L + V|^2 / 4 is N.L N.V
        // exactly and only G's masking differs, which is 1 until 60 degrees; off the highlight,
        // where the lobe is weak, |L + V|^2 / 4 drifts from N.L N.V by up to a quarter.
        for (tl, tv, azimuth, tolerance) in [
            (10.0f64, 10.0f64, 180.0f64, 0.01),
            (30.0, 30.0, 180.0, 0.01),
            (60.0, 60.0, 180.0, 0.03),
            (45.0, 20.0, 90.0, 0.3),
        ] {
            let l = dir(tl.to_radians(), 0.0);
            let v = dir(tv.to_radians(), azimuth.to_radians());
            let (ours, theirs) = (boundary_reflection(n, l, v, ALPHA, ETA), ks(n, l, v));
            assert!(
                (ours / theirs - 1.0).abs() < tolerance,
                "light {tl} view {tv} azimuth {azimuth}: {ours} vs {theirs}"
            );
        }
        // A back light grazing a rim toward the camera, as in the finger-backlit scene: both
        // directions 87 degrees from the normal and 174 apart. Kelemen/Szirmay-Kalos's
        // 1 / |L + V|^2 sends 4.7 times what G's masking lets the facets reflect.
        let l = dir(87f64.to_radians(), 0.0);
        let v = dir(87f64.to_radians(), PI);
        let (ours, theirs) = (boundary_reflection(n, l, v, ALPHA, ETA), ks(n, l, v));
        assert!(theirs > 4.0 * ours, "{ours} vs {theirs}");
    }

    #[test]
    fn the_rough_boundary_lets_in_what_mitsuba_lets_in() {
        // Mitsuba 3.9's `roughdielectric` (Beckmann, int_ior 1.3), its sampling routine run
        // 200 000 times per direction from outside (scalar_rgb): the mean weight of the
        // transmitted samples times eta^2 (Mitsuba scales transmitted radiance by 1 / eta^2).
        for (alpha, mu, mitsuba) in [
            (0.3, 1.0, 0.9826),
            (0.3, 0.5, 0.9358),
            (0.3, 0.2, 0.8265),
            (0.3, 0.1, 0.7767),
            (0.3, 0.02, 0.7328),
            (0.1, 0.5, 0.9445),
            (0.1, 0.2, 0.731),
            (0.1, 0.1, 0.5695),
            (0.1, 0.02, 0.4353),
        ] {
            let ours = rough_transmittance(mu, alpha, ETA);
            assert!(
                (ours - mitsuba).abs() < 0.01,
                "alpha {alpha}, cos {mu}: {ours} vs Mitsuba's {mitsuba}"
            );
        }
        // A smooth boundary's limit is 1 - F, exact Fresnel.
        for mu in [1.0, 0.5, 0.2] {
            let smooth = 1.0 - crate::transport::fresnel_inside(1.0 / ETA, mu);
            let ours = rough_transmittance(mu, 1e-3, ETA);
            assert!((ours - smooth).abs() < 2e-3, "cos {mu}: {ours} vs {smooth}");
        }
        // Never more than arrives, and less toward grazing.
        let mut last = 1.0;
        for i in 0..=20 {
            let t = rough_transmittance(1.0 - i as f64 / 20.0, ALPHA, ETA);
            assert!(t <= last + 1e-9 && t > 0.0, "{i}: {t}");
            last = t;
        }
    }

    #[test]
    fn nothing_is_reflected_from_below_the_surface() {
        let n = [0.0, 0.0, 1.0];
        let up = dir(0.3, 0.0);
        let below = [0.0, 0.3, -1.0];
        assert_eq!(boundary_reflection(n, below, up, ALPHA, ETA), 0.0);
        assert_eq!(boundary_reflection(n, up, below, ALPHA, ETA), 0.0);
        assert_eq!(
            boundary_reflection(n, [1.0, 0.0, 0.0], [-1.0, 0.0, 0.0], ALPHA, ETA),
            0.0
        );
    }
}
