//! A headless Bevy app (no window, no winit) renders a lit, shadowed sphere into an `Image`,
//! and the image read back shows it: the renderer, PBR lighting and Bevy's shadow maps work
//! with this crate's feature set on this machine's adapter.

use crate::common;

use bevy::prelude::*;
use common::*;

#[test]
fn headless_sphere_is_lit_and_shadowed() {
    if !gpu_available() {
        return;
    }
    let mut h = setup(app(), ());
    let grey = StandardMaterial {
        base_color: Color::linear_rgb(0.8, 0.8, 0.8),
        perceptual_roughness: 0.7,
        ..default()
    };
    let material = add_asset(&mut h.app, grey);
    let image = render_scene(&mut h, MeshMaterial3d(material));

    // Background: top-left corner is sky, the clear colour exactly (as f16).
    let bg = pixel(&image, 1, 1);
    for c in 0..4 {
        assert_eq!(
            bg[c],
            half::f16::from_f32(CLEAR[c]).to_f32(),
            "background {bg:?}"
        );
    }

    // Points to look at, projected with Bevy's own camera.
    let camera = h.camera;
    let top = project(&mut h.app, camera, Vec3::new(0.0, 0.95, 0.3)); // faces the light
    // The light comes along (0.5, -4, -1): the sphere's shadow is a disc of radius ~1 around
    // (0.125, -1, -0.25) on the plane; (0.1, -1, 0.55) is inside it and seen past the sphere.
    let below = project(&mut h.app, camera, Vec3::new(0.1, -1.0, 0.55));
    let lit_plane = project(&mut h.app, camera, Vec3::new(1.5, -1.0, 1.5));
    let bottom = project(&mut h.app, camera, Vec3::new(0.0, -0.6, 0.8)); // sphere, facing away from the light

    let (p_top, p_bottom) = (
        pixel(&image, top.0, top.1),
        pixel(&image, bottom.0, bottom.1),
    );
    let (p_lit_plane, p_below) = (
        pixel(&image, lit_plane.0, lit_plane.1),
        pixel(&image, below.0, below.1),
    );
    eprintln!(
        "sphere top {p_top:?} bottom {p_bottom:?}; plane lit {p_lit_plane:?} shadowed {p_below:?}"
    );
    for p in [p_top, p_bottom, p_lit_plane, p_below] {
        assert!(!is_magenta(p), "placeholder colour {p:?}");
        assert!(p.iter().all(|v| v.is_finite()));
    }
    // The sphere is lit where it faces the light, grey (equal channels), and much brighter
    // than where it faces away (ambient only).
    assert!(luminance(p_top) > 0.2, "sphere top not lit: {p_top:?}");
    assert!(
        (p_top[0] - p_top[2]).abs() < 0.02 * p_top[0],
        "not grey: {p_top:?}"
    );
    assert!(luminance(p_top) > 5.0 * luminance(p_bottom));
    // The sphere's shadow on the plane: much darker than the plane in the open.
    assert!(
        luminance(p_lit_plane) > 0.1,
        "plane not lit: {p_lit_plane:?}"
    );
    assert!(
        luminance(p_below) < 0.3 * luminance(p_lit_plane),
        "no shadow under the sphere: {p_below:?} vs {p_lit_plane:?}"
    );
}
