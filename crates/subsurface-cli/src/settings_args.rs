//! The command line's overlay on a scene's settings, shared by every command that renders: each
//! flag has the name and unit of the scene-file key it overrides (`--samples` is
//! `render.sss.samples`, `--sss-width` is each material's `sss_width`), and one `apply` writes
//! them all into the scene before it is validated as a whole.

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use glam::{Mat4, Vec3};
use subsurface_render::settings::Quality;
use subsurface_render::{MapEvaluation, Scene, SssFetch, SssMethod, TransmittanceMethod};

#[derive(Args, Debug, Clone, Default)]
pub struct SettingsArgs {
    /// Quality preset, a bundle of the settings below: low (the 2010 paper's cost class),
    /// medium (the default) or high (every term); keys the scene file sets and the flags
    /// below override it. `subsurface settings --quality Q` lists what it sets
    /// [default: the scene's render.quality, medium].
    #[arg(long, value_name = "PRESET")]
    quality: Option<Quality>,
    /// Image width in pixels [default: the scene's render.width, 1280].
    #[arg(long)]
    pub width: Option<u32>,
    /// Image height in pixels [default: the scene's render.height, 720].
    #[arg(long)]
    pub height: Option<u32>,
    /// Exposure in stops, in place of the scene's render.exposure_ev [default: 0].
    #[arg(long, value_name = "EV", allow_negative_numbers = true)]
    exposure_ev: Option<f32>,
    /// Subsurface-scattering method: gaussian6 = Jimenez et al. 2009 / GPU Pro (the profile's
    /// Gaussians, H+V 7-tap blurs each), separable = Jimenez et al. 2015 (one H and one V
    /// pass), hable13 = Hable et al. 2009 (one 2-D pass of 13 taps), texture = d'Eon et al.
    /// 2007 texture-space diffusion (per-object UV irradiance maps), none = no scattering.
    /// Each material scatters with its own profile [default: the scene's render.sss.method,
    /// separable].
    #[arg(long, value_name = "METHOD")]
    sss: Option<SssMethod>,
    /// Separable: number of kernel taps, odd, 3..=63 [default: render.sss.samples, 17].
    #[arg(long, value_name = "N")]
    samples: Option<u32>,
    /// Separable: jitter the taps per pixel, Jimenez et al. 2015's few-sample mode (e.g.
    /// --samples 7 --jitter): fixed taps' banding becomes fine noise (render.sss.jitter = true)
    /// [default: render.sss.jitter, false].
    #[arg(long)]
    jitter: bool,
    /// Screen space: how a tap fetches its texels, packed (a pack step first, then one
    /// Rgba32Uint texel per texel), workgroup (separable's passes as compute shaders that read
    /// each line once into workgroup memory, the first packing as it loads) or direct (colour,
    /// depth and SSS textures per texel); the same image at a different cost [default:
    /// render.sss.fetch, workgroup].
    #[arg(long, value_name = "FETCH")]
    sss_fetch: Option<SssFetch>,
    /// Let the blur cross depth edges (render.sss.follow_surface = false).
    #[arg(long)]
    no_follow_surface: bool,
    /// Six Gaussians: which of the five blurred Gaussians to accumulate, five 0/1 values (e.g.
    /// 1,1,0,1,1) [default: render.sss.gaussians, all].
    #[arg(long, value_name = "G1,..,G5", value_parser = parse_gaussians)]
    gaussians: Option<[bool; 5]>,
    /// Texture space: size of each object's irradiance map in texels, 16..=16384 [default:
    /// render.sss.texture_size, 1024].
    #[arg(long, value_name = "N")]
    texture_size: Option<u32>,
    #[command(flatten)]
    materials: MaterialArgs,
    /// Transmittance method: paper = Jimenez et al. 2010 (T(s) of the material's profile from
    /// standard shadow maps), beer = Green's exp(-sigma_t s), seed-report = the ad-hoc s^-0.6
    /// term of the screen/texture-space report, tsm = translucent shadow maps (d'Eon: back-side
    /// irradiance blurred in texture space, same T(s) as paper), diffusion = light diffusing
    /// through the material's measured medium (T(s) of a slab by exact transport, lit by the
    /// entry surface, plus unscattered and once-scattered light; docs/lab/fidelity.md), off = none
    /// [default: render.transmittance.method, diffusion].
    #[arg(long, value_name = "METHOD")]
    transmittance: Option<TransmittanceMethod>,
    /// Width in texels (odd, 1..=15) of the shadow-map area averaged for a softer thickness
    /// [default: render.transmittance.thickness_filter, 3].
    #[arg(long, value_name = "N")]
    thickness_filter: Option<u32>,
    /// Diffusion: shadow-map taps (0..=32) gathering the light that enters the lit surface
    /// around the light's chord and reaches the point through the medium, as behind a palm
    /// beside the finger roots; 0 = the chord's slab alone
    /// [default: render.transmittance.lateral_taps, 12].
    #[arg(long, value_name = "N")]
    lateral_taps: Option<u32>,
    /// Diffusion: evaluate it (the lateral taps included) for every light on a
    /// reduced-resolution map whose texels lie about MM profile millimetres apart on the
    /// nearest skin (0..=50; the reduction follows the skin's size on screen, 2x2 to 8x8 pixels
    /// a texel); each pixel reads the lights' sum once, interpolated on its own surface, and
    /// where the map has no texel of it (an outline) runs each light's chord itself; skin whose
    /// texels would span more than 4 MM runs everything at each pixel; 0 = at every pixel
    /// [default: render.transmitted_map.texel_mm, 4].
    #[arg(long, value_name = "MM", alias = "lateral-texel-mm")]
    map_texel_mm: Option<f32>,
    /// Diffusion: how the transmitted map is evaluated, auto (compute on GPUs, fragment on
    /// CPU adapters such as lavapipe), compute (its raster pass records each texel's surface,
    /// then a compute shader per object evaluates it; adapters without storage textures fall
    /// back to fragment) or fragment (in the raster pass's fragment shader); the same map at a
    /// different cost [default: render.transmitted_map.pass, auto].
    #[arg(long, value_name = "PASS", alias = "lateral-pass")]
    map_pass: Option<MapEvaluation>,
    /// Inward shift along the vertex normal before the shadow-map lookup, in scene units
    /// [default: render.transmittance.normal_shrink, 0.005].
    #[arg(long, value_name = "UNITS")]
    normal_shrink: Option<f32>,
    /// The light lit parts send each other across the air, gathered from a flux pyramid of
    /// the shadow maps: each level is read from N to 2N of its cells away from the point
    /// (0..=8, about 9.4 N^2 reads a level); 0 = off [default: render.bounce.ring, 2].
    #[arg(long, value_name = "N")]
    bounce_ring: Option<u32>,
    /// Width of the finest flux-pyramid cells the bounce reads, profile millimetres
    /// (0.1..=50) [default: render.bounce.cell_mm, 2].
    #[arg(long, value_name = "MM")]
    bounce_cell_mm: Option<f32>,
    /// Any setting of the scene's `[render]` table by its key, after the flags above, e.g.
    /// --set render.sss.samples=9 --set transmittance.method=paper (values in TOML syntax; a
    /// bare word is a string). `subsurface settings` lists every key with its default.
    #[arg(long = "set", value_name = "KEY=VALUE", value_parser = parse_key_value)]
    set: Vec<(String, String)>,
}

