//! A headless Bevy app for the GPU tests: no window and no winit; one HDR camera draws into an
//! `Image` that is read back every frame.
#![allow(dead_code)] // each test binary uses part of it

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use bevy::app::PluginsState;
use bevy::camera::{Hdr, RenderTarget};
use bevy::color::ColorToPacked;
use bevy::core_pipeline::tonemapping::{DebandDither, Tonemapping};
use bevy::prelude::*;
use bevy::render::gpu_readback::{Readback, ReadbackComplete};
use bevy::render::render_resource::{TextureFormat, TextureUsages};
use bevy::window::ExitCondition;
use subsurface_bevy::{Skin, SkinMaterial, SkinMedium};

pub const WIDTH: u32 = 160;
pub const HEIGHT: u32 = 120;
/// The camera's clear colour (linear). Background pixels must come back as exactly this.
pub const CLEAR: [f32; 4] = [0.05, 0.1, 0.2, 1.0];

/// True when an adapter is there. Without one the GPU tests skip, unless
/// `SUBSURFACE_REQUIRE_GPU=1`, when they fail (Bevy's RenderPlugin would panic with a less
/// helpful message, so the adapter is looked for first, the way subsurface-render's tests do).
pub fn gpu_available() -> bool {
    match subsurface_render::GpuContext::new_headless() {
        Ok(_) => true,
        Err(e) if subsurface_render::gpu_required() => {
            panic!("SUBSURFACE_REQUIRE_GPU=1 but no adapter: {e}")
        }
        Err(e) => {
            eprintln!("skipped: no GPU adapter ({e})");
            false
        }
    }
}

/// The last image read back, as f16 bit patterns (Rgba16Float target).
pub type Slot = Arc<Mutex<Option<Vec<u8>>>>;

pub struct Headless {
    pub app: App,
    pub target: Handle<Image>,
    pub camera: Entity,
    pub readback: Slot,
}

/// DefaultPlugins without a primary window and without winit (the examples' dev-dependency
/// features add it; its event loop refuses a test's thread). The runner is never used: the
/// tests call `update` themselves.
pub fn app() -> App {
    let mut app = App::new();
    app.add_plugins(
        DefaultPlugins
            .set(WindowPlugin {
                primary_window: None,
                exit_condition: ExitCondition::DontExit,
                ..default()
            })
            .disable::<bevy::winit::WinitPlugin>(),
    );
    app
}

/// Finishes plugin setup the way Bevy's own runner does (the renderer is created
/// asynchronously), spawns the camera with its image target and readback.
pub fn setup(app: App, camera_extra: impl Bundle) -> Headless {
    setup_with(app, camera_extra, Tonemapping::None)
}

/// As [`setup`], with this tone mapper (one that needs no LUT: this crate leaves Bevy's
/// `tonemapping_luts` feature out).
pub fn setup_with(app: App, camera_extra: impl Bundle, tonemapping: Tonemapping) -> Headless {
    setup_sized(app, camera_extra, tonemapping, (WIDTH, HEIGHT))
}

/// As [`setup_with`], at another size (only for tests that read no pixels).
pub fn setup_sized(
    mut app: App,
    camera_extra: impl Bundle,
    tonemapping: Tonemapping,
    (width, height): (u32, u32),
) -> Headless {
    let start = Instant::now();
    while app.plugins_state() == PluginsState::Adding {
        bevy::tasks::tick_global_task_pools_on_main_thread();
        assert!(
            start.elapsed() < Duration::from_secs(120),
            "the renderer did not start"
        );
    }
    app.finish();
    app.cleanup();

    // Rgba16Float keeps the HDR values: the test reads linear radiance, not a tone-mapped
    // 8-bit image, so "unchanged" can be checked bit for bit.
    let mut image = Image::new_target_texture(width, height, TextureFormat::Rgba16Float, None);
    image.texture_descriptor.usage |= TextureUsages::COPY_SRC;
    let target = app.world_mut().resource_mut::<Assets<Image>>().add(image);

    let camera = app
        .world_mut()
        .spawn((
            Camera3d::default(),
            Camera {
                clear_color: ClearColorConfig::Custom(Color::LinearRgba(LinearRgba::new(
                    CLEAR[0], CLEAR[1], CLEAR[2], CLEAR[3],
                ))),
                ..default()
            },
            RenderTarget::Image(target.clone().into()),
            Hdr,
            // No tone mapping (by default), dithering or MSAA: the target holds the lit
            // radiance itself, the same on every run.
            tonemapping,
            DebandDither::Disabled,
            Msaa::Off,
            Transform::from_xyz(0.0, 1.2, 5.0).looking_at(Vec3::new(0.0, -0.2, 0.0), Vec3::Y),
            camera_extra,
        ))
        .id();

    let readback: Slot = Arc::default();
    let slot = readback.clone();
    app.world_mut()
        .spawn(Readback::texture(target.clone()))
        .observe(move |event: On<ReadbackComplete>| {
            *slot.lock().unwrap() = Some(event.data.clone());
        });
    Headless {
        app,
        target,
        camera,
        readback,
    }
}

