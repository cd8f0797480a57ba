//! The sides of a part narrower than the light's spread take their share of the light through
//! it (`transmittance.side_walls`). The oracle is a random walk in the same medium
//! (tools/reference/confinement_mc.py, its figures in references/confinement_mc.json): the
//! diffuse light leaving the middle of a backlit rod or ball, over that of a slab as thick as
//! its diameter. The renderer's ratio is read the same way: the part and the slab rendered
//! alike, the diffuse target alone (no blur, no unscattered or once-scattered light).

use crate::common;

use common::{camera_toml, context, dark_scene, diffuse_with, light_toml, repo_root};
use subsurface_render::{Scene, SssMethod};

/// The media of the walk (Jensen et al. 2001's skin1 and skin2, the suite's `custom`).
fn medium_toml(medium: &str) -> &'static str {
    match medium {
        "skin1" => "{ sigma_a = [0.032, 0.17, 0.48], sigma_s = [0.74, 0.88, 1.01], eta = 1.3 }",
        "skin2" => "{ sigma_a = [0.013, 0.070, 0.145], sigma_s = [1.09, 1.59, 1.79], eta = 1.3 }",
        "custom" => "{ sigma_a = [0.12, 0.025, 0.08], sigma_s = [0.6, 0.9, 0.7], eta = 1.5 }",
        _ => unreachable!("no such medium in the walk's table: {medium}"),
    }
}

/// A `shape` of radius `r_mm` (a slab: as thick as the diameter) seen head-on over a frame
/// 4 radii tall, lit from straight behind by a spot light 350 mm away, as the walk's
/// `--renderer` mode renders it.
fn backlit(shape: &str, medium: &str, r_mm: f32) -> Scene {
    lit_from(shape, medium, r_mm, 0.0)
}

/// [`backlit`] with the light turned `tilt_deg` about the vertical axis (a cylinder's) toward
/// the frame's left: 90 lights the part from the side, 180 from the camera's side.
fn lit_from(shape: &str, medium: &str, r_mm: f32, tilt_deg: f32) -> Scene {
    let m = r_mm / 1000.0;
    let a = tilt_deg.to_radians();
    let mesh = match shape {
        "slab" => format!(
            "{{ shape = \"slab\", width = {:?}, height = {:?}, thickness = {:?} }}",
            16.0 * m,
            16.0 * m,
            2.0 * m
        ),
        "cylinder" => format!(
            "{{ shape = \"cylinder\", radius = {m:?}, length = {:?}, segments = 256 }}",
            24.0 * m
        ),
        _ => format!("{{ shape = \"sphere\", radius = {m:?}, segments = 192 }}"),
    };
    let fov = 2.0 * (2.0 * m / 0.2).atan().to_degrees();
    dark_scene(
        &camera_toml(0.2, fov, "near = 0.05\nfar = 2.0"),
        &light_toml(
            "spot",
            [-0.35 * a.sin(), 0.0, -0.35 * a.cos()],
            3.675,
            "inner_angle_deg = 9.0\nouter_angle_deg = 14.0\nshadow_map_size = 2048\nshadow_bias = 0.0005",
        ),
        &format!(
            "[[objects]]\nmesh = {mesh}\nmm_per_unit = 1000.0\n[objects.material]\nmedium = {}\nroughness = 0.3\nspecular = 1.0\n",
            medium_toml(medium)
        ),
    )
}

/// A cylinder of `medium` and radius `r_mm` as [`backlit`] renders it, with a twin on each
/// side across a gap of `gap_mm` (their axes parallel, all three in the plane across the light).
fn rod_between_twins(medium: &str, r_mm: f32, gap_mm: f32) -> Scene {
    let m = r_mm / 1000.0;
    let mut scene = backlit("cylinder", medium, r_mm);
    let twin = scene.desc.objects[0].clone();
    for side in [-1.0f32, 1.0] {
        let mut o = twin.clone();
        o.translation = [side * (2.0 * m + gap_mm / 1000.0), 0.0, 0.0];
        scene.desc.objects.push(o);
    }
    Scene::from_desc(scene.desc, std::path::Path::new("."), "twins.toml").unwrap()
}

/// The diffuse target at the middle of the part (a cylinder's axis runs up the frame: 64 rows
/// of its 8 middle columns), channel by channel.
fn middle(shape: &str, medium: &str, r_mm: f32, side_walls: bool) -> [f32; 3] {
    middle_of(&backlit(shape, medium, r_mm), shape, side_walls)
}

fn middle_of(scene: &Scene, shape: &str, side_walls: bool) -> [f32; 3] {
    let d = diffuse_with(scene, 128, 128, |s| {
        s.sss.method = SssMethod::None;
        s.transmittance.ballistic = false;
        s.transmittance.single_scattering = false;
        s.transmittance.normal_shrink = 0.0005;
        s.transmittance.side_walls = side_walls;
    });
    let rows = if shape == "cylinder" { 32..96 } else { 60..68 };
    mean_over(&d, rows, 60..68)
}