/// The flags that change every scattering material rather than a `[render]` key.
#[derive(Args, Debug, Clone, Default)]
struct MaterialArgs {
    /// Multiplier on the physical size of every scattering material's profile (each
    /// material's sss_width) [default: the materials' own, 1].
    #[arg(long, value_name = "FACTOR")]
    sss_width: Option<f32>,
    /// Separable: per-channel share of scattered light R,G,B in 0..=1 for every scattering
    /// material (kernel_strength) [default: the material's; skin 0.48,0.41,0.28].
    #[arg(long, value_name = "R,G,B", value_parser = parse_rgb)]
    kernel_strength: Option<[f32; 3]>,
    /// Separable: per-channel falloff R,G,B in 0..=1 for every scattering material
    /// [default: the material's; skin 1,0.37,0.3].
    #[arg(long, value_name = "R,G,B", value_parser = parse_rgb)]
    falloff: Option<[f32; 3]>,
}

/// Sets one `[render]` key of `scene`; the quality preset keeps the scene file's own keys
/// over its bundle.
pub fn set_key(
    scene: &mut Scene,
    key: &str,
    value: &str,
) -> Result<(), subsurface_render::settings::InvalidSetting> {
    if key.strip_prefix("render.").unwrap_or(key) == "quality" {
        let q: Quality = value
            .trim_matches('"')
            .parse()
            .map_err(|m| subsurface_render::settings::InvalidSetting::new("render.quality", m))?;
        return scene.desc.set_quality(q);
    }
    scene.desc.render.set(key, value)
}

