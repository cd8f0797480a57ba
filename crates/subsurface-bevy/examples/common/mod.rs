//! What the `hand` and `head` examples share: a subsurface-render scene file turned into
//! Bevy entities, an orbit camera, keys that switch the plugin's effects, a line of text with
//! the plugin's GPU time, and the scripted modes (`--frames N --screenshot FILE.png`,
//! `--bench`).

use std::path::PathBuf;

use bevy::asset::RenderAssetUsages;
use bevy::camera::{Exposure, Hdr};
use bevy::core_pipeline::tonemapping::Tonemapping;
use bevy::diagnostic::{DiagnosticPath, DiagnosticsStore, FrameTimeDiagnosticsPlugin};
use bevy::input::mouse::{AccumulatedMouseMotion, AccumulatedMouseScroll};
use bevy::light::CascadeShadowConfigBuilder;
use bevy::mesh::{Indices, PrimitiveTopology};
use bevy::prelude::*;
use bevy::render::diagnostic::RenderDiagnosticsPlugin;
use bevy::render::render_resource::{Extent3d, TextureDimension, TextureFormat};
use bevy::render::view::screenshot::{Screenshot, save_to_disk};
use bevy::window::{PresentMode, WindowResolution};
use clap::Parser;
use subsurface_bevy::{Quality, Skin, SkinMaterial, Subsurface, SubsurfacePlugin};
use subsurface_render::scene::{LightKind, Scene};

/// The examples' command line.
#[derive(Parser, Debug, Clone)]
pub struct Args {
    /// Window width in physical pixels.
    #[arg(long, default_value_t = 1280)]
    pub width: u32,
    /// Window height in physical pixels.
    #[arg(long, default_value_t = 720)]
    pub height: u32,
    /// The plugin's quality preset at start: low, medium or high (Q cycles it).
    #[arg(long, default_value = "medium")]
    pub quality: Quality,
    /// Scripted mode: render N frames, write --screenshot, and exit.
    #[arg(long, value_name = "N")]
    pub frames: Option<u32>,
    /// With --frames: save the window's image as this PNG after the last frame.
    #[arg(long, value_name = "FILE.png")]
    pub screenshot: Option<PathBuf>,
    /// Measure: render 60 frames with the plugin and 60 without (after 30 to warm up each),
    /// print the median frame time of each and the plugin's median GPU time, and exit.
    #[arg(long)]
    pub bench: bool,
    /// Start without subsurface scattering (S toggles it).
    #[arg(long)]
    pub off: bool,
    /// Start without light through thin parts (T toggles it).
    #[arg(long)]
    pub no_transmittance: bool,
}

/// The scene's radiometric units against Bevy's photometric ones: subsurface-render lights a
/// surface with irradiance `intensity / distance^2`; Bevy divides a point light's lumens by
/// 4 pi for its intensity and scales radiance by the camera's exposure, 1 / 1.2 at EV100 = 0
/// (so a directional light's lux are 1.2 times the irradiance).
const LUMENS_PER_INTENSITY: f32 = 4.0 * std::f32::consts::PI * 1.2;

/// The camera's orbit: drag with the left button to turn, scroll to move closer.
#[derive(Component)]
pub struct Orbit {
    pub target: Vec3,
    pub yaw: f32,
    pub pitch: f32,
    pub distance: f32,
}

impl Orbit {
    fn from_eye(eye: Vec3, target: Vec3) -> Self {
        let d = eye - target;
        Self {
            target,
            yaw: d.x.atan2(d.z),
            pitch: (d.y / d.length()).asin(),
            distance: d.length(),
        }
    }

    fn transform(&self) -> Transform {
        let dir = Vec3::new(
            self.yaw.sin() * self.pitch.cos(),
            self.pitch.sin(),
            self.yaw.cos() * self.pitch.cos(),
        );
        Transform::from_translation(self.target + self.distance * dir)
            .looking_at(self.target, Vec3::Y)
    }
}

