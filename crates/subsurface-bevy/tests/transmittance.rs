//! Transmittance from Bevy's shadow maps: a 3 mm skin slab lit from straight behind by a
//! shadow-casting directional, spot or point light, seen from its dark side 30 degrees off its
//! normal (out of the unscattered lobe, which leaves along the light), beside a 10 cm skin
//! ball lit the same way. With transmittance the slab's dark side gains light, reddest, as
//! much as exact slab transport says 3 mm of skin passes; the ball's dark side, 10 cm
//! through, gains nothing; nothing but skin changes.

use crate::common;

use bevy::light::CascadeShadowConfigBuilder;
use bevy::prelude::*;
use common::*;
use subsurface_bevy::{Quality, Subsurface, SubsurfacePlugin};

const THICKNESS_MM: f32 = 3.0;
const SLAB: Vec3 = Vec3::new(-0.09, 0.0, 0.0);
const BALL: Vec3 = Vec3::new(0.1, 0.0, 0.0);
const BALL_RADIUS: f32 = 0.05;
const ILLUMINANCE: f32 = 10_000.0;
/// The spot light's and the point light's distance behind the scene's centre, metres.
const SPOT_M: f32 = 3.0;
const POINT_M: f32 = 2.0;

/// The light behind the slab.
#[derive(Clone, Copy)]
enum Backlight {
    Directional {
        shadows: bool,
    },
    Spot,
    Point,
    /// The point light on Bevy's default cube size, beside a shadow-casting directional
    /// light from the camera's side: the cube's faces follow the sun's cascade in our maps,
    /// smaller than it.
    PointAfterSun,
}

impl Backlight {
    /// The irradiance at the slab's centre, as a share of `ILLUMINANCE`: 1 for the
    /// directional light; for the others, whose intensity gives `ILLUMINANCE` at the scene's
    /// centre, the inverse square and the cosine of the slab's offset.
    fn share_at_slab(self) -> f32 {
        let d = match self {
            Backlight::Directional { .. } => return 1.0,
            Backlight::Spot => SPOT_M,
            Backlight::Point | Backlight::PointAfterSun => POINT_M,
        };
        let r2 = d * d + SLAB.length_squared();
        d.powi(3) / r2.powf(1.5)
    }
}
/// The camera's angle to the slab's normal.
const VIEW_DEG: f32 = 30.0;

/// `None`: no `Subsurface` on the camera (the skin keeps its marker, which tells the skin
/// pixels); `Some(t)`: `Subsurface` with transmittance `t`.
fn render(transmittance: Option<bool>) -> Vec<u8> {
    render_with(
        transmittance,
        Backlight::Directional { shadows: true },
        None,
    )
}