/// Parses `KEY=VALUE` (the value may hold further `=`).
pub fn parse_key_value(s: &str) -> Result<(String, String), String> {
    let (k, v) = s
        .split_once('=')
        .ok_or_else(|| format!("expected KEY=VALUE, e.g. render.sss.samples=9 (got {s:?})"))?;
    let k = k.trim();
    if k.is_empty() {
        return Err(format!("the key is empty in {s:?}"));
    }
    Ok((k.to_string(), v.trim().to_string()))
}

/// The flag that sets a `[render]` field (`sss.samples` -> `--samples`), for error messages.
fn flag_of(field: &str) -> String {
    let leaf = match field {
        "sss.method" => "sss",
        "transmittance.method" => "transmittance",
        "bounce.ring" => "bounce_ring",
        "bounce.cell_mm" => "bounce_cell_mm",
        f => f.rsplit('.').next().unwrap_or(f),
    };
    let leaf = leaf.split('[').next().unwrap_or(leaf);
    format!("--{}", leaf.replace('_', "-"))
}

/// Writes each flag that is given into its field: `set! { flag => field, .. }`.
macro_rules! set {
    ($($flag:expr => $field:expr),* $(,)?) => {
        $(if let Some(v) = $flag {
            $field = v;
        })*
    };
}

impl SettingsArgs {
    /// Writes the flags into the scene's settings and materials and checks the result; an
    /// error names the flag.
    pub fn apply(&self, scene: &mut Scene) -> Result<()> {
        if let Some(q) = self.quality {
            scene
                .desc
                .set_quality(q)
                .map_err(|e| anyhow::anyhow!("--quality: {e}"))?;
        }
        let r = &mut scene.desc.render;
        set! {
            self.width => r.width,
            self.height => r.height,
            self.exposure_ev => r.exposure_ev,
            self.sss => r.sss.method,
            self.samples => r.sss.samples,
            self.sss_fetch => r.sss.fetch,
            self.gaussians => r.sss.gaussians,
            self.texture_size => r.sss.texture_size,
            self.transmittance => r.transmittance.method,
            self.thickness_filter => r.transmittance.thickness_filter,
            self.lateral_taps => r.transmittance.lateral_taps,
            self.map_texel_mm => r.transmitted_map.texel_mm,
            self.map_pass => r.transmitted_map.pass,
            self.normal_shrink => r.transmittance.normal_shrink,
            self.bounce_ring => r.bounce.ring,
            self.bounce_cell_mm => r.bounce.cell_mm,
        }
        if self.jitter {
            r.sss.jitter = true;
        }
        if self.no_follow_surface {
            r.sss.follow_surface = false;
        }
        if let Err(e) = r.validate() {
            anyhow::bail!("{}: {}", flag_of(&e.field), e.message);
        }
        for (key, value) in &self.set {
            set_key(scene, key, value).map_err(|e| anyhow::anyhow!("--set {e}"))?;
        }
        self.materials.apply(scene)
    }
}

