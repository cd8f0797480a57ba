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

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    const ALPHA: f64 = 0.3;
    const ETA: f64 = 1.3;

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