/// As [`render`], with the light `light`; with `first_eye`, the camera first renders a
/// stable frame from there, then moves to its place.
fn render_with(transmittance: Option<bool>, light: Backlight, first_eye: Option<Vec3>) -> Vec<u8> {
    let mut app = app();
    app.add_plugins(SubsurfacePlugin);
    let mut h = match transmittance {
        // High: fixed taps, no jitter noise in the comparison.
        Some(transmittance) => setup(
            app,
            Subsurface {
                quality: Quality::High,
                transmittance,
                ..default()
            },
        ),
        None => setup(app, ()),
    };
    let a = VIEW_DEG.to_radians();
    let eye = Vec3::new(0.5 * a.sin(), 0.0, 0.5 * a.cos());
    let world = h.app.world_mut();
    world.entity_mut(h.camera).insert(
        Transform::from_translation(first_eye.unwrap_or(eye)).looking_at(Vec3::ZERO, Vec3::Y),
    );
    world.insert_resource(GlobalAmbientLight {
        brightness: 0.0,
        ..default()
    });
    let skin = common::white_skin(world, "skin", 1.0);
    let grey = world
        .resource_mut::<Assets<StandardMaterial>>()
        .add(StandardMaterial {
            base_color: Color::linear_rgb(0.5, 0.5, 0.5),
            ..default()
        });
    let (slab, ball, bead) = {
        let mut meshes = world.resource_mut::<Assets<Mesh>>();
        (
            meshes.add(Cuboid::new(0.12, 0.16, THICKNESS_MM / 1000.0)),
            meshes.add(Sphere::new(BALL_RADIUS).mesh().uv(64, 32)),
            meshes.add(Sphere::new(0.03).mesh().uv(32, 16)),
        )
    };
    world.spawn((
        Mesh3d(slab),
        MeshMaterial3d(skin.clone()),
        Transform::from_translation(SLAB),
    ));
    world.spawn((
        Mesh3d(ball),
        MeshMaterial3d(skin),
        Transform::from_translation(BALL),
    ));
    // Not skin, partly lit (the camera sees the edge of its lit side): must not change at
    // all.
    world.spawn((
        Mesh3d(bead),
        MeshMaterial3d(grey),
        Transform::from_xyz(0.0, 0.13, -0.05),
    ));
    // Spot and point lights: lumens whose candela give ILLUMINANCE lux at the scene's
    // centre; a range far beyond the scene, so Bevy's fade near it does not dim them.
    let lumens = |d: f32| ILLUMINANCE * 4.0 * std::f32::consts::PI * d * d;
    // From straight behind the slab: along +z, toward the camera's side.
    let behind = |d: f32| Transform::from_xyz(0.0, 0.0, -d).looking_at(Vec3::ZERO, Vec3::Y);
    match light {
        Backlight::Directional { shadows } => {
            world.spawn((
                DirectionalLight {
                    illuminance: ILLUMINANCE,
                    shadow_maps_enabled: shadows,
                    ..default()
                },
                behind(1.0),
                // One cascade over the close scene: its texels are 1.5 mm (the default's
                // first cascade spans 10 m).
                CascadeShadowConfigBuilder {
                    num_cascades: 1,
                    minimum_distance: 0.1,
                    maximum_distance: 1.5,
                    first_cascade_far_bound: 1.5,
                    overlap_proportion: 0.2,
                }
                .build(),
            ));
        }
        // A narrow cone over the scene: 0.3 mm texels on the 2048² map at 3 m; the scene
        // lies inside the inner angle.
        Backlight::Spot => {
            world.spawn((
                SpotLight {
                    intensity: lumens(SPOT_M),
                    range: 100.0,
                    inner_angle: 0.09,
                    outer_angle: 0.1,
                    shadow_maps_enabled: true,
                    ..default()
                },
                behind(SPOT_M),
            ));
        }
        // 2 mm texels on 2048² cube faces at 2 m.
        Backlight::Point | Backlight::PointAfterSun => {
            if let Backlight::PointAfterSun = light {
                // It lights the side the camera sees: nothing of it crosses the slab.
                world.spawn((
                    DirectionalLight {
                        illuminance: ILLUMINANCE,
                        shadow_maps_enabled: true,
                        ..default()
                    },
                    Transform::from_xyz(0.3, 0.2, 1.0).looking_at(Vec3::ZERO, Vec3::Y),
                ));
            } else {
                world.insert_resource(bevy::light::PointLightShadowMap { size: 2048 });
            }
            world.spawn((
                PointLight {
                    intensity: lumens(POINT_M),
                    range: 100.0,
                    shadow_maps_enabled: true,
                    ..default()
                },
                behind(POINT_M),
            ));
        }
    }
    if first_eye.is_some() {
        render_until_stable(&mut h, 600);
        h.app
            .world_mut()
            .entity_mut(h.camera)
            .insert(Transform::from_translation(eye).looking_at(Vec3::ZERO, Vec3::Y));
        // Read-backs of frames drawn before the move are still in flight: two of them in a
        // row would look stable.
        for _ in 0..8 {
            h.app.update();
        }
        h.readback.lock().unwrap().take();
    }
    let image = render_until_stable(&mut h, 600);
    // The test splits the image between the two at its middle column.
    let (slab_px, ball_px) = (
        project(&mut h.app, h.camera, SLAB),
        project(&mut h.app, h.camera, BALL),
    );
    assert!(
        slab_px.0 < WIDTH / 2 && ball_px.0 > WIDTH / 2,
        "{slab_px:?} {ball_px:?}"
    );
    image
}