impl MaterialArgs {
    /// Checks the flags and writes them into every scattering material.
    fn apply(&self, scene: &mut Scene) -> Result<()> {
        if let Some(w) = self.sss_width {
            anyhow::ensure!(
                w.is_finite() && w > 0.0,
                "--sss-width: must be finite and > 0 (got {w})"
            );
        }
        for (flag, v) in [
            ("--kernel-strength", self.kernel_strength),
            ("--falloff", self.falloff),
        ] {
            if let Some(v) = v {
                anyhow::ensure!(
                    v.iter().all(|x| (0.0..=1.0).contains(x)),
                    "{flag}: each value must be in 0..=1 (got {},{},{})",
                    v[0],
                    v[1],
                    v[2]
                );
            }
        }
        scene.edit_materials(|m| {
            if m.sss_strength > 0.0 {
                if let Some(w) = self.sss_width {
                    m.sss_width = w;
                }
                if self.kernel_strength.is_some() {
                    m.kernel_strength = self.kernel_strength;
                }
                if self.falloff.is_some() {
                    m.falloff = self.falloff;
                }
            }
        });
        Ok(())
    }
}

/// Parses five comma-separated 0/1 values (the six-Gaussian switches).
pub fn parse_gaussians(s: &str) -> Result<[bool; 5], String> {
    let v: Vec<bool> = s
        .split(',')
        .map(|p| match p.trim() {
            "1" => Ok(true),
            "0" => Ok(false),
            o => Err(format!("{o:?} is not 0 or 1")),
        })
        .collect::<Result<_, _>>()?;
    v.try_into()
        .map_err(|v: Vec<bool>| format!("expected five 0/1 values (got {})", v.len()))
}

/// Parses "r,g,b" into three finite floats.
pub fn parse_rgb(s: &str) -> Result<[f32; 3], String> {
    let v: Vec<f32> = s
        .split(',')
        .map(|p| p.trim().parse::<f32>().map_err(|e| format!("{p:?}: {e}")))
        .collect::<Result<_, _>>()?;
    match v.as_slice() {
        [r, g, b] if v.iter().all(|x| x.is_finite()) => Ok([*r, *g, *b]),
        [_, _, _] => Err("values must be finite".into()),
        _ => Err(format!(
            "expected three comma-separated numbers R,G,B (got {s:?})"
        )),
    }
}

#[derive(Args, Debug)]
pub struct SettingsListArgs {
    /// Scene file whose values to show (default: the embedded default scene).
    scene: Option<PathBuf>,
    /// Show the values with this quality preset (the scene file's own keys kept).
    #[arg(long, value_name = "PRESET")]
    quality: Option<Quality>,
}

/// `subsurface settings`: one line per key of `[render]`.
pub fn list(args: &SettingsListArgs) -> Result<()> {
    let mut scene = load_scene(args.scene.as_ref(), None)?;
    if let Some(q) = args.quality {
        scene.desc.set_quality(q)?;
    }
    let values = scene.desc.render.entries();
    let mut out = String::new();
    for d in subsurface_render::SETTINGS {
        let value = values
            .iter()
            .find(|(k, _)| k == d.key)
            .map_or(String::new(), |(_, v)| {
                subsurface_render::settings::value_text(v)
            });
        let unit = if d.unit.is_empty() {
            String::new()
        } else {
            format!(" [{}]", d.unit)
        };
        out.push_str(&format!(
            "render.{:<31} = {:<24} {}{unit}\n",
            d.key, value, d.doc
        ));
    }
    crate::output::print_summary(false, &out);
    Ok(())
}

/// Loads the scene named on the command line (or the default) and applies `--model`.
pub fn load_scene(scene: Option<&PathBuf>, model: Option<&PathBuf>) -> Result<Scene> {
    let mut scene = match scene {
        Some(p) => Scene::load_file(p)?,
        None => Scene::default_scene(),
    };
    if let Some(m) = model {
        scene.replace_model(m)?;
    }
    Ok(scene)
}

