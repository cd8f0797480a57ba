//! What scattering looks like at a shadow edge on skin: light that entered in the lit part
//! comes out in the shadow, and red light, which travels furthest in skin (skin1's red mean
//! free path is the longest), comes out furthest. The skin is white here, so the colour of
//! the light gained in the shadow is the profile's own.

use crate::common;

use bevy::prelude::*;
use common::*;
use subsurface_bevy::{Quality, Subsurface, SubsurfacePlugin};

fn render(with_subsurface: bool) -> Vec<u8> {
    let mut app = app();
    app.add_plugins(SubsurfacePlugin);
    let mut h = if with_subsurface {
        // High: fixed taps, no jitter noise in the comparison.
        setup(
            app,
            Subsurface {
                quality: Quality::High,
                ..default()
            },
        )
    } else {
        setup(app, ())
    };
    let world = h.app.world_mut();
    // A profile millimetre of 10 cm on this 1 m sphere: the blur spans a few pixels.
    let skin = common::white_skin(world, "skin1", 100.0);
    // A bar along x, above the view, between the light and the sphere: a shadow stripe
    // across the sphere's lit upper front, through (0, 0.5, 0.866).
    let bar = world
        .resource_mut::<Assets<Mesh>>()
        .add(Cuboid::new(6.0, 0.15, 0.15));
    let grey = world
        .resource_mut::<Assets<StandardMaterial>>()
        .add(StandardMaterial::default());
    let to_light = Vec3::new(-0.5, 4.0, 1.0).normalize();
    world.spawn((
        Mesh3d(bar),
        MeshMaterial3d(grey),
        Transform::from_translation(Vec3::new(0.0, 0.5, 0.866) + 2.0 * to_light),
    ));
    render_scene(&mut h, MeshMaterial3d(skin))
}

#[test]
fn red_light_scatters_furthest_into_a_shadow() {
    let Some((off, on)) = off_and_on(render) else {
        return;
    };
    dump(&off, "edge_off");
    dump(&on, "edge_on");
    let skin = |x: u32, y: u32| pixel(&off, x, y)[3] < 0.0;
    // Shadowed skin within 3 pixels of lit skin, all of whose neighbours are skin (not the
    // silhouette).
    let lit = |x: u32, y: u32| skin(x, y) && luminance(pixel(&off, x, y)) > 0.3;
    let mut gain = [0.0f64; 3];
    let mut n = 0;
    for y in 3..HEIGHT - 3 {
        for x in 3..WIDTH - 3 {
            let p = pixel(&off, x, y);
            if !skin(x, y) || luminance(p) > 0.1 {
                continue;
            }
            let around = (y - 3..=y + 3).flat_map(|v| (x - 3..=x + 3).map(move |u| (u, v)));
            let (mut all_skin, mut near_lit) = (true, false);
            for (u, v) in around {
                all_skin &= skin(u, v);
                near_lit |= lit(u, v);
            }
            if !(all_skin && near_lit) {
                continue;
            }
            let q = pixel(&on, x, y);
            for c in 0..3 {
                gain[c] += (q[c] - p[c]) as f64;
            }
            n += 1;
        }
    }
    assert!(n > 20, "too few shadow-edge pixels: {n}");
    let gain = gain.map(|g| g / n as f64);
    eprintln!(
        "{n} shadow-edge pixels, mean gain r {:.4} g {:.4} b {:.4}",
        gain[0], gain[1], gain[2]
    );
    assert_reddest(
        gain,
        0.01,
        1.1,
        "no light scattered into the shadow",
        "red does not scatter furthest",
    );
}