/// What subsurface-render's `diffusion` sends toward the camera through `s_mm` of skin1 (the
/// Gaussian `skin` preset's medium) per unit of back irradiance, at cosine `c` to the flow
/// and exit cosine `mu_o`, by subsurface-profile's oracle (roughness 0.3, eta 1.3).
fn skin1_transport_t(s_mm: f32, c: f32, mu_o: f32) -> [f32; 3] {
    let skin1 =
        subsurface_profile::Dipole::new([0.032, 0.17, 0.48], [0.74, 0.88, 1.01], 1.3).unwrap();
    subsurface_profile::oracle::transmitted::SlabTransmission::new(&skin1, 32.0, 0.3, 1.3)
        .unwrap()
        .toward(s_mm, c, mu_o)
}

fn mean_gain(on: &[u8], off: &[u8], pixels: &[(u32, u32)]) -> [f64; 3] {
    let mut sum = [0.0f64; 3];
    for &(x, y) in pixels {
        let (p, q) = (pixel(off, x, y), pixel(on, x, y));
        for c in 0..3 {
            sum[c] += f64::from(q[c] - p[c]);
        }
    }
    sum.map(|s| s / pixels.len().max(1) as f64)
}

#[test]
fn thin_backlit_skin_transmits_red_light_and_thick_skin_none() {
    thin_slab_transmits(Backlight::Directional { shadows: true }, "directional");
}

/// The same through a spot light's map, which Bevy keeps after every camera's cascades.
#[test]
fn a_spot_light_transmits_through_thin_skin() {
    thin_slab_transmits(Backlight::Spot, "spot");
}

/// The same through a point light's cube map (the face toward the scene is Bevy's +Z,
/// subsurface-render's face 4).
#[test]
fn a_point_light_transmits_through_thin_skin() {
    thin_slab_transmits(Backlight::Point, "point");
}

/// The same with a directional light's cascade in the layer before the cube's faces, the
/// cube smaller than the cascade (Bevy's default sizes): a layer or a size mixed up between
/// the two reads no light.
#[test]
fn a_point_light_after_a_sun_transmits_through_thin_skin() {
    thin_slab_transmits(Backlight::PointAfterSun, "point after sun");
}

