//! No NaN or infinity reaches an HDR target, whatever a documented parameter is set to
//! within its range: each numeric setting at its extremes, one at a time, on a small
//! backlit scene that exercises shadows, transmittance and every SSS method.

use crate::common;

use common::{context, light_toml, scene};
use subsurface_render::{RenderOptions, Renderer, Scene, SssMethod, TransmittanceMethod};

const VIEW: &str = r#"
[camera]
position = [0.0, 0.0, 0.3]
target = [0.0, 0.0, 0.0]
near = 0.05
far = 2.0
[render]
width = 64
height = 48
"#;

/// After the spot light behind the objects.
const REST: &str = r#"[[lights]]
kind = "point"
position = [0.1, 0.1, 0.3]
intensity = 0.05
shadow_map_size = 64
[[objects]]
mesh = { shape = "sphere", radius = 0.04, segments = 24 }
material = { albedo = [0.75, 0.5, 0.4] }
[[objects]]
mesh = { shape = "slab", width = 0.05, height = 0.05, thickness = 0.003 }
translation = [0.05, 0.0, 0.0]
material = { albedo = [0.8, 0.8, 0.8], medium = "marble" }
"#;

/// The backlit scene the edits change: `VIEW`, a spot light behind the objects, `REST`.
fn base() -> String {
    let spot = light_toml(
        "spot",
        [0.0, 0.05, -0.3],
        2.0,
        "shadow_map_size = 256\nshadow_bias = 0.0005",
    );
    [VIEW, &spot, REST].concat()
}

/// Edits of the base scene, each at a documented extreme: by the line they follow, the
/// `key = value` lines inserted there and what they set.
const EDITS: &[(&str, &[(&str, &str)])] = &[
    (
        "[render]",
        &[
            ("exposure_ev = 32.0", "exposure"),
            ("exposure_ev = -32.0", "exposure"),
            ("ambient = [1e30, 1e30, 1e30]", "ambient"),
        ],
    ),
    (
        "intensity = 2.0",
        &[
            ("color = [1e30, 1e30, 1e30]", "light colour"),
            ("shadow_bias = 1e30", "shadow bias"),
            ("intensity = 1e38", "light intensity"),
            (
                "inner_angle_deg = 89.9\nouter_angle_deg = 89.9",
                "spot angles",
            ),
        ],
    ),
    (
        "intensity = 0.05",
        &[("position = [1e18, 1e18, 1e18]", "distant point light")],
    ),
    ("segments = 24 }", &[("scale = 1e-30", "object scale")]),
    (
        "near = 0.05",
        &[
            ("fov_y_deg = 179.9", "field of view"),
            ("fov_y_deg = 0.001", "field of view"),
        ],
    ),
];

fn edited(anchor: &str, line: &str) -> Scene {
    let text = base().replacen(anchor, &format!("{anchor}\n{line}"), 1);
    // Keys given twice (the base's and the edit's) keep the edit.
    let text = dedup_keys(&text);
    scene(&text)
}

/// Drops an earlier `key = ...` line of a table when the same key follows in it.
fn dedup_keys(text: &str) -> String {
    let lines: Vec<&str> = text.lines().collect();
    let key = |l: &str| l.split('=').next().map(str::trim).unwrap_or("").to_string();
    let mut keep = vec![true; lines.len()];
    for (i, l) in lines.iter().enumerate() {
        if !l.contains('=') {
            continue;
        }
        for later in &lines[i + 1..] {
            if later.starts_with('[') {
                break;
            }
            if later.contains('=') && key(later) == key(l) {
                keep[i] = false;
            }
        }
    }
    lines
        .iter()
        .zip(keep)
        .filter(|(_, k)| *k)
        .map(|(l, _)| *l)
        .collect::<Vec<_>>()
        .join("\n")
}

fn all_finite(r: &Renderer) -> Result<(), String> {
    for (name, v) in [
        ("diffuse", r.read_diffuse().unwrap()),
        ("specular", r.read_specular().unwrap()),
        ("sss", r.read_sss().unwrap()),
    ] {
        if let Some(i) = v.iter().position(|p| p.iter().any(|x| !x.is_finite())) {
            return Err(format!("{name} pixel {i} is {:?}", v[i]));
        }
    }
    Ok(())
}

