//! The plugin in a headless Bevy app: a skin sphere on a grey plane, rendered once by a
//! camera with `Subsurface` and once by the same camera without it. Pixels that are not skin
//! must come back bit for bit; skin pixels must change, keep their energy, and lose the
//! skin marker.

use crate::common;

use bevy::core_pipeline::tonemapping::Tonemapping;
use bevy::prelude::*;
use common::*;
use subsurface_bevy::{SkinMedium, Subsurface, SubsurfacePlugin};

fn render(with_subsurface: bool) -> Vec<u8> {
    render_skin(with_subsurface, 0.6, 20.0, "skin1")
}

/// The scene of `common::spawn_scene` with a skin sphere of this roughness, width and medium.
fn render_skin(
    with_subsurface: bool,
    roughness: f32,
    width: f32,
    medium: impl Into<SkinMedium>,
) -> Vec<u8> {
    render_full(with_subsurface, roughness, width, medium, Tonemapping::None)
}

fn render_full(
    with_subsurface: bool,
    roughness: f32,
    width: f32,
    medium: impl Into<SkinMedium>,
    tonemapping: Tonemapping,
) -> Vec<u8> {
    let sub = with_subsurface.then(Subsurface::default);
    render_camera(sub, roughness, width, medium, tonemapping)
}

fn render_camera(
    subsurface: Option<Subsurface>,
    roughness: f32,
    width: f32,
    medium: impl Into<SkinMedium>,
    tonemapping: Tonemapping,
) -> Vec<u8> {
    let mut app = app();
    app.add_plugins(SubsurfacePlugin);
    let mut h = match subsurface {
        Some(sub) => setup_with(app, sub, tonemapping),
        None => setup_with(app, (), tonemapping),
    };
    let base = StandardMaterial {
        base_color: Color::linear_rgb(0.8, 0.5, 0.4),
        perceptual_roughness: roughness,
        ..default()
    };
    // The sphere has a radius of 1 m, 30 pixels here: a width of 20 makes a profile
    // millimetre 2 cm, a fraction of a pixel, the profile a few pixels.
    let skin = add_skin(h.app.world_mut(), base, medium, width);
    render_scene(&mut h, MeshMaterial3d(skin))
}

#[test]
fn subsurface_changes_skin_and_nothing_else() {
    let Some((off, on)) = off_and_on(render) else {
        return;
    };
    // The blur alone, for its energy: transmittance (on by default) adds light that crosses
    // the sphere near its terminator.
    let blur_only = Subsurface {
        transmittance: false,
        ..default()
    };
    let blurred = render_camera(Some(blur_only), 0.6, 20.0, "skin1", Tonemapping::None);
    dump(&off, "scatter_off");
    dump(&on, "scatter_on");

    let (mut skin, mut other, mut changed) = (0usize, 0usize, 0usize);
    let (mut energy_off, mut energy_on, mut energy_blur) = (0.0f64, 0.0f64, 0.0f64);
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
                let c = pixel(&blurred, x, y);
                energy_blur += (c[0] + c[1] + c[2]) as f64;
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
         skin energy {energy_off:.2} -> {energy_blur:.2} (blur alone), {energy_on:.2} (with \
         transmittance)"
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
    let ratio = energy_blur / energy_off;
    assert!((0.9..1.05).contains(&ratio), "skin energy ratio {ratio}");
}

/// The skin's specular light is drawn after the blur (by the additive twin), so a sharp
/// highlight keeps its peak while the diffuse light around it scatters. Blurring the
/// highlight with the diffuse light would lower its peak (measured in docs/lab/bevy.md).
#[test]
fn specular_highlight_stays_sharp() {
    // Glossy skin and a wide profile, so that the blur is several pixels wide.
    let Some((off, on)) = off_and_on(|sub| render_skin(sub, 0.25, 100.0, "skin1")) else {
        return;
    };
    dump(&off, "specular_off");
    dump(&on, "specular_on");

    let skin: Vec<(u32, u32)> = (0..HEIGHT)
        .flat_map(|y| (0..WIDTH).map(move |x| (x, y)))
        .filter(|&(x, y)| pixel(&off, x, y)[3] < 0.0)
        .collect();
    let &(px, py) = skin
        .iter()
        .max_by(|a, b| {
            luminance(pixel(&off, a.0, a.1)).total_cmp(&luminance(pixel(&off, b.0, b.1)))
        })
        .expect("skin pixels");
    let mut lum: Vec<f32> = skin
        .iter()
        .map(|&(x, y)| luminance(pixel(&off, x, y)))
        .collect();
    lum.sort_by(f32::total_cmp);
    let median = lum[lum.len() / 2];
    let (peak_off, peak_on) = (
        luminance(pixel(&off, px, py)),
        luminance(pixel(&on, px, py)),
    );
    // How much the blur changes the skin elsewhere: the diffuse light does scatter.
    let changed = skin
        .iter()
        .filter(|&&(x, y)| {
            (luminance(pixel(&on, x, y)) - luminance(pixel(&off, x, y))).abs() > 0.01
        })
        .count();
    eprintln!(
        "highlight at {px},{py}: {peak_off} -> {peak_on} (skin median {median}); \
         {changed} of {} skin pixels changed by > 0.01",
        skin.len()
    );
    // A real highlight: well above the skin's median.
    assert!(
        peak_off > 2.0 * median,
        "no highlight: peak {peak_off}, median {median}"
    );
    assert!(
        changed * 5 > skin.len(),
        "the diffuse light hardly scattered"
    );
    assert!(
        (peak_on / peak_off - 1.0).abs() < 0.02,
        "the highlight changed: {peak_off} -> {peak_on}"
    );
}