/// What the example runs and what it has measured.
#[derive(Resource)]
struct Run {
    args: Args,
    /// Scene units per millimetre of skin.
    units_per_mm: f32,
    frame: u32,
    quality: Quality,
    scattering: bool,
    transmittance: bool,
    /// `--bench`: frame times and the plugin's GPU times, with the plugin and without.
    bench_on: Vec<f64>,
    bench_off: Vec<f64>,
    bench_gpu: Vec<f64>,
}

impl Run {
    fn subsurface(&self) -> Subsurface {
        Subsurface {
            quality: self.quality,
            units_per_mm: self.units_per_mm,
            transmittance: self.transmittance,
        }
    }
}

/// The HUD line.
#[derive(Component)]
struct Hud;

/// Bevy's diagnostic path of the plugin's GPU time (its render step's time span).
const GPU_TIME: DiagnosticPath = DiagnosticPath::const_new("render/subsurface/elapsed_gpu");

/// Runs the example: `scene` drawn by Bevy with the plugin, in a window titled `title`.
pub fn run(title: &str, scene: Scene, args: Args) -> AppExit {
    let units_per_mm = scene.objects.first().map_or(0.001, |o| 1.0 / o.mm_per_unit);
    let (w, h) = (args.width, args.height);
    let mut app = App::new();
    app.add_plugins((
        DefaultPlugins.set(WindowPlugin {
            primary_window: Some(Window {
                title: title.into(),
                resolution: WindowResolution::new(w, h),
                // Frame times then show the GPU's pace, not the display's.
                present_mode: PresentMode::AutoNoVsync,
                ..default()
            }),
            ..default()
        }),
        SubsurfacePlugin,
        FrameTimeDiagnosticsPlugin::default(),
        RenderDiagnosticsPlugin,
    ))
    .insert_resource(Run {
        quality: args.quality,
        scattering: !args.off,
        transmittance: !args.no_transmittance,
        args,
        units_per_mm,
        frame: 0,
        bench_on: Vec::new(),
        bench_off: Vec::new(),
        bench_gpu: Vec::new(),
    })
    .insert_resource(SceneToSpawn(Some(scene)))
    .add_systems(Startup, spawn_scene)
    .add_systems(Update, (orbit, keys, hud, script));
    app.run()
}

#[derive(Resource)]
struct SceneToSpawn(Option<Scene>);

/// A subsurface-render mesh as a Bevy mesh (object space, with tangents for normal maps).
fn bevy_mesh(m: &subsurface_render::mesh::Mesh) -> Mesh {
    use bevy::mesh::VertexAttributeValues as Values;
    let v = &m.vertices;
    let mut mesh = Mesh::new(
        PrimitiveTopology::TriangleList,
        RenderAssetUsages::RENDER_WORLD,
    )
    .with_inserted_indices(Indices::U32(m.indices.clone()));
    for (attribute, values) in [
        (
            Mesh::ATTRIBUTE_POSITION,
            Values::Float32x3(v.iter().map(|v| v.position).collect()),
        ),
        (
            Mesh::ATTRIBUTE_NORMAL,
            Values::Float32x3(v.iter().map(|v| v.normal).collect()),
        ),
        (
            Mesh::ATTRIBUTE_UV_0,
            Values::Float32x2(v.iter().map(|v| v.uv).collect()),
        ),
        (
            Mesh::ATTRIBUTE_TANGENT,
            Values::Float32x4(v.iter().map(|v| v.tangent).collect()),
        ),
    ] {
        mesh.insert_attribute(attribute, values);
    }
    mesh
}

fn bevy_image(img: &image::RgbaImage, format: TextureFormat) -> Image {
    Image::new(
        Extent3d {
            width: img.width(),
            height: img.height(),
            depth_or_array_layers: 1,
        },
        TextureDimension::D2,
        img.as_raw().clone(),
        format,
        RenderAssetUsages::RENDER_WORLD,
    )
}

fn vec3(v: [f32; 3]) -> Vec3 {
    Vec3::from_array(v)
}

