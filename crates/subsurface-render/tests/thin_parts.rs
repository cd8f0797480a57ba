//! Thin parts lit from the front reflect less than the half-space (`sss.thin_parts`): the
//! light a slab lets out through its far face is missing from its lit face. The oracle is the
//! adding-doubling slab solver of subsurface-profile (`SlabSolver::slab(..).reflected` over its
//! half-space reflectance), a method independent of the renderer's LUT and of its thickness
//! estimate from the back faces.

use crate::common;

use common::{camera_toml, context, dark_scene, diffuse_with, light_toml};
use subsurface_profile::{Dipole, SlabSolver};
use subsurface_render::{Scene, SssMethod};

/// Jensen et al. 2001's skin1, 1/mm.
const SKIN1_SIGMA_A: [f64; 3] = [0.032, 0.17, 0.48];
const SKIN1_SIGMA_S_PRIME: [f64; 3] = [0.74, 0.88, 1.01];

/// What a slab of skin1 `s_mm` thick reflects as a share of the half-space, per channel.
fn reflected_share(s_mm: f64) -> [f32; 3] {
    let d = Dipole::new(SKIN1_SIGMA_A, SKIN1_SIGMA_S_PRIME, 1.3).unwrap();
    let solver = SlabSolver::new(1.3).unwrap();
    std::array::from_fn(|c| {
        let ch = d.channel(c);
        let slab = solver
            .slab(ch.sigma_t_prime, ch.alpha_prime, s_mm)
            .unwrap()
            .reflected;
        let deep = solver
            .diffuse_reflectance(ch.sigma_t_prime, ch.alpha_prime)
            .unwrap();
        (slab / deep) as f32
    })
}

/// `mesh` (1000 mm a unit, skin1, no specular) turned by `tilt_deg` about the vertical axis,
/// seen head-on from `camera_z` along +z (a 20 degree view) and lit from the camera's side by
/// a directional light without a shadow map.
fn front_lit(mesh: &str, tilt_deg: f32, camera_z: f32) -> Scene {
    dark_scene(
        &camera_toml(camera_z, 20.0, "near = 0.005\nfar = 2.0"),
        &light_toml("directional", [0.0, 0.0, 1.0], 1.0, "shadow_map_size = 0"),
        &format!(
            "[[objects]]\nmesh = {mesh}\nmm_per_unit = 1000.0\nrotation_deg = [0.0, {tilt_deg:?}, 0.0]\n[objects.material]\nalbedo = [1.0, 1.0, 1.0]\nspecular = 0.0\nmedium = \"skin1\"\n"
        ),
    )
}

/// The diffuse target (irradiance x albedo, no blur) of `scene` at 64 x 64, with the thin
/// parts' term on or off.
fn diffuse(scene: &Scene, thin_parts: bool) -> Vec<[f32; 4]> {
    diffuse_with(scene, 64, 64, |s| {
        s.sss.method = SssMethod::None;
        s.sss.thin_parts = thin_parts;
    })
}

fn slab(thickness_m: f32) -> String {
    format!("{{ shape = \"slab\", width = 0.2, height = 0.2, thickness = {thickness_m:?} }}")
}

/// Each channel of the ratio `on / off` at pixel `i` within `tol` of `want`.
fn assert_share(on: &[[f32; 4]], off: &[[f32; 4]], i: usize, want: [f32; 3], tol: f32, what: &str) {
    for c in 0..3 {
        let got = on[i][c] / off[i][c];
        assert!(
            (got - want[c]).abs() < tol,
            "{what}, channel {c}: {got} (on {:?}, off {:?}) vs the slab solver's {}",
            on[i],
            off[i],
            want[c]
        );
    }
}

/// A 1 mm and a 2 mm slab of skin1 seen head-on keep the solver's share of their reflectance
/// (1 mm: about half the red); a 30 mm slab keeps all of it.
#[test]
fn a_thin_slab_reflects_what_the_slab_solver_says() {
    if context().is_none() {
        return;
    }
    for s_mm in [1.0, 2.0, 30.0] {
        let scene = front_lit(&slab(s_mm / 1000.0), 0.0, 0.3);
        let (on, off) = (diffuse(&scene, true), diffuse(&scene, false));
        let want = if s_mm > 20.0 {
            [1.0; 3]
        } else {
            reflected_share(f64::from(s_mm))
        };
        assert_share(&on, &off, 32 * 64 + 32, want, 0.02, &format!("{s_mm} mm"));
    }
    assert!(reflected_share(1.0)[0] < 0.6);
}

/// Seen at 50 degrees, a 2 mm slab's view ray crosses 3.1 mm of it: the thickness along the
/// normal, chord x |n.v|, is still 2 mm, and the share is the head-on one.
#[test]
fn a_tilted_slab_is_as_thin_as_its_normal_says() {
    if context().is_none() {
        return;
    }
    let scene = front_lit(&slab(0.002), 50.0, 0.3);
    let (on, off) = (diffuse(&scene, true), diffuse(&scene, false));
    assert_share(
        &on,
        &off,
        32 * 64 + 32,
        reflected_share(2.0),
        0.02,
        "tilted 2 mm",
    );
}

/// A 20 mm sphere keeps its reflectance up to its rim, where the view ray's chord is short but
/// the back face it meets is the same surface curving away, not the far side of a sheet (taken
/// for one, the outermost pixels would read as 1-3 mm of skin and lose a third of their red).
#[test]
fn a_thick_sphere_keeps_its_reflectance_at_the_rim() {
    if context().is_none() {
        return;
    }
    // The sphere fills most of a view 23 mm across.
    let scene = front_lit(
        "{ shape = \"sphere\", radius = 0.01, segments = 256 }",
        0.0,
        0.075,
    );
    let (on, off) = (diffuse(&scene, true), diffuse(&scene, false));
    let background = off[0];
    let mut lit = 0;
    for i in 0..on.len() {
        if off[i][0] > background[0] + 1e-3 {
            lit += 1;
            assert_share(&on, &off, i, [1.0; 3], 0.01, &format!("pixel {i}"));
        }
    }
    assert!(lit > 1500, "{lit} pixels on the sphere");
}