/// A grey sphere of radius 1 at the origin on a ground plane at y = -1, lit from above by a
/// shadow-casting directional light; dim ambient light so the unlit side stays dark.
pub fn spawn_scene(app: &mut App, sphere_material: impl Bundle) {
    let world = app.world_mut();
    world.insert_resource(GlobalAmbientLight {
        brightness: 40.0,
        ..default()
    });
    let (sphere, plane) = {
        let mut meshes = world.resource_mut::<Assets<Mesh>>();
        (
            meshes.add(Sphere::new(1.0).mesh().uv(64, 32)),
            meshes.add(Plane3d::default().mesh().size(20.0, 20.0)),
        )
    };
    let ground = world
        .resource_mut::<Assets<StandardMaterial>>()
        .add(StandardMaterial {
            base_color: Color::linear_rgb(0.5, 0.5, 0.5),
            perceptual_roughness: 0.9,
            ..default()
        });
    world.spawn((Mesh3d(sphere), sphere_material, Transform::default()));
    world.spawn((
        Mesh3d(plane),
        MeshMaterial3d(ground),
        Transform::from_xyz(0.0, -1.0, 0.0),
    ));
    world.spawn((
        DirectionalLight {
            illuminance: 3000.0,
            shadow_maps_enabled: true,
            ..default()
        },
        // Light from above, slightly from the front-left.
        Transform::from_xyz(-0.5, 4.0, 1.0).looking_at(Vec3::ZERO, Vec3::Y),
    ));
}

/// The scene of [`spawn_scene`] with `sphere_material`, rendered until stable.
pub fn render_scene(h: &mut Headless, sphere_material: impl Bundle) -> Vec<u8> {
    spawn_scene(&mut h.app, sphere_material);
    render_until_stable(h, 600)
}

/// A pixel of the image: linear RGBA.
pub fn pixel(data: &[u8], x: u32, y: u32) -> [f32; 4] {
    let i = 8 * (y * WIDTH + x) as usize;
    std::array::from_fn(|c| {
        half::f16::from_le_bytes([data[i + 2 * c], data[i + 2 * c + 1]]).to_f32()
    })
}

/// The raw bits of a pixel (for comparisons that must be exact).
pub fn pixel_bits(data: &[u8], x: u32, y: u32) -> [u8; 8] {
    let i = 8 * (y * WIDTH + x) as usize;
    data[i..i + 8].try_into().unwrap()
}

/// Bevy draws pipelines that are not compiled yet with nothing (or a magenta placeholder);
/// this tells those frames from a finished one.
pub fn is_magenta(p: [f32; 4]) -> bool {
    p[0] > 0.5 && p[2] > 0.5 && p[1] < 0.2 * p[0]
}

/// Relative luminance (Rec. 709) of a linear pixel.
pub fn luminance(p: [f32; 4]) -> f32 {
    0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2]
}

/// Adds `asset` to the app's `Assets<A>`.
pub fn add_asset<A: Asset>(app: &mut App, asset: A) -> Handle<A> {
    app.world_mut().resource_mut::<Assets<A>>().add(asset)
}

/// The frames `render` gives with what a test compares switched off (`false`) and on
/// (`true`); None when the test is skipped for want of an adapter ([`gpu_available`]).
pub fn off_and_on(render: impl Fn(bool) -> Vec<u8>) -> Option<(Vec<u8>, Vec<u8>)> {
    gpu_available().then(|| (render(false), render(true)))
}

/// Asserts that the mean light a scattering step added per channel, `gain`, is at least
/// `min_red` in red and falls by more than `ratio` from red to green and from green to blue:
/// skin's red travels furthest. `none` and `not_reddest` say what failed.
pub fn assert_reddest(gain: [f64; 3], min_red: f64, ratio: f64, none: &str, not_reddest: &str) {
    assert!(gain[0] > min_red, "{none}: {gain:?}");
    assert!(
        gain[0] > ratio * gain[1] && gain[1] > ratio * gain[2],
        "{not_reddest}: {gain:?}"
    );
}