/// The mean of a 128-pixel-wide target over `rows` x `cols`, channel by channel.
fn mean_over(
    d: &[[f32; 4]],
    rows: std::ops::Range<usize>,
    cols: std::ops::Range<usize>,
) -> [f32; 3] {
    let mut sum = [0.0f64; 3];
    let mut n = 0.0;
    for y in rows {
        for x in cols.clone() {
            for (c, s) in sum.iter_mut().enumerate() {
                *s += f64::from(d[y * 128 + x][c]);
            }
            n += 1.0;
        }
    }
    sum.map(|s| (s / n) as f32)
}

/// The walk's ratio part / slab for one medium, shape, radius and channel, and its standard
/// error.
fn walk(medium: &str, shape: &str, r_mm: f64, channel: &str) -> (f64, f64) {
    let text = std::fs::read_to_string(repo_root().join("references/confinement_mc.json")).unwrap();
    let doc: serde_json::Value = serde_json::from_str(&text).unwrap();
    let point = doc["points"]
        .as_array()
        .unwrap()
        .iter()
        .find(|p| {
            p["medium"] == medium
                && p["shape"] == shape
                && p["radius_mm"].as_f64() == Some(r_mm)
                && p["channel"] == channel
        })
        .unwrap_or_else(|| panic!("the walk's table has no {medium} {shape} {r_mm} mm {channel}"));
    (
        point["ratio"].as_f64().unwrap(),
        point["ratio_stderr"].as_f64().unwrap(),
    )
}

/// The middle of backlit rods, in media whose channels absorb little for the rod's size, lets
/// through what the walk says (within 8 %, or two of the walk's standard errors). With the kernel-mass coverage in the walls' place
/// the first five cases read 0.686 / 0.738 / 0.483 / 0.623 / 0.756 against the walk's 0.783 /
/// 0.618 / 0.824 / 0.925 / 0.668: 12 to 41 % off, every one outside the band. In the sixth, a
/// 16 mm rod, the lateral taps give more than the chord: without the walls' loss on their
/// light too it read 0.97 against the walk's 0.77 (docs/lab/suite.md, session 34). (Balls are
/// not held here: their four walls overcount, a 10 mm ball of skin2 reads 0.37 against the
/// walk's 0.46; session 32.)
#[test]
fn a_backlit_rod_keeps_what_a_random_walk_says() {
    if context().is_none() {
        return;
    }
    let cases = [
        ("skin1", "cylinder", 3.0, 0),
        ("skin2", "cylinder", 3.0, 0),
        ("custom", "cylinder", 3.0, 1),
        ("custom", "cylinder", 5.0, 1),
        ("skin2", "cylinder", 5.0, 0),
        ("skin2", "cylinder", 8.0, 0),
    ];
    let mut misses = Vec::new();
    for (medium, shape, r_mm, c) in cases {
        let part = middle(shape, medium, r_mm as f32, true)[c];
        let slab = middle("slab", medium, r_mm as f32, true)[c];
        let got = f64::from(part / slab);
        let (want, stderr) = walk(medium, shape, r_mm, ["R", "G", "B"][c]);
        // The walk's own noise bounds what can be asked: 8 %, or two of its standard errors
        // where they are wider (the 16 mm rod's 9 %).
        let band = 0.08f64.max(2.0 * stderr / want);
        if (got / want - 1.0).abs() > band {
            misses.push(format!(
                "{medium} {shape} {r_mm} mm channel {c}: {got:.3} against the walk's {want:.3} +- {stderr:.3}"
            ));
        }
    }
    assert!(
        misses.is_empty(),
        "part / slab off the walk by more than its band: {misses:?}"
    );
}

/// A slab wider than the walls' reach keeps all of its chord's light: the term is 1 where there
/// are no walls, so it cannot be what moves a wide part.
#[test]
fn a_wide_slab_loses_nothing_to_walls() {
    if context().is_none() {
        return;
    }
    // A 48 mm slab 6 mm thick: its edges lie 24 mm from the middle, past the 22 mm the walls
    // are looked for.
    for medium in ["skin2", "custom"] {
        let on = middle("slab", medium, 3.0, true);
        let off = middle("slab", medium, 3.0, false);
        for c in 0..3 {
            assert!(
                (on[c] - off[c]).abs() <= 1e-4 * off[c].abs().max(1e-6),
                "{medium} channel {c}: {} with walls, {} without",
                on[c],
                off[c]
            );
        }
    }
}