/// `n` copies of the scene's objects on a grid of ceil(sqrt(n)) columns, each scaled by
/// 1/columns about the scene's centre, so the grid covers about the area of one character.
pub fn replicate(scene: &Scene, n: u32) -> Scene {
    if n <= 1 {
        return scene.clone();
    }
    let (lo, hi) = scene.bounds();
    let centre = (lo + hi) * 0.5;
    let size = hi - lo;
    let cols = (n as f32).sqrt().ceil() as u32;
    let rows = n.div_ceil(cols);
    let s = 1.0 / cols as f32;
    let mut out = scene.clone();
    out.objects.clear();
    // The description keeps one entry per object (the scene's invariant), so per-object
    // edits such as bench's distinct profiles reach both.
    out.desc.objects.clear();
    for k in 0..n {
        let (c, r) = (k % cols, k / cols);
        let cell = Vec3::new(
            (c as f32 + 0.5) / cols as f32 - 0.5,
            0.5 - (r as f32 + 0.5) / rows.max(cols) as f32,
            0.0,
        ) * Vec3::new(size.x, size.y, 0.0);
        let m = Mat4::from_translation(centre + cell)
            * Mat4::from_scale(Vec3::splat(s))
            * Mat4::from_translation(-centre);
        for (o, d) in scene.objects.iter().zip(&scene.desc.objects) {
            let transform = m * o.transform;
            out.objects.push(subsurface_render::scene::Object {
                transform,
                ..o.clone()
            });
            let (scale, rotation, translation) = transform.to_scale_rotation_translation();
            let mut desc = d.clone();
            desc.translation = translation.to_array();
            let (x, y, z) = rotation.to_euler(glam::EulerRot::XYZ);
            desc.rotation_deg = [x, y, z].map(f32::to_degrees);
            desc.scale = scale.x;
            out.desc.objects.push(desc);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flags_name_the_keys_they_set() {
        assert_eq!(flag_of("sss.samples"), "--samples");
        assert_eq!(flag_of("sss.method"), "--sss");
        assert_eq!(flag_of("transmittance.normal_shrink"), "--normal-shrink");
        assert_eq!(flag_of("exposure_ev"), "--exposure-ev");
        assert_eq!(flag_of("ambient[1]"), "--ambient");
        assert_eq!(flag_of("bounce.ring"), "--bounce-ring");
        assert_eq!(flag_of("bounce.cell_mm"), "--bounce-cell-mm");
    }

    #[test]
    fn apply_overlays_settings_and_every_scattering_material() {
        let mut scene = Scene::default_scene();
        let args = SettingsArgs {
            samples: Some(9),
            jitter: true,
            sss_fetch: Some(SssFetch::Direct),
            map_pass: Some(MapEvaluation::Fragment),
            sss: Some(SssMethod::Hable13),
            materials: MaterialArgs {
                sss_width: Some(2.0),
                kernel_strength: Some([1.0, 0.5, 0.25]),
                ..Default::default()
            },
            ..Default::default()
        };
        args.apply(&mut scene).unwrap();
        assert_eq!(scene.desc.render.sss.samples, 9);
        assert!(scene.desc.render.sss.jitter);
        assert_eq!(scene.desc.render.sss.fetch, SssFetch::Direct);
        assert_eq!(
            scene.desc.render.transmitted_map.pass,
            MapEvaluation::Fragment
        );
        assert_eq!(scene.desc.render.sss.method, SssMethod::Hable13);
        for (o, d) in scene.objects.iter().zip(&scene.desc.objects) {
            assert_eq!(o.material.sss_width, 2.0);
            assert_eq!(d.material.sss_width, 2.0);
            assert_eq!(o.material.kernel_strength, Some([1.0, 0.5, 0.25]));
        }
        let e = SettingsArgs {
            samples: Some(4),
            ..Default::default()
        }
        .apply(&mut scene)
        .unwrap_err()
        .to_string();
        assert!(e.starts_with("--samples: must be odd"), "{e}");
        let args = SettingsArgs {
            samples: Some(9),
            set: vec![parse_key_value("render.sss.samples = 11").unwrap()],
            ..Default::default()
        };
        args.apply(&mut scene).unwrap();
        assert_eq!(
            scene.desc.render.sss.samples, 11,
            "--set comes after the flags"
        );
        let e = SettingsArgs {
            set: vec![parse_key_value("render.sss.sampels=9").unwrap()],
            ..Default::default()
        }
        .apply(&mut scene)
        .unwrap_err()
        .to_string();
        assert!(
            e.starts_with("--set render.sss.sampels: unknown key"),
            "{e}"
        );
        assert!(parse_key_value("samples").is_err());
    }
}