fn thin_slab_transmits(light: Backlight, name: &str) {
    let Some((off, on)) = off_and_on(|t| render_with(Some(t), light, None)) else {
        return;
    };
    let marked = render_with(None, light, None);
    dump(&off, &format!("transmit_{name}_off"));
    dump(&on, &format!("transmit_{name}_on"));
    let skin = |x: u32, y: u32| pixel(&marked, x, y)[3] < 0.0;
    // Skin pixels 4 pixels or more from anything else: the blur's footprint and the
    // rebuilt normal stay on one surface.
    let interior = |x: u32, y: u32| {
        (4..WIDTH - 4).contains(&x)
            && (4..HEIGHT - 4).contains(&y)
            && (y - 4..=y + 4).all(|v| (x - 4..=x + 4).all(|u| skin(u, v)))
    };
    let (mut slab, mut ball, mut changed_elsewhere) = (Vec::new(), Vec::new(), 0);
    // The ball lies right of the image's centre, the slab left of it.
    let split = WIDTH / 2;
    let mut ball_pixels = Vec::new();
    for y in 0..HEIGHT {
        for x in 0..WIDTH {
            if !skin(x, y) {
                changed_elsewhere += usize::from(pixel_bits(&on, x, y) != pixel_bits(&off, x, y));
                continue;
            }
            if x >= split {
                ball_pixels.push((x, y));
            }
            if interior(x, y) {
                if x < split {
                    slab.push((x, y));
                } else {
                    ball.push((x, y));
                }
            }
        }
    }
    assert_eq!(changed_elsewhere, 0, "non-skin pixels changed");
    // The ball's dark side far from its outline: within half its radius of its centre.
    let n = ball_pixels.len() as f64;
    let centre = ball_pixels.iter().fold((0.0, 0.0), |(a, b), &(x, y)| {
        (a + f64::from(x) / n, b + f64::from(y) / n)
    });
    let radius_px = (n / std::f64::consts::PI).sqrt();
    ball.retain(|&(x, y)| {
        (f64::from(x) - centre.0).hypot(f64::from(y) - centre.1) < 0.5 * radius_px
    });
    assert!(slab.len() > 200, "slab interior: {} pixels", slab.len());
    assert!(ball.len() > 20, "ball interior: {} pixels", ball.len());

    let slab_gain = mean_gain(&on, &off, &slab);
    let ball_gain = mean_gain(&on, &off, &ball);
    let dark: f64 = slab
        .iter()
        .map(|&(x, y)| f64::from(pixel(&off, x, y)[0]))
        .sum::<f64>()
        / slab.len() as f64;
    eprintln!(
        "{name}: slab: {} pixels, red without transmittance {dark:.5}, gain r {:.4} g {:.4} b {:.4}; \
         ball: {} pixels, gain r {:.6} g {:.6} b {:.6}",
        slab.len(),
        slab_gain[0],
        slab_gain[1],
        slab_gain[2],
        ball.len(),
        ball_gain[0],
        ball_gain[1],
        ball_gain[2]
    );
    assert_reddest(
        slab_gain,
        0.05,
        1.2,
        "the backlit slab gained no light",
        "the transmitted light is not reddest",
    );
    assert!(
        ball_gain.iter().all(|g| g.abs() < 0.01 * slab_gain[0]),
        "10 cm of skin transmits: {ball_gain:?} (slab {slab_gain:?})"
    );

    // Against exact slab transport: light along the slab's normal flows straight through
    // (cosine 1 of the entry face, chord = thickness); the camera's ray refracts to
    // asin(sin 30 / 1.3) inside and leaves at cosine cos 30. The irradiance in Bevy's units
    // is illuminance x exposure / pi (Bevy's Lambert lobe), the albedo 1.
    let exposure = bevy::camera::Exposure::default().exposure();
    let e = ILLUMINANCE * light.share_at_slab() * exposure / std::f32::consts::PI;
    let a = VIEW_DEG.to_radians();
    let inside = (1.0 - (a.sin() / 1.3).powi(2)).sqrt();
    let want = skin1_transport_t(THICKNESS_MM, inside, a.cos()).map(|t| t * e);
    eprintln!("{name}: exact slab transport x E: {want:?}");
    for c in 0..3 {
        let got = slab_gain[c] as f32;
        assert!(
            (got - want[c]).abs() < 0.01 + 0.1 * want[c],
            "channel {c}: gained {got}, exact transport {}",
            want[c]
        );
    }
}

/// Without a shadow-casting light there is no thickness to read: the step skips
/// transmittance quietly, and the frame is the one without it, bit for bit.
#[test]
fn no_shadow_casting_light_no_transmittance() {
    let unshadowed = Backlight::Directional { shadows: false };
    let Some((off, on)) = off_and_on(|t| render_with(Some(t), unshadowed, None)) else {
        return;
    };
    let marked = render_with(None, unshadowed, None);
    let skin = (0..HEIGHT)
        .flat_map(|y| (0..WIDTH).map(move |x| (x, y)))
        .filter(|&(x, y)| pixel(&marked, x, y)[3] < 0.0)
        .count();
    assert!(skin > 1000, "skin covers {skin} pixels");
    assert!(
        on == off,
        "transmittance changed the frame without a shadow map"
    );
}

/// The cascades follow the camera, and the step's G-buffer binding holds the camera's
/// matrix: a camera that rendered elsewhere first and then moved gives, bit for bit, the
/// frame of one that started where it ends (with the light gained through the slab).
#[test]
fn a_moved_camera_transmits_as_a_fresh_one() {
    if !gpu_available() {
        return;
    }
    let fresh = render(Some(true));
    let moved = render_with(
        Some(true),
        Backlight::Directional { shadows: true },
        Some(Vec3::new(-0.2, 0.15, 0.6)),
    );
    let off = render(Some(false));
    assert!(fresh != off, "no transmitted light in the frame");
    let differ = fresh
        .chunks(8)
        .zip(moved.chunks(8))
        .filter(|(a, b)| a != b)
        .count();
    assert_eq!(differ, 0, "{differ} pixels differ after the move");
}
