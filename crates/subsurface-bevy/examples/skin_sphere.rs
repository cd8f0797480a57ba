//! A skin sphere rendered headless by Bevy with `SubsurfacePlugin`, written as a PNG.
//!
//! ```text
//! XDG_RUNTIME_DIR=/tmp/xdg WGPU_BACKEND=vulkan \
//!   cargo +1.97.1 run -p subsurface-bevy --example skin_sphere -- [OUT.png] [--off]
//! ```
//! `--off` leaves `Subsurface` off the camera (the same frame without scattering). The
//! image is the HDR radiance clamped to [0, 1] and sRGB-encoded (no tone mapper: this crate
//! builds Bevy without the tone-mapping LUTs).

use std::sync::{Arc, Mutex};

use bevy::app::PluginsState;
use bevy::camera::{Hdr, RenderTarget};
use bevy::color::ColorToPacked;
use bevy::core_pipeline::tonemapping::Tonemapping;
use bevy::light::{CascadeShadowConfigBuilder, ShadowFilteringMethod};
use bevy::prelude::*;
use bevy::render::gpu_readback::{Readback, ReadbackComplete};
use bevy::render::render_resource::{TextureFormat, TextureUsages};
use bevy::window::ExitCondition;
use subsurface_bevy::{Quality, Skin, SkinMaterial, Subsurface, SubsurfacePlugin};

const SIZE: (u32, u32) = (640, 480);

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let off = args.iter().any(|a| a == "--off");
    let out = args
        .iter()
        .find(|a| !a.starts_with("--"))
        .cloned()
        .unwrap_or_else(|| "skin_sphere.png".into());

    let mut app = App::new();
    app.add_plugins((
        // Headless: no window, and no winit event loop (the other examples' features add it).
        DefaultPlugins
            .set(WindowPlugin {
                primary_window: None,
                exit_condition: ExitCondition::DontExit,
                ..default()
            })
            .disable::<bevy::winit::WinitPlugin>(),
        SubsurfacePlugin,
    ));
    // Without a window there is no runner: finish the plugins (the renderer starts
    // asynchronously) and call `update` here.
    while app.plugins_state() == PluginsState::Adding {
        bevy::tasks::tick_global_task_pools_on_main_thread();
    }
    app.finish();
    app.cleanup();

    let world = app.world_mut();
    let mut image = Image::new_target_texture(SIZE.0, SIZE.1, TextureFormat::Rgba16Float, None);
    image.texture_descriptor.usage |= TextureUsages::COPY_SRC;
    let target = world.resource_mut::<Assets<Image>>().add(image);
    let mut camera = world.spawn((
        Camera3d::default(),
        RenderTarget::Image(target.clone().into()),
        Hdr,
        Tonemapping::None,
        Msaa::Off,
        ShadowFilteringMethod::Hardware2x2,
        // A 10 cm ball seen from 25 cm: skin at the scale it has.
        Transform::from_xyz(0.0, 0.03, 0.25).looking_at(Vec3::ZERO, Vec3::Y),
    ));
    if !off {
        // `High`: 17 fixed taps; `Medium` and `Low` take 7 jittered taps, which leave
        // fine noise where the light changes fast, as at this shadow's edges.
        camera.insert(Subsurface {
            quality: Quality::High,
            ..default()
        });
    }
    let sphere = world
        .resource_mut::<Assets<Mesh>>()
        .add(Sphere::new(0.05).mesh().uv(128, 64));
    let skin = world
        .resource_mut::<Assets<SkinMaterial>>()
        .add(SkinMaterial {
            base: StandardMaterial {
                base_color: Color::linear_rgb(0.75, 0.5, 0.4),
                perceptual_roughness: 0.45,
                ..default()
            },
            extension: Skin::new("skin1", 1.0),
        });
    world.spawn((Mesh3d(sphere), MeshMaterial3d(skin)));
    // A bar between the light and the ball, behind the camera, casts a shadow stripe across
    // it: the shadow's edges are where scattering shows (light bleeds red into the shadow).
    let light_dir = Vec3::new(0.5, 0.3, 1.0).normalize();
    let bar = world
        .resource_mut::<Assets<Mesh>>()
        .add(Cuboid::new(0.008, 0.3, 0.008));
    let grey = world
        .resource_mut::<Assets<StandardMaterial>>()
        .add(StandardMaterial::from_color(Color::linear_rgb(
            0.3, 0.3, 0.3,
        )));
    world.spawn((
        Mesh3d(bar),
        MeshMaterial3d(grey),
        Transform::from_translation(0.5 * light_dir),
    ));
    world.spawn((
        DirectionalLight {
            illuminance: 1500.0,
            shadow_maps_enabled: true,
            ..default()
        },
        Transform::from_translation(light_dir).looking_at(Vec3::ZERO, Vec3::Y),
        // One cascade over the first metre: texels of half a millimetre, a crisp shadow
        // edge at this scale (the default cascades span 150 m).
        CascadeShadowConfigBuilder {
            num_cascades: 1,
            minimum_distance: 0.01,
            maximum_distance: 1.0,
            first_cascade_far_bound: 1.0,
            overlap_proportion: 0.2,
        }
        .build(),
    ));

    let slot: Arc<Mutex<Option<Vec<u8>>>> = Arc::default();
    let sink = slot.clone();
    world
        .spawn(Readback::texture(target))
        .observe(move |event: On<ReadbackComplete>| {
            *sink.lock().unwrap() = Some(event.data.clone());
        });

    // Pipelines compile over the first frames; a finished frame repeats exactly.
    let mut previous = None;
    let data = loop {
        app.update();
        let Some(current) = slot.lock().unwrap().take() else {
            continue;
        };
        if previous.as_ref() == Some(&current) {
            break current;
        }
        previous = Some(current);
    };

    let img = image::RgbImage::from_fn(SIZE.0, SIZE.1, |x, y| {
        let i = 8 * (y * SIZE.0 + x) as usize;
        let c =
            |k: usize| half::f16::from_le_bytes([data[i + 2 * k], data[i + 2 * k + 1]]).to_f32();
        let linear = LinearRgba::rgb(c(0), c(1), c(2));
        image::Rgb(Srgba::from(linear).to_u8_array_no_alpha())
    });
    img.save(&out)?;
    println!("wrote {out}");
    Ok(())
}