#[test]
fn hdr_targets_stay_finite_at_every_extreme() {
    let Some(ctx) = context() else { return };
    let mut failures = Vec::new();
    // (what, scene, SSS method, transmittance, separable's few-sample jitter)
    let mut cases: Vec<(String, Scene, SssMethod, TransmittanceMethod, bool)> = Vec::new();
    for &(anchor, edits) in EDITS {
        for &(line, what) in edits {
            for jitter in [false, true] {
                cases.push((
                    format!("{what}, jitter {jitter}"),
                    edited(anchor, line),
                    SssMethod::Separable,
                    TransmittanceMethod::Paper,
                    jitter,
                ));
            }
        }
    }
    let base = scene(&base());
    for sss in SssMethod::ALL {
        for t in TransmittanceMethod::ALL {
            cases.push((format!("{sss}+{t}"), base.clone(), sss, t, false));
        }
    }
    for (what, s, sss, t, jitter) in cases {
        let mut o = RenderOptions::from_scene(&s);
        o.settings.sss.method = sss;
        if jitter {
            (o.settings.sss.samples, o.settings.sss.jitter) = (7, true);
        }
        o.settings.sss.texture_size = 64;
        o.settings.transmittance.method = t;
        let mut r = match Renderer::new(&ctx, &s, o) {
            Ok(r) => r,
            Err(e) => {
                failures.push(format!("{what}: {e}"));
                continue;
            }
        };
        r.render().unwrap();
        if let Err(e) = all_finite(&r) {
            failures.push(format!("{what}: {e}"));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Every radiance at its largest at once: ambient, and each light's colour and intensity at
/// f32::MAX (their product is infinite in f32, and the shader multiplies it by fall-off and
/// spot factors that can be 0: inf x 0 = NaN unless it saturates first). The HDR targets stay
/// finite and the image is saturated white where the sphere is, not NaN-black, with every
/// SSS method and every transmittance method. So no upper bound is needed on `intensity`,
/// `color` or `render.ambient` for rendering (`export-mitsuba` has its own, Mitsuba's floats).
#[test]
fn every_radiance_at_f32_max_at_once_stays_finite() {
    let Some(ctx) = context() else { return };
    let max = "3.4e38";
    let text = base()
        .replace(
            "[render]",
            &format!("[render]\nambient = [{max}, {max}, {max}]"),
        )
        .replace(
            "intensity = 2.0",
            &format!("intensity = {max}\ncolor = [{max}, {max}, {max}]"),
        )
        .replace(
            "intensity = 0.05",
            &format!("intensity = {max}\ncolor = [{max}, 0.0, {max}]"),
        )
        + &format!(
            "[[lights]]\nkind = \"directional\"\nposition = [0.0, 1.0, 1.0]\nintensity = {max}\ncolor = [{max}, {max}, {max}]\nshadow_map_size = 64\n"
        );
    let s = scene(&text);
    let mut failures = Vec::new();
    let methods = SssMethod::ALL
        .into_iter()
        .map(|m| (m, TransmittanceMethod::Paper))
        .chain(
            TransmittanceMethod::ALL
                .into_iter()
                .map(|t| (SssMethod::Separable, t)),
        );
    for (sss, t) in methods {
        let mut o = RenderOptions::from_scene(&s);
        o.settings.sss.method = sss;
        o.settings.sss.texture_size = 64;
        o.settings.transmittance.method = t;
        let mut r = Renderer::new(&ctx, &s, o).unwrap();
        let frame = r.render().unwrap();
        if let Err(e) = all_finite(&r) {
            failures.push(format!("{sss}+{t}: {e}"));
        }
        // The sphere covers the centre of the frame.
        let c = frame.image.get_pixel(32, 24).0;
        if c[..3].iter().any(|&v| v < 250) {
            failures.push(format!("{sss}+{t}: centre pixel {c:?}, not saturated"));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