#[allow(clippy::too_many_arguments)]
fn spawn_scene(
    mut commands: Commands,
    mut to_spawn: ResMut<SceneToSpawn>,
    run: Res<Run>,
    mut meshes: ResMut<Assets<Mesh>>,
    mut images: ResMut<Assets<Image>>,
    mut skins: ResMut<Assets<SkinMaterial>>,
    mut plain: ResMut<Assets<StandardMaterial>>,
) {
    let Some(scene) = to_spawn.0.take() else {
        return;
    };
    let r = &scene.desc.render;
    let linear = |c: [f32; 3]| Color::linear_rgb(c[0], c[1], c[2]);
    commands.insert_resource(ClearColor(linear(r.background)));
    // The scene's ambient is a uniform radiance, which a diffuse surface returns times its
    // albedo; Bevy's ambient term is colour x brightness x albedo, then the exposure.
    commands.insert_resource(GlobalAmbientLight {
        color: linear(r.ambient),
        brightness: 1.2,
        ..default()
    });
    let cam = &scene.desc.camera;
    let (eye, target) = (vec3(cam.position), vec3(cam.target));
    let orbit = Orbit::from_eye(eye, target);
    let mut camera = commands.spawn((
        Camera3d::default(),
        Hdr,
        Msaa::Off,
        // Reinhard needs no lookup table (this crate builds Bevy without them).
        Tonemapping::Reinhard,
        // subsurface-render scales radiance by 2^exposure_ev; the lights and the ambient
        // below carry Bevy's factor 1.2 at EV100 = 0.
        Exposure {
            ev100: -scene.desc.render.exposure_ev,
        },
        Projection::Perspective(PerspectiveProjection {
            fov: cam.fov_y_deg.to_radians(),
            near: cam.near,
            far: cam.far,
            ..default()
        }),
        orbit.transform(),
        orbit,
    ));
    if run.scattering {
        camera.insert(run.subsurface());
    }
    for o in &scene.objects {
        let m = &o.material;
        // A measured medium's diffuse albedo colours the skin, as in subsurface-render.
        let medium_albedo = m.medium.diffuse_albedo().ok().flatten().unwrap_or([1.0; 3]);
        let a: [f32; 3] = std::array::from_fn(|c| o.albedo[c] * medium_albedo[c] as f32);
        let albedo = Color::linear_rgb(a[0], a[1], a[2]);
        let base = StandardMaterial {
            base_color: albedo,
            base_color_texture: o
                .albedo_texture
                .as_ref()
                .map(|t| images.add(bevy_image(t, TextureFormat::Rgba8UnormSrgb))),
            normal_map_texture: o
                .normal_texture
                .as_ref()
                .map(|t| images.add(bevy_image(t, TextureFormat::Rgba8Unorm))),
            // Beckmann m is close to GGX alpha, which Bevy takes as perceptual roughness squared;
            // skin's F0 of 0.028 (eta 1.4) is reflectance 0.42.
            perceptual_roughness: m.roughness.sqrt(),
            reflectance: 0.42,
            ..default()
        };
        let transform = Transform::from_matrix(Mat4::from_cols_array(&o.transform.to_cols_array()));
        let mesh = Mesh3d(meshes.add(bevy_mesh(&o.mesh)));
        // Any medium a scene file takes, preset or measured, scatters in Bevy too.
        if m.sss_strength > 0.0 {
            // The profile is in millimetres of this object's own units.
            let width = m.sss_width / (o.mm_per_unit * run.units_per_mm);
            let skin = SkinMaterial {
                base,
                extension: Skin::new(m.medium.clone(), width),
            };
            commands.spawn((mesh, MeshMaterial3d(skins.add(skin)), transform));
        } else {
            commands.spawn((mesh, MeshMaterial3d(plain.add(base)), transform));
        }
    }
    let (lo, hi) = scene.bounds();
    let radius = (hi - lo).length() * 0.5;
    for l in &scene.desc.lights {
        let (pos, aim) = (vec3(l.position), vec3(l.target));
        let color = Color::linear_rgb(l.color[0], l.color[1], l.color[2]);
        let shadows = l.shadow_map_size > 0;
        match l.kind {
            // Spot lights stay spot lights (the plugin's transmittance reads their maps as it
            // reads a directional light's cascade).
            LightKind::Spot => {
                commands.spawn((
                    SpotLight {
                        color,
                        intensity: l.intensity * LUMENS_PER_INTENSITY,
                        shadow_maps_enabled: shadows,
                        range: 100.0 * radius,
                        inner_angle: l.inner_angle_deg.to_radians(),
                        outer_angle: l.outer_angle_deg.to_radians(),
                        ..default()
                    },
                    Transform::from_translation(pos).looking_at(aim, Vec3::Y),
                ));
            }
            LightKind::Directional => {
                commands.spawn((
                    DirectionalLight {
                        color,
                        illuminance: l.intensity * 1.2,
                        shadow_maps_enabled: shadows,
                        ..default()
                    },
                    Transform::from_translation(pos).looking_at(aim, Vec3::Y),
                    // One cascade over the scene: fine texels on the skin, which the
                    // transmittance's thickness is read from.
                    CascadeShadowConfigBuilder {
                        num_cascades: 1,
                        minimum_distance: 0.01 * radius,
                        maximum_distance: eye.distance(target) + 2.0 * radius,
                        first_cascade_far_bound: eye.distance(target) + 2.0 * radius,
                        overlap_proportion: 0.2,
                    }
                    .build(),
                ));
            }
            LightKind::Point => {
                commands.spawn((
                    PointLight {
                        color,
                        intensity: l.intensity * LUMENS_PER_INTENSITY,
                        shadow_maps_enabled: shadows,
                        range: 100.0 * radius,
                        ..default()
                    },
                    Transform::from_translation(pos),
                ));
            }
        }
    }
    commands.spawn((
        Hud,
        Text::new(""),
        TextFont::from_font_size(16.0),
        Node {
            position_type: PositionType::Absolute,
            top: Val::Px(8.0),
            left: Val::Px(8.0),
            ..default()
        },
    ));
}

