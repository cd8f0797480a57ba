//! The plugin's blur against subsurface-profile's CPU oracle: a flat skin card facing the
//! camera, with a shadow stripe across it, rendered by Bevy without `Subsurface` (the
//! un-blurred diffuse light and the skin markers, read back) and with it. The oracle blurs the
//! first image with the kernels the plugin builds for the card's medium and width; the second
//! image must match it within the tolerance subsurface-render's own oracle tests state for
//! Rgba16Float targets, relative to the value. The card is flat and square to the view, so
//! its linear depth is the camera's distance, exactly what the step reads from Bevy's depth
//! buffer. The specular twins are hidden: the comparison is of the diffuse light alone.

use crate::common;

use bevy::light::CascadeShadowConfigBuilder;
use bevy::prelude::*;
use common::*;
use subsurface_bevy::{Quality, SkinSpecular, Subsurface, SubsurfacePlugin};
use subsurface_profile::oracle::{ScreenInput, ScreenParams, separable};
use subsurface_render::RenderSettings;

const DISTANCE: f32 = 3.0;
/// Profile millimetres are 5 cm on the card: the kernel spans several pixels at 160x120.
const WIDTH_FACTOR: f32 = 50.0;
const UNITS_PER_MM: f32 = 0.001;

fn hide_twins(mut twins: Query<&mut Visibility, With<SkinSpecular>>) {
    for mut v in &mut twins {
        *v = Visibility::Hidden;
    }
}

fn render(subsurface: bool) -> Vec<u8> {
    let mut app = app();
    app.add_plugins(SubsurfacePlugin)
        .add_systems(Update, hide_twins);
    let mut h = if subsurface {
        setup(
            app,
            Subsurface {
                // Fixed taps: the oracle's `separable`, not its jittered twin.
                quality: Quality::High,
                units_per_mm: UNITS_PER_MM,
                transmittance: false,
            },
        )
    } else {
        setup(app, ())
    };
    let world = h.app.world_mut();
    world
        .entity_mut(h.camera)
        .insert(Transform::from_xyz(0.0, 0.0, DISTANCE).looking_at(Vec3::ZERO, Vec3::Y));
    world.insert_resource(GlobalAmbientLight {
        brightness: 20.0,
        ..default()
    });
    let skin = white_skin(world, "skin1", WIDTH_FACTOR);
    let light_dir = Vec3::new(0.2, 0.4, 1.0).normalize();
    let grey = world
        .resource_mut::<Assets<StandardMaterial>>()
        .add(StandardMaterial::from_color(Color::linear_rgb(
            0.3, 0.3, 0.3,
        )));
    let (card, bar) = {
        let mut meshes = world.resource_mut::<Assets<Mesh>>();
        (
            meshes.add(Rectangle::new(2.0, 1.4)),
            meshes.add(Cuboid::new(4.0, 0.12, 0.12)),
        )
    };
    world.spawn((Mesh3d(card), MeshMaterial3d(skin), Transform::default()));
    // Between the light and the card, out of the camera's view: a stripe of shadow across
    // the card, whose edges the blur softens.
    world.spawn((
        Mesh3d(bar),
        MeshMaterial3d(grey),
        Transform::from_translation(1.5 * light_dir),
    ));
    world.spawn((
        DirectionalLight {
            illuminance: 2000.0,
            shadow_maps_enabled: true,
            ..default()
        },
        Transform::from_translation(light_dir).looking_at(Vec3::ZERO, Vec3::Y),
        CascadeShadowConfigBuilder {
            num_cascades: 1,
            minimum_distance: 0.1,
            maximum_distance: 8.0,
            first_cascade_far_bound: 8.0,
            overlap_proportion: 0.2,
        }
        .build(),
    ));
    render_until_stable(&mut h, 600)
}

/// The kernels the plugin builds for skin1 at `High` (subsurface_bevy's render step).
fn skin1_kernels(samples: u32) -> Vec<subsurface_profile::ScreenKernels> {
    use subsurface_render::material::{MaterialCache, screen_kernels};
    let medium = subsurface_profile::Medium::Preset("skin1".into());
    let optics = MaterialCache::default().get(&medium, "skin").unwrap();
    let desc = subsurface_render::scene::MaterialDesc {
        medium,
        ..Default::default()
    };
    vec![screen_kernels(&optics, &desc, samples).unwrap()]
}

#[test]
fn the_blur_is_the_cpu_oracles() {
    if !gpu_available() {
        return;
    }
    let (plain, blurred) = (render(false), render(true));
    let n = (WIDTH * HEIGHT) as usize;
    let px = |data: &[u8], i: usize| pixel(data, i as u32 % WIDTH, i as u32 / WIDTH);
    let skin: Vec<bool> = (0..n).map(|i| px(&plain, i)[3] < 0.0).collect();
    let count = skin.iter().filter(|s| **s).count();
    assert!(count > n / 4, "the card covers {count} of {n} pixels");
    let input = ScreenInput {
        width: WIDTH,
        height: HEIGHT,
        color: (0..n)
            .map(|i| {
                let p = px(&plain, i);
                [p[0], p[1], p[2]]
            })
            .collect(),
        depth: vec![DISTANCE; n],
        strength: skin.iter().map(|&s| if s { 1.0 } else { 0.0 }).collect(),
        world_per_mm: vec![UNITS_PER_MM * WIDTH_FACTOR; n],
        profile: vec![0; n],
    };
    let sss = RenderSettings::preset(Quality::High).sss;
    // Bevy's default perspective: a vertical field of view of pi / 4.
    let params = ScreenParams {
        focal_px: 0.5 * HEIGHT as f32 / (std::f32::consts::FRAC_PI_8).tan(),
        follow_surface: sss.follow_surface,
        edge_mm: sss.edge_mm,
    };
    let want = separable(&input, &skin1_kernels(sss.samples), &params).unwrap();
    let (mut worst, mut changed) = (0.0f32, 0);
    for i in (0..n).filter(|&i| skin[i]) {
        let got = px(&blurred, i);
        for c in 0..3 {
            // subsurface-render's tests/sss.rs: 1e-3 for values up to 0.35 in Rgba16Float;
            // the card's lit side is brighter, and half-float steps grow with the value.
            let d = (got[c] - want[i][c]).abs() / want[i][c].max(0.35);
            worst = worst.max(d);
        }
        changed += usize::from((got[0] - input.color[i][0]).abs() > 1e-3);
    }
    eprintln!("{count} skin pixels, {changed} changed by the blur, worst relative error {worst}");
    assert!(
        changed > count / 10,
        "the blur changed only {changed} of {count} pixels"
    );
    assert!(
        worst < 1e-3 / 0.35,
        "worst difference from the oracle {worst} (relative to max(value, 0.35))"
    );
}