/// Where a world point lands in the image (pixel coordinates).
pub fn project(app: &mut App, camera: Entity, point: Vec3) -> (u32, u32) {
    let world = app.world_mut();
    let mut q = world.query::<(&Camera, &GlobalTransform)>();
    let (cam, transform) = q.get(world, camera).expect("camera");
    let p = cam
        .world_to_viewport(transform, point)
        .unwrap_or_else(|e| panic!("{point} is not on screen: {e:?}"));
    (p.x as u32, p.y as u32)
}

/// Runs frames until every pipeline is compiled and two consecutive read-back images are
/// identical (the scene is static, so a finished frame repeats), then returns that image.
pub fn render_until_stable(h: &mut Headless, max_frames: u32) -> Vec<u8> {
    let start = Instant::now();
    let mut previous: Option<Vec<u8>> = None;
    for frame in 0..max_frames {
        h.app.update();
        let waiting = h
            .app
            .sub_app(bevy::render::RenderApp)
            .world()
            .resource::<bevy::render::render_resource::PipelineCache>()
            .waiting_pipelines()
            .count();
        let current = h.readback.lock().unwrap().take();
        let Some(current) = current else { continue };
        // Every 7th pixel, whatever the image's size.
        let magenta = current.chunks_exact(8).step_by(7).any(|p| {
            is_magenta(std::array::from_fn(|c| {
                half::f16::from_le_bytes([p[2 * c], p[2 * c + 1]]).to_f32()
            }))
        });
        if waiting == 0 && !magenta && previous.as_ref() == Some(&current) {
            eprintln!(
                "stable after {frame} frames, {:.1} s",
                start.elapsed().as_secs_f32()
            );
            return current;
        }
        previous = Some(current);
    }
    panic!("no stable image after {max_frames} frames");
}

/// With `SUBSURFACE_BEVY_OUT=DIR`, writes the image as `DIR/NAME.png` (radiance clamped to
/// [0, 1], sRGB-encoded) to look at.
pub fn dump(data: &[u8], name: &str) {
    let Ok(dir) = std::env::var("SUBSURFACE_BEVY_OUT") else {
        return;
    };
    let img = image::RgbImage::from_fn(WIDTH, HEIGHT, |x, y| {
        let p = pixel(data, x, y);
        image::Rgb(Srgba::from(LinearRgba::rgb(p[0], p[1], p[2])).to_u8_array_no_alpha())
    });
    std::fs::create_dir_all(&dir).unwrap();
    let path = std::path::Path::new(&dir).join(format!("{name}.png"));
    img.save(&path).unwrap();
    eprintln!("wrote {}", path.display());
}

/// Adds a second camera (another `Image` target and read-back) to a [`Headless`] app, at
/// `transform`, with `extra` components.
pub fn add_camera(h: &mut Headless, transform: Transform, extra: impl Bundle) -> Slot {
    let mut image = Image::new_target_texture(WIDTH, HEIGHT, TextureFormat::Rgba16Float, None);
    image.texture_descriptor.usage |= TextureUsages::COPY_SRC;
    let world = h.app.world_mut();
    let target = world.resource_mut::<Assets<Image>>().add(image);
    world.spawn((
        Camera3d::default(),
        Camera {
            clear_color: ClearColorConfig::Custom(Color::LinearRgba(LinearRgba::new(
                CLEAR[0], CLEAR[1], CLEAR[2], CLEAR[3],
            ))),
            // After the first camera: each camera has its own order.
            order: 1,
            ..default()
        },
        RenderTarget::Image(target.clone().into()),
        Hdr,
        Tonemapping::None,
        DebandDither::Disabled,
        Msaa::Off,
        transform,
        extra,
    ));
    let slot: Slot = Arc::default();
    let sink = slot.clone();
    world
        .spawn(Readback::texture(target))
        .observe(move |event: On<ReadbackComplete>| {
            *sink.lock().unwrap() = Some(event.data.clone());
        });
    slot
}

/// A skin material: `base` with the skin extension of `medium` at profile `width`.
pub fn add_skin(
    world: &mut World,
    base: StandardMaterial,
    medium: impl Into<SkinMedium>,
    width: f32,
) -> Handle<SkinMaterial> {
    world
        .resource_mut::<Assets<SkinMaterial>>()
        .add(SkinMaterial {
            base,
            extension: Skin::new(medium, width),
        })
}

/// A matte white skin material of `medium` at profile `width`: the tests read the light the
/// skin adds, not its colour.
pub fn white_skin(world: &mut World, medium: &str, width: f32) -> Handle<SkinMaterial> {
    let base = StandardMaterial {
        base_color: Color::WHITE,
        perceptual_roughness: 0.8,
        ..default()
    };
    add_skin(world, base, medium, width)
}
