//! Frame times with and without the plugin (not a check: `cargo test -p subsurface-bevy
//! --test integration timing:: -- --ignored --nocapture`). Figures go to docs/lab/bevy.md
//! with the machine they came from.

use crate::common;

use std::time::Instant;

use bevy::core_pipeline::tonemapping::Tonemapping;
use bevy::prelude::*;
use common::*;
use subsurface_bevy::{Quality, Skin, SkinMaterial, Subsurface, SubsurfacePlugin};

const SIZE: (u32, u32) = (640, 480);
const FRAMES: u32 = 20;

#[derive(Clone, Copy, Debug)]
enum Case {
    /// StandardMaterial, no plugin.
    Plain,
    /// The skin material (diffuse + specular twin), camera without `Subsurface`.
    SkinNoStep,
    /// The skin material and a `Subsurface` camera, with transmittance or without.
    Skin(Quality, bool),
}

fn frame_ms(case: Case) -> f64 {
    let mut app = app();
    if !matches!(case, Case::Plain) {
        app.add_plugins(SubsurfacePlugin);
    }
    let mut h = match case {
        Case::Skin(quality, transmittance) => setup_sized(
            app,
            Subsurface {
                quality,
                transmittance,
                ..default()
            },
            Tonemapping::None,
            SIZE,
        ),
        _ => setup_sized(app, (), Tonemapping::None, SIZE),
    };
    let base = StandardMaterial {
        base_color: Color::linear_rgb(0.8, 0.5, 0.4),
        perceptual_roughness: 0.6,
        ..default()
    };
    if matches!(case, Case::Plain) {
        let m = h
            .app
            .world_mut()
            .resource_mut::<Assets<StandardMaterial>>()
            .add(base);
        spawn_scene(&mut h.app, MeshMaterial3d(m));
    } else {
        let m = h
            .app
            .world_mut()
            .resource_mut::<Assets<SkinMaterial>>()
            .add(SkinMaterial {
                base,
                extension: Skin::new("skin1", 20.0),
            });
        spawn_scene(&mut h.app, MeshMaterial3d(m));
    }
    render_until_stable(&mut h, 600);
    let start = Instant::now();
    for _ in 0..FRAMES {
        h.app.update();
    }
    // The read-back of each frame waits for it: the figure is frame to frame, GPU included.
    start.elapsed().as_secs_f64() * 1000.0 / FRAMES as f64
}

#[test]
#[ignore]
fn frame_times() {
    if !gpu_available() {
        return;
    }
    for case in [
        Case::Plain,
        Case::SkinNoStep,
        Case::Skin(Quality::Low, false),
        Case::Skin(Quality::Medium, false),
        Case::Skin(Quality::High, false),
        Case::Skin(Quality::Low, true),
        Case::Skin(Quality::Medium, true),
        Case::Skin(Quality::High, true),
    ] {
        let ms = frame_ms(case);
        eprintln!("{}x{} {case:?}: {ms:.1} ms/frame", SIZE.0, SIZE.1);
    }
}
