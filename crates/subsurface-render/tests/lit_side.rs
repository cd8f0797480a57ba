//! A point the light reaches takes the light of the beam beneath it beyond the half-space's
//! (`transmittance.lit_side`, lit_side.wgsl). On a plane the half-space is exact, so the term
//! must add nothing there whatever the light's angle; on a rod lit from the side it must light
//! the lit side near the terminator, where the beam that entered the flank runs beneath the
//! surface. How much it adds is held against the path tracer on the suite
//! (subsurface-cli tests/suite_guard.rs).

use crate::common;

use common::{camera_toml, context, dark_scene, diffuse_with, light_toml};
use subsurface_render::{Scene, SssMethod};

/// `mesh` of ketchup (light crosses a centimetre of it) seen head-on from 200 mm over a frame
/// 24 mm tall, lit by a spot light 350 mm away at 60 degrees to the right of the camera.
fn side_lit(mesh: &str) -> Scene {
    let fov = 2.0 * (0.012f32 / 0.2).atan().to_degrees();
    let a = 60f32.to_radians();
    dark_scene(
        &camera_toml(0.2, fov, "near = 0.05\nfar = 2.0"),
        &light_toml(
            "spot",
            [0.35 * a.sin(), 0.0, 0.35 * a.cos()],
            0.245,
            "inner_angle_deg = 9.0\nouter_angle_deg = 14.0\nshadow_map_size = 2048\nshadow_bias = 0.0005",
        ),
        &format!(
            "[[objects]]\nmesh = {mesh}\nmm_per_unit = 1000.0\n[objects.material]\nmedium = \"ketchup\"\nroughness = 0.3\nspecular = 1.0\n"
        ),
    )
}

/// The diffuse target (no blur, no unscattered or once-scattered light) with the lit side's
/// term on or off.
fn diffuse(scene: &Scene, lit_side: bool) -> Vec<[f32; 4]> {
    diffuse_with(scene, 128, 128, |s| {
        s.sss.method = SssMethod::None;
        s.transmittance.ballistic = false;
        s.transmittance.single_scattering = false;
        s.transmittance.normal_shrink = 0.0005;
        s.transmittance.lit_side = lit_side;
    })
}

/// Mean red of the diffuse target over columns `x` of the middle 64 rows.
fn columns(d: &[[f32; 4]], x: std::ops::Range<usize>) -> f32 {
    let mut sum = 0.0;
    let mut n = 0.0;
    for y in 32..96 {
        for i in x.clone() {
            sum += d[y * 128 + i][0];
            n += 1.0;
        }
    }
    sum / n
}

#[test]
fn a_plane_takes_nothing_and_a_side_lit_rods_lit_side_does() {
    if context().is_none() {
        return;
    }
    // A slab 100 mm wide and 10 mm thick facing the camera, the light 60 degrees off its normal:
    // every visible pixel is lit, and the beam below each is the plane's own.
    let slab = side_lit("{ shape = \"slab\", width = 0.1, height = 0.1, thickness = 0.01 }");
    let (on, off) = (diffuse(&slab, true), diffuse(&slab, false));
    let peak = off.iter().map(|p| p[0]).fold(0.0f32, f32::max);
    assert!(peak > 0.0, "the slab is dark");
    let worst = on
        .iter()
        .zip(&off)
        .map(|(a, b)| (0..3).map(|c| (a[c] - b[c]).abs()).fold(0.0f32, f32::max))
        .fold(0.0f32, f32::max);
    assert!(
        worst <= 1e-4 * peak,
        "the term added {worst} on a plane (the diffuse target peaks at {peak})"
    );
    // A rod 18 mm across, its axis up the frame (about 96 pixels wide, the light from the
    // right): the terminator lies 30 degrees left of the middle, near x = 40. On the lit side
    // between it and the middle the term doubles the light (0.139 against 0.067 in red); on
    // the far lit side, where the beam below is nearly the plane's, it adds 0.3 %. How much
    // it should add the path tracer says (tests/suite_guard.rs).
    let rod = side_lit("{ shape = \"cylinder\", radius = 0.009, length = 0.12, segments = 256 }");
    let (on, off) = (diffuse(&rod, true), diffuse(&rod, false));
    let near = (columns(&on, 46..56), columns(&off, 46..56));
    let far = (columns(&on, 100..106), columns(&off, 100..106));
    assert!(
        near.0 >= 1.5 * near.1,
        "near the terminator's lit side the rod reads {} with the term, {} without",
        near.0,
        near.1
    );
    assert!(
        far.0 <= 1.02 * far.1 && far.1 > 0.0,
        "on the far lit side the rod reads {} with the term, {} without",
        far.0,
        far.1
    );
}