/// A medium that does not exist is logged, not a panic: the material is drawn as plain PBR
/// (its diffuse and its specular twin), no pixel is marked, and nothing is blurred.
#[test]
fn unknown_medium_draws_plain_pbr() {
    let Some((off, on)) = off_and_on(|sub| render_skin(sub, 0.6, 1.0, "unobtainium")) else {
        return;
    };
    let (x, y) = (WIDTH / 2, HEIGHT / 3); // on the sphere's lit upper half
    let p = pixel(&on, x, y);
    assert!(
        luminance(p) > 0.2 && !is_magenta(p),
        "sphere not drawn: {p:?}"
    );
    for y in 0..HEIGHT {
        for x in 0..WIDTH {
            assert!(pixel(&off, x, y)[3] >= 0.0, "skin marker at {x},{y}");
        }
    }
    assert!(off == on, "the plugin changed an image without skin");
}

/// A medium given by its measured coefficients scatters as the preset they come from: skin1's
/// (Jensen et al. 2001) give the preset's image bit for bit, and scatter (the image differs
/// from the one without the plugin); coefficients out of range are logged and drawn as plain
/// PBR, as an unknown preset is.
#[test]
fn measured_coefficients_scatter_as_their_preset() {
    let skin1 = || SkinMedium::Measured {
        sigma_a: [0.032, 0.17, 0.48],
        sigma_s: [0.74, 0.88, 1.01],
        eta: 1.3,
    };
    let Some((off, measured)) = off_and_on(|sub| render_skin(sub, 0.6, 20.0, skin1())) else {
        return;
    };
    let preset = render_skin(true, 0.6, 20.0, "skin1");
    assert!(measured != off, "the measured medium did not scatter");
    assert!(
        measured == preset,
        "skin1's coefficients scatter unlike skin1"
    );
    let out_of_range = SkinMedium::Measured {
        sigma_a: [-1.0, 0.17, 0.48],
        sigma_s: [0.74, 0.88, 1.01],
        eta: 1.3,
    };
    let plain = render_skin(true, 0.6, 20.0, out_of_range.clone());
    let plain_off = render_skin(false, 0.6, 20.0, out_of_range);
    assert!(plain == plain_off, "an invalid medium was drawn as skin");
}

/// With a tone mapper, Bevy's tone-mapping pass writes the camera's other main texture and
/// swaps them, so the opaque pass draws into the two in turn, frame after frame: the step
/// must follow (it keeps one bound pass per main texture). Tone mapping is per pixel, so
/// the non-skin pixels must still come back bit for bit, and the skin must still change.
#[test]
fn works_when_tone_mapping_swaps_main_textures() {
    let Some((off, on)) =
        off_and_on(|sub| render_full(sub, 0.6, 20.0, "skin1", Tonemapping::Reinhard))
    else {
        return;
    };
    let (mut skin, mut changed) = (0, 0);
    for y in 0..HEIGHT {
        for x in 0..WIDTH {
            let (a, b) = (pixel(&off, x, y), pixel(&on, x, y));
            // Reinhard keeps alpha: the marker survives without the step.
            if a[3] < 0.0 {
                skin += 1;
                assert_eq!(b[3], 1.0, "marker left at {x},{y}");
                if (0..3).any(|c| (a[c] - b[c]).abs() > 1e-3) {
                    changed += 1;
                }
            } else {
                assert_eq!(pixel_bits(&off, x, y), pixel_bits(&on, x, y), "{x},{y}");
            }
        }
    }
    eprintln!("tone mapped: {changed} of {skin} skin pixels changed");
    assert!(skin > 2000 && changed * 10 > skin, "{changed} of {skin}");
}