fn orbit(
    buttons: Res<ButtonInput<MouseButton>>,
    motion: Res<AccumulatedMouseMotion>,
    scroll: Res<AccumulatedMouseScroll>,
    mut cameras: Query<(&mut Orbit, &mut Transform)>,
) {
    for (mut o, mut t) in &mut cameras {
        if buttons.pressed(MouseButton::Left) {
            o.yaw -= motion.delta.x * 0.005;
            o.pitch = (o.pitch + motion.delta.y * 0.005).clamp(-1.5, 1.5);
        }
        if scroll.delta.y != 0.0 {
            o.distance *= (1.0 - 0.1 * scroll.delta.y.signum()).max(0.1);
        }
        *t = o.transform();
    }
}

/// S: scattering on/off; T: transmittance on/off; Q: the next quality preset; Esc: quit.
fn keys(
    keys: Res<ButtonInput<KeyCode>>,
    mut run: ResMut<Run>,
    mut commands: Commands,
    cameras: Query<Entity, With<Camera3d>>,
    mut exit: MessageWriter<AppExit>,
) {
    if keys.just_pressed(KeyCode::Escape) {
        exit.write(AppExit::Success);
    }
    let mut changed = false;
    if keys.just_pressed(KeyCode::KeyS) {
        run.scattering = !run.scattering;
        changed = true;
    }
    if keys.just_pressed(KeyCode::KeyT) {
        run.transmittance = !run.transmittance;
        changed = true;
    }
    if keys.just_pressed(KeyCode::KeyQ) {
        let all = Quality::ALL;
        let i = all.iter().position(|q| *q == run.quality).unwrap_or(0);
        run.quality = all[(i + 1) % all.len()];
        changed = true;
    }
    if changed {
        set_scattering(&mut commands, &cameras, &run, run.scattering);
    }
}

