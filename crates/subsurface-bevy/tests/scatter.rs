//! The plugin in a headless Bevy app: a skin sphere on a grey plane, rendered once by a
//! camera with `Subsurface` and once by the same camera without it. Pixels that are not skin
//! must come back bit for bit; skin pixels must change, keep their energy, and lose the
//! skin marker.

mod common;

use bevy::prelude::*;
use common::*;
use subsurface_bevy::{Skin, SkinMaterial, Subsurface, SubsurfacePlugin};

fn render(with_subsurface: bool) -> Vec<u8> {
    let mut app = app();
    app.add_plugins(SubsurfacePlugin);
    let mut h = if with_subsurface {
        setup(app, Subsurface::default())
    } else {
        setup(app, ())
    };
    let skin = h
        .app
        .world_mut()
        .resource_mut::<Assets<SkinMaterial>>()
        .add(SkinMaterial {
            base: StandardMaterial {
                base_color: Color::linear_rgb(0.8, 0.5, 0.4),
                perceptual_roughness: 0.6,
                ..default()
            },
            // The sphere has a radius of 1 m; a width of 20 makes the profile about a
            // centimetre wide, a few pixels at this resolution.
            extension: Skin::new("skin1", 20.0),
        });
    spawn_scene(&mut h.app, MeshMaterial3d(skin));
    render_until_stable(&mut h, 600)
}

#[test]
fn subsurface_changes_skin_and_nothing_else() {
    if !gpu_available() {
        return;
    }
    let off = render(false);
    let on = render(true);
    dump(&off, "scatter_off");
    dump(&on, "scatter_on");

    let (mut skin, mut other, mut changed) = (0usize, 0usize, 0usize);
    let (mut energy_off, mut energy_on) = (0.0f64, 0.0f64);
    let mut max_change = 0.0f32;
    for y in 0..HEIGHT {
        for x in 0..WIDTH {
            let (a, b) = (pixel(&off, x, y), pixel(&on, x, y));
            // Without the camera component nothing removes the marker: skin pixels keep
            // alpha -(row + 1) = -1.
            if a[3] < 0.0 {
                assert_eq!(a[3], -1.0, "marker at {x},{y}");
                skin += 1;
                assert_eq!(b[3], 1.0, "skin at {x},{y} kept its marker: {b:?}");
                let d = (0..3).map(|c| (a[c] - b[c]).abs()).fold(0.0, f32::max);
                max_change = max_change.max(d);
                if d > 1e-3 {
                    changed += 1;
                }
                energy_off += (a[0] + a[1] + a[2]) as f64;
                energy_on += (b[0] + b[1] + b[2]) as f64;
            } else {
                other += 1;
                assert_eq!(
                    pixel_bits(&off, x, y),
                    pixel_bits(&on, x, y),
                    "non-skin pixel {x},{y} changed: {a:?} -> {b:?}"
                );
            }
        }
    }
    eprintln!(
        "skin {skin} px ({changed} changed, max |change| {max_change}), other {other} px; \
         skin energy {energy_off:.2} -> {energy_on:.2}"
    );
    assert!(skin > 2000, "too few skin pixels: {skin}");
    assert!(other > 2000, "too few other pixels: {other}");
    // The blur moves light across the terminator and the shadow edge: a good share of the
    // sphere changes.
    assert!(
        changed * 10 > skin,
        "only {changed} of {skin} skin pixels changed"
    );
    // Scattering moves light, it does not make or destroy much of it (some leaves past the
    // silhouette's depth edges, where taps are cut).
    let ratio = energy_on / energy_off;
    assert!((0.9..1.05).contains(&ratio), "skin energy ratio {ratio}");
}