/// A wall facing a like part across a narrow gap (one finger beside the next) loses only what
/// leaves the gap: the neighbour takes the wall's light in and sends as much back. The share
/// that leaves is 1 - F, F the view factor between two parallel strips as tall as the chord
/// across the gap: for a 6 mm rod with twins 0.5 mm away, F = 0.92. So the walls take at most a
/// quarter of what they take from the lone rod (without the gap's return they take the same).
#[test]
fn a_wall_across_a_narrow_gap_from_a_like_part_keeps_its_light() {
    if context().is_none() {
        return;
    }
    let lone = backlit("cylinder", "skin2", 3.0);
    let twins = rod_between_twins("skin2", 3.0, 0.5);
    let taken = |scene: &Scene| {
        let on = middle_of(scene, "cylinder", true)[0];
        let off = middle_of(scene, "cylinder", false)[0];
        1.0 - on / off
    };
    let (alone, beside) = (taken(&lone), taken(&twins));
    assert!(
        alone > 0.1,
        "a lone rod's walls take {alone:.3} of its light: too little to test the gap on"
    );
    assert!(
        beside <= 0.25 * alone,
        "between twins 0.5 mm away the walls take {beside:.3}, alone {alone:.3}"
    );
}

/// The diffuse target of a cylinder as [`lit_from`] renders it, every pixel evaluating its own
/// transmitted light (the walk's windows are narrower than the map's texels), over the rows
/// 32..96 and the columns of the walk's window: `at` radii right of the axis, 0.5 mm either side.
fn rod_window(scene: &Scene, r_mm: f32, at: f32) -> [f32; 3] {
    let d = diffuse_with(scene, 128, 128, |s| {
        s.sss.method = SssMethod::None;
        s.transmittance.ballistic = false;
        s.transmittance.single_scattering = false;
        s.transmittance.normal_shrink = 0.0005;
        s.transmitted_map.texel_mm = 0.0;
    });
    // 32 pixels a radius (the frame spans 4 radii), as confinement_mc.py's renderer_centre.
    let (x, w) = (64.0 + 32.0 * at, (32.0 * 0.5 / r_mm).max(0.5));
    mean_over(
        &d,
        32..96,
        (x - w).round() as usize..(x + w).round() as usize,
    )
}

/// Past the terminator of a rod lit from the side (90 degrees off the axis behind it) or from
/// the side and in front (120), the light that crosses the rod leaves along its own direction:
/// windows 0.5 and 0.8 radii from the axis, away from the light, over the axis lit from behind,
/// against a random walk in the same media (references/confinement_tilts.json,
/// `confinement_mc.py --tilts 90,120 --at 0.5,0.8`; the walk's standard errors 3-4 %). With the
/// exit flow halfway between the normal and the light (until session 43) skin1 read 1.20 /
/// 1.08 / 1.13 and skin2 1.21 / 1.16 / 1.15 of the walk, a mean of 0.155 off; with the light's
/// direction bent by 0.4 of the normal (`exit_flow`) 1.10 / 1.01 / 1.01 and 1.10 / 1.10 /
/// 1.03, a mean of 0.058. (120 degrees at 0.5 radii is the terminator itself, where the direct
/// light's edge decides. The walk's absorbing channels are not held: custom's red reads 1.2-1.6x
/// the walk here, 1.3-1.8x with the halfway flow.)
#[test]
fn past_the_terminator_a_rod_lit_from_the_side_keeps_what_a_random_walk_says() {
    if context().is_none() {
        return;
    }
    let text =
        std::fs::read_to_string(repo_root().join("references/confinement_tilts.json")).unwrap();
    let doc: serde_json::Value = serde_json::from_str(&text).unwrap();
    let r_mm = 4.0;
    let mut ratios = Vec::new();
    for medium in ["skin1", "skin2"] {
        let axis = rod_window(&lit_from("cylinder", medium, r_mm, 0.0), r_mm, 0.0)[0];
        for (tilt, at) in [(90.0, 0.5), (90.0, 0.8), (120.0, 0.8)] {
            let point = doc["tilts"]
                .as_array()
                .unwrap()
                .iter()
                .find(|p| {
                    p["medium"] == medium
                        && p["radius_mm"].as_f64() == Some(f64::from(r_mm))
                        && p["channel"] == "R"
                        && p["tilt_deg"].as_f64() == Some(tilt)
                        && p["at_radii"].as_f64() == Some(at)
                })
                .unwrap_or_else(|| panic!("the walk's table has no {medium} {tilt} deg at {at}"));
            let want = point["walk_ratio"].as_f64().unwrap();
            let window = rod_window(
                &lit_from("cylinder", medium, r_mm, tilt as f32),
                r_mm,
                at as f32,
            )[0];
            ratios.push((
                format!("{medium} {tilt} deg at {at} R"),
                f64::from(window / axis) / want,
            ));
        }
    }
    let mean = ratios.iter().map(|(_, r)| (r - 1.0).abs()).sum::<f64>() / ratios.len() as f64;
    assert!(
        ratios.iter().all(|(_, r)| (r - 1.0).abs() <= 0.15) && mean <= 0.09,
        "renderer over walk {ratios:?}, mean |ratio - 1| {mean:.3}"
    );
}