fn set_scattering(
    commands: &mut Commands,
    cameras: &Query<Entity, With<Camera3d>>,
    run: &Run,
    on: bool,
) {
    for camera in cameras {
        if on {
            commands.entity(camera).insert(run.subsurface());
        } else {
            commands.entity(camera).remove::<Subsurface>();
        }
    }
}

fn ms(store: &DiagnosticsStore, path: &DiagnosticPath) -> Option<f64> {
    store.get(path).and_then(|d| d.smoothed())
}

fn hud(store: Res<DiagnosticsStore>, run: Res<Run>, mut text: Query<&mut Text, With<Hud>>) {
    let frame = ms(&store, &FrameTimeDiagnosticsPlugin::FRAME_TIME);
    let gpu = ms(&store, &GPU_TIME);
    let line = format!(
        "subsurface {} ({}, transmittance {}): GPU {}   frame {}\n[S] scattering  [T] transmittance  [Q] quality  drag: orbit  wheel: zoom",
        if run.scattering { "on" } else { "off" },
        run.quality.name(),
        if run.transmittance { "on" } else { "off" },
        gpu.filter(|_| run.scattering)
            .map_or("-".into(), |g| format!("{g:.3} ms")),
        frame.map_or("-".into(), |f| format!("{f:.1} ms")),
    );
    for mut t in &mut text {
        t.0.clone_from(&line);
    }
}

/// Frames before `--bench` measures (pipelines compile over the first frames).
const WARMUP: u32 = 30;
const MEASURED: u32 = 60;

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(f64::NAN)
}

/// `--frames N --screenshot FILE` and `--bench`.
fn script(
    mut run: ResMut<Run>,
    time: Res<Time<Real>>,
    store: Res<DiagnosticsStore>,
    mut commands: Commands,
    cameras: Query<Entity, With<Camera3d>>,
    mut exit: MessageWriter<AppExit>,
) {
    run.frame += 1;
    let frame = run.frame;
    if run.args.bench {
        let dt = time.delta().as_secs_f64() * 1e3;
        let (on_start, off_start) = (WARMUP, 2 * WARMUP + MEASURED);
        if frame == 1 {
            set_scattering(&mut commands, &cameras, &run, true);
        } else if frame > on_start && frame <= on_start + MEASURED {
            run.bench_on.push(dt);
            if let Some(g) = store.get(&GPU_TIME).and_then(|d| d.value()) {
                run.bench_gpu.push(g);
            }
        } else if frame == on_start + MEASURED + 1 {
            set_scattering(&mut commands, &cameras, &run, false);
        } else if frame > off_start && frame <= off_start + MEASURED {
            run.bench_off.push(dt);
        } else if frame > off_start + MEASURED {
            let (w, h) = (run.args.width, run.args.height);
            let on = median(&mut run.bench_on);
            let off = median(&mut run.bench_off);
            let gpu = median(&mut run.bench_gpu);
            println!(
                "{w}x{h} {}: frame {on:.2} ms with the plugin, {off:.2} ms without; the plugin's GPU time {gpu:.3} ms (medians of {MEASURED} frames)",
                run.quality.name()
            );
            exit.write(AppExit::Success);
        }
        return;
    }
    let Some(n) = run.args.frames else {
        return;
    };
    if frame == n {
        if let Some(path) = run.args.screenshot.clone() {
            commands
                .spawn(Screenshot::primary_window())
                .observe(save_to_disk(path.clone()))
                .observe(
                    move |_: On<bevy::render::view::screenshot::ScreenshotCaptured>,
                          mut exit: MessageWriter<AppExit>| {
                        println!("wrote {}", path.display());
                        exit.write(AppExit::Success);
                    },
                );
        } else {
            exit.write(AppExit::Success);
        }
    } else if frame > n + 600 {
        // The screenshot never came back.
        eprintln!("error: no screenshot after 600 frames");
        exit.write(AppExit::error());
    }
}
