//! Scene description (TOML, see `docs/scene-format.md`) and scene loading.
//!
//! [`SceneDesc`] is the raw, serialisable description; [`Scene`] is the loaded
//! scene with meshes and textures decoded, ready for upload.

use std::path::{Path, PathBuf};

use glam::{EulerRot, Mat4, Quat, Vec3};
use serde::{Deserialize, Serialize};

use crate::mesh::{self, Mesh};

/// The gltf path that names the embedded vendored WebXR right hand.
pub const BUILTIN_HAND: &str = "builtin:hand";

/// Source of the embedded default scene.
pub const DEFAULT_SCENE_TOML: &str = include_str!("default_scene.toml");

/// Every error of scene parsing and loading. `Display` is always one line that
/// names the file (and, where it applies, the field or `line:col`).
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// TOML syntax error, unknown key, wrong type or missing key.
    #[error("{file}{}: {msg}", .line_col.map(|(l, c)| format!(":{l}:{c}")).unwrap_or_default())]
    Toml {
        file: String,
        line_col: Option<(usize, usize)>,
        msg: String,
    },
    /// A value out of range (or not finite).
    #[error("{file}: {field}: {msg}")]
    Invalid {
        file: String,
        field: String,
        msg: String,
    },
    /// A file could not be read.
    #[error("{file}: cannot read: {msg}")]
    Io { file: String, msg: String },
    /// A glTF/GLB file could not be parsed or has no usable mesh.
    #[error("{file}: not a valid glTF file: {msg}")]
    Gltf { file: String, msg: String },
    /// An image could not be read or decoded.
    #[error("{file}: cannot decode image: {msg}")]
    Image { file: String, msg: String },
    /// An error while loading an asset named by a scene field.
    #[error("{file}: {field}: {source}")]
    Asset {
        file: String,
        field: String,
        source: Box<SceneError>,
    },
}

/// Flattens a possibly multi-line message into one line.
pub(crate) fn one_line(s: &str) -> String {
    s.lines()
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .collect::<Vec<_>>()
        .join("; ")
}

// ---------------------------------------------------------------- defaults

fn d_up() -> [f32; 3] {
    [0.0, 1.0, 0.0]
}
fn d_fov() -> f32 {
    30.0
}
fn d_near() -> f32 {
    0.01
}
fn d_far() -> f32 {
    100.0
}
fn d_white() -> [f32; 3] {
    [1.0, 1.0, 1.0]
}
fn d_zero3() -> [f32; 3] {
    [0.0, 0.0, 0.0]
}
fn d_one() -> f32 {
    1.0
}
fn d_inner() -> f32 {
    20.0
}
fn d_outer() -> f32 {
    30.0
}
fn d_shadow_size() -> u32 {
    2048
}
fn d_shadow_bias() -> f32 {
    0.001
}
fn d_mm_per_unit() -> f32 {
    1000.0
}
fn d_true() -> bool {
    true
}
fn is_true(b: &bool) -> bool {
    *b
}

// ---------------------------------------------------------------- description

/// The whole scene file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneDesc {
    pub camera: CameraDesc,
    #[serde(default)]
    pub render: RenderDesc,
    #[serde(default)]
    pub lights: Vec<LightDesc>,
    #[serde(default)]
    pub objects: Vec<ObjectDesc>,
}

/// Perspective camera.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraDesc {
    pub position: [f32; 3],
    pub target: [f32; 3],
    #[serde(default = "d_up")]
    pub up: [f32; 3],
    /// Vertical field of view in degrees, 0 < fov < 180.
    #[serde(default = "d_fov")]
    pub fov_y_deg: f32,
    #[serde(default = "d_near")]
    pub near: f32,
    #[serde(default = "d_far")]
    pub far: f32,
}

impl Default for CameraDesc {
    fn default() -> Self {
        CameraDesc {
            position: [0.0, 0.0, 1.0],
            target: [0.0, 0.0, 0.0],
            up: d_up(),
            fov_y_deg: d_fov(),
            near: d_near(),
            far: d_far(),
        }
    }
}

/// Output image and global lighting settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RenderDesc {
    pub width: u32,
    pub height: u32,
    /// Exposure in stops (multiplies radiance by 2^ev before tone mapping).
    pub exposure_ev: f32,
    /// Uniform ambient radiance (linear RGB).
    pub ambient: [f32; 3],
    /// Background colour (linear RGB).
    pub background: [f32; 3],
    /// Transmittance: how far (scene units) a shaded point moves inward along its vertex
    /// normal before the shadow-map lookup (Jimenez et al. 2010 use 0.005).
    pub normal_shrink: f32,
    /// Screen-space SSS method (`subsurface render --sss` overrides it).
    pub sss: crate::passes::sss::SssMethod,
    /// Separable kernel taps, odd, 3..=63.
    pub samples: u32,
    /// Transmittance method.
    pub transmittance: crate::passes::transmittance::TransmittanceMethod,
    /// Width in texels of the shadow-map area averaged for thickness, odd, 1..=15.
    pub thickness_filter: u32,
    /// Screen-space SSS: weaken taps across depth differences (the blur follows the surface
    /// instead of crossing silhouettes and depth edges).
    pub follow_surface: bool,
    /// Six-Gaussian SSS: which of the five blurred Gaussians (variances 2..6 of the profile)
    /// are accumulated; switching one off shows its share of the profile.
    pub gaussians: [bool; 5],
}

impl Default for RenderDesc {
    fn default() -> Self {
        RenderDesc {
            width: 1280,
            height: 720,
            exposure_ev: 0.0,
            ambient: [0.02, 0.02, 0.02],
            background: [0.02, 0.02, 0.025],
            normal_shrink: 0.005,
            sss: crate::passes::sss::SssMethod::Separable,
            samples: 17,
            transmittance: crate::passes::transmittance::TransmittanceMethod::Paper,
            thickness_filter: 3,
            follow_surface: true,
            gaussians: [true; 5],
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum LightKind {
    Point,
    Spot,
    Directional,
}

/// A light source.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LightDesc {
    pub kind: LightKind,
    pub position: [f32; 3],
    /// Spot and directional: direction = target - position. Unused by point lights.
    #[serde(default = "d_zero3")]
    pub target: [f32; 3],
    #[serde(default = "d_white")]
    pub color: [f32; 3],
    /// Point/spot: radiant intensity (falls off as 1/d^2 in scene units);
    /// directional: irradiance.
    #[serde(default = "d_one")]
    pub intensity: f32,
    /// Spot only: half-angles in degrees, 0 < inner <= outer < 90.
    #[serde(default = "d_inner")]
    pub inner_angle_deg: f32,
    #[serde(default = "d_outer")]
    pub outer_angle_deg: f32,
    /// 0 = no shadow map; else 16..=8192.
    #[serde(default = "d_shadow_size")]
    pub shadow_map_size: u32,
    /// Depth bias in scene units.
    #[serde(default = "d_shadow_bias")]
    pub shadow_bias: f32,
}

impl Default for LightDesc {
    fn default() -> Self {
        LightDesc {
            kind: LightKind::Point,
            position: [0.0, 0.0, 1.0],
            target: d_zero3(),
            color: d_white(),
            intensity: d_one(),
            inner_angle_deg: d_inner(),
            outer_angle_deg: d_outer(),
            shadow_map_size: d_shadow_size(),
            shadow_bias: d_shadow_bias(),
        }
    }
}

/// One object of the scene.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectDesc {
    #[serde(default)]
    pub name: String,
    pub mesh: MeshDesc,
    /// Millimetres per scene unit of this object's mesh (before `scale`):
    /// 1000 for metres (glTF), ~48 for the Lee Perry-Smith head.
    #[serde(default = "d_mm_per_unit")]
    pub mm_per_unit: f32,
    #[serde(default = "d_zero3")]
    pub translation: [f32; 3],
    /// Euler angles in degrees, `glam::EulerRot::XYZ`: R = Rx * Ry * Rz.
    #[serde(default = "d_zero3")]
    pub rotation_deg: [f32; 3],
    /// Uniform scale.
    #[serde(default = "d_one")]
    pub scale: f32,
    #[serde(default)]
    pub material: MaterialDesc,
}

impl ObjectDesc {
    /// Object -> world matrix: translation * rotation * scale.
    pub fn transform(&self) -> Mat4 {
        let r = self.rotation_deg.map(f32::to_radians);
        Mat4::from_scale_rotation_translation(
            Vec3::splat(self.scale),
            Quat::from_euler(EulerRot::XYZ, r[0], r[1], r[2]),
            Vec3::from(self.translation),
        )
    }
}

/// Geometry of an object. TOML form:
/// `mesh = { gltf = "hand.glb" }`,
/// `mesh = { shape = "slab", width = 0.1, height = 0.1, thickness = 0.01 }`,
/// `mesh = { shape = "wedge", length = 0.1, height = 0.05, max_thickness = 0.02 }`,
/// `mesh = { shape = "sphere", radius = 0.05, segments = 64 }` (segments optional).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "MeshDescToml", into = "MeshDescToml")]
pub enum MeshDesc {
    /// Path relative to the scene file, or [`BUILTIN_HAND`].
    Gltf {
        path: String,
    },
    Slab {
        width: f32,
        height: f32,
        thickness: f32,
    },
    Wedge {
        length: f32,
        height: f32,
        max_thickness: f32,
    },
    Sphere {
        radius: f32,
        segments: u32,
    },
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
enum ShapeKind {
    Slab,
    Wedge,
    Sphere,
}

/// Flat TOML form of [`MeshDesc`].
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct MeshDescToml {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    gltf: Option<String>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    shape: Option<ShapeKind>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    width: Option<f32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    height: Option<f32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    thickness: Option<f32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    length: Option<f32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    max_thickness: Option<f32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    radius: Option<f32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    segments: Option<u32>,
}

const DEFAULT_SPHERE_SEGMENTS: u32 = 64;

impl TryFrom<MeshDescToml> for MeshDesc {
    type Error = String;
    fn try_from(t: MeshDescToml) -> Result<Self, String> {
        let given: Vec<&str> = [
            ("width", t.width.is_some()),
            ("height", t.height.is_some()),
            ("thickness", t.thickness.is_some()),
            ("length", t.length.is_some()),
            ("max_thickness", t.max_thickness.is_some()),
            ("radius", t.radius.is_some()),
            ("segments", t.segments.is_some()),
        ]
        .into_iter()
        .filter_map(|(k, set)| set.then_some(k))
        .collect();
        let only = |allowed: &[&str], what: &str| -> Result<(), String> {
            match given.iter().find(|k| !allowed.contains(k)) {
                Some(k) => Err(format!(
                    "`{k}` does not apply to {what} (allowed: {})",
                    if allowed.is_empty() {
                        "nothing else".to_string()
                    } else {
                        allowed.join(", ")
                    }
                )),
                None => Ok(()),
            }
        };
        let need = |v: Option<f32>, k: &str, shape: &str| {
            v.ok_or_else(|| format!("shape \"{shape}\" needs `{k}`"))
        };
        match (t.gltf, t.shape) {
            (Some(_), Some(_)) => Err("give either `gltf` or `shape`, not both".into()),
            (None, None) => {
                Err("needs `gltf = \"path\"` or `shape = \"slab\" | \"wedge\" | \"sphere\"`".into())
            }
            (Some(path), None) => {
                only(&[], "a glTF mesh")?;
                Ok(MeshDesc::Gltf { path })
            }
            (None, Some(ShapeKind::Slab)) => {
                only(&["width", "height", "thickness"], "shape \"slab\"")?;
                Ok(MeshDesc::Slab {
                    width: need(t.width, "width", "slab")?,
                    height: need(t.height, "height", "slab")?,
                    thickness: need(t.thickness, "thickness", "slab")?,
                })
            }
            (None, Some(ShapeKind::Wedge)) => {
                only(&["length", "height", "max_thickness"], "shape \"wedge\"")?;
                Ok(MeshDesc::Wedge {
                    length: need(t.length, "length", "wedge")?,
                    height: need(t.height, "height", "wedge")?,
                    max_thickness: need(t.max_thickness, "max_thickness", "wedge")?,
                })
            }
            (None, Some(ShapeKind::Sphere)) => {
                only(&["radius", "segments"], "shape \"sphere\"")?;
                Ok(MeshDesc::Sphere {
                    radius: need(t.radius, "radius", "sphere")?,
                    segments: t.segments.unwrap_or(DEFAULT_SPHERE_SEGMENTS),
                })
            }
        }
    }
}

impl From<MeshDesc> for MeshDescToml {
    fn from(m: MeshDesc) -> Self {
        match m {
            MeshDesc::Gltf { path } => MeshDescToml {
                gltf: Some(path),
                ..Default::default()
            },
            MeshDesc::Slab {
                width,
                height,
                thickness,
            } => MeshDescToml {
                shape: Some(ShapeKind::Slab),
                width: Some(width),
                height: Some(height),
                thickness: Some(thickness),
                ..Default::default()
            },
            MeshDesc::Wedge {
                length,
                height,
                max_thickness,
            } => MeshDescToml {
                shape: Some(ShapeKind::Wedge),
                length: Some(length),
                height: Some(height),
                max_thickness: Some(max_thickness),
                ..Default::default()
            },
            MeshDesc::Sphere { radius, segments } => MeshDescToml {
                shape: Some(ShapeKind::Sphere),
                radius: Some(radius),
                segments: Some(segments),
                ..Default::default()
            },
        }
    }
}

/// Surface and subsurface-scattering parameters of an object.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MaterialDesc {
    /// Linear RGB; multiplies the albedo texture and (if `use_gltf_color`)
    /// the glTF base colour factor.
    pub albedo: [f32; 3],
    /// sRGB colour texture, path relative to the scene file (overrides the glTF's).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub albedo_texture: Option<String>,
    /// Tangent-space normal map (overrides the glTF's).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub normal_texture: Option<String>,
    /// Specular intensity map (linear, red channel scales `specular`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub specular_texture: Option<String>,
    /// glTF meshes: multiply `albedo` by the glTF base colour factor and use
    /// the glTF base colour texture when `albedo_texture` is not given.
    #[serde(default = "d_true", skip_serializing_if = "is_true")]
    pub use_gltf_color: bool,
    /// Beckmann roughness m, in (0, 1].
    pub roughness: f32,
    /// Kelemen/Szirmay-Kalos specular intensity rho_s, >= 0.
    pub specular: f32,
    /// 0 = not skin (no subsurface scattering), 1 = full.
    pub sss_strength: f32,
    /// Multiplier on the physical profile size, > 0.
    pub sss_width: f32,
    /// Thickness scale for transmittance, >= 0.
    pub translucency: f32,
    /// Material preset name of the scattering profile.
    pub profile: String,
    /// Per-channel strength of the separable kernel, each in [0, 1].
    pub kernel_strength: [f32; 3],
    /// Per-channel falloff of the separable kernel, each in [0, 1].
    pub falloff: [f32; 3],
}

impl Default for MaterialDesc {
    fn default() -> Self {
        MaterialDesc {
            albedo: [1.0, 1.0, 1.0],
            albedo_texture: None,
            normal_texture: None,
            specular_texture: None,
            use_gltf_color: true,
            roughness: 0.3,
            specular: 0.18,
            sss_strength: 1.0,
            sss_width: 1.0,
            translucency: 1.0,
            profile: "skin".to_string(),
            kernel_strength: [0.48, 0.41, 0.28],
            falloff: [1.0, 0.37, 0.3],
        }
    }
}

impl MaterialDesc {
    /// Untextured skin: the default material with a linear skin albedo,
    /// ignoring the glTF base colour.
    pub fn skin() -> Self {
        MaterialDesc {
            albedo: SKIN_ALBEDO,
            use_gltf_color: false,
            ..Default::default()
        }
    }
}

/// A plausible linear albedo for untextured (Caucasian) skin.
pub const SKIN_ALBEDO: [f32; 3] = [0.75, 0.5, 0.4];

// ---------------------------------------------------------------- parsing and validation

fn line_col(s: &str, offset: usize) -> (usize, usize) {
    let offset = offset.min(s.len());
    let before = &s.as_bytes()[..offset];
    let line = before.iter().filter(|&&b| b == b'\n').count() + 1;
    let line_start = before
        .iter()
        .rposition(|&b| b == b'\n')
        .map_or(0, |p| p + 1);
    let col = s[line_start..offset].chars().count() + 1;
    (line, col)
}

struct Check<'a> {
    file: &'a str,
}

impl Check<'_> {
    fn err(&self, field: impl Into<String>, msg: impl Into<String>) -> SceneError {
        SceneError::Invalid {
            file: self.file.to_string(),
            field: field.into(),
            msg: msg.into(),
        }
    }
    /// `x` must be finite and satisfy `ok`; `rule` reads e.g. "> 0".
    fn num(&self, field: &str, x: f32, ok: bool, rule: &str) -> Result<(), SceneError> {
        if x.is_finite() && ok {
            Ok(())
        } else if rule.is_empty() {
            Err(self.err(field, format!("must be finite (got {x})")))
        } else {
            Err(self.err(field, format!("must be finite and {rule} (got {x})")))
        }
    }
    fn finite(&self, field: &str, x: f32) -> Result<(), SceneError> {
        self.num(field, x, true, "")
    }
    fn finite3(&self, field: &str, v: [f32; 3]) -> Result<(), SceneError> {
        for (i, x) in v.into_iter().enumerate() {
            self.finite(&format!("{field}[{i}]"), x)?;
        }
        Ok(())
    }
    fn nonneg3(&self, field: &str, v: [f32; 3]) -> Result<(), SceneError> {
        for (i, x) in v.into_iter().enumerate() {
            self.num(&format!("{field}[{i}]"), x, x >= 0.0, ">= 0")?;
        }
        Ok(())
    }
    fn unit3(&self, field: &str, v: [f32; 3]) -> Result<(), SceneError> {
        for (i, x) in v.into_iter().enumerate() {
            self.num(
                &format!("{field}[{i}]"),
                x,
                (0.0..=1.0).contains(&x),
                "in [0, 1]",
            )?;
        }
        Ok(())
    }
    fn positive(&self, field: &str, x: f32) -> Result<(), SceneError> {
        self.num(field, x, x > 0.0, "> 0")
    }
    fn path(&self, field: &str, p: &Option<String>) -> Result<(), SceneError> {
        match p {
            Some(p) if p.trim().is_empty() => Err(self.err(field, "must not be empty")),
            _ => Ok(()),
        }
    }
}

impl SceneDesc {
    /// Parses and validates a scene. `name_for_errors` names the file in errors.
    pub fn from_toml_str(s: &str, name_for_errors: &str) -> Result<Self, SceneError> {
        let desc: SceneDesc = toml::from_str(s).map_err(|mut e| {
            let line_col = e.span().map(|sp| line_col(s, sp.start));
            let msg = one_line(e.message());
            // Without its input, toml's Display appends "in `a.b.c`" (the key path).
            e.set_input(None);
            let keys = e.to_string().lines().rev().find_map(|l| {
                l.strip_prefix("in `")?
                    .strip_suffix('`')
                    .map(str::to_string)
            });
            SceneError::Toml {
                file: name_for_errors.to_string(),
                line_col,
                msg: match keys {
                    Some(k) if !k.is_empty() => format!("{k}: {msg}"),
                    _ => msg,
                },
            }
        })?;
        desc.validate(name_for_errors)?;
        Ok(desc)
    }

    /// Serialises to TOML; `from_toml_str` of the result gives back `self`.
    pub fn to_toml_string(&self) -> String {
        toml::to_string(self).expect("a SceneDesc always serialises to TOML")
    }

    /// Checks every number (see `docs/scene-format.md` for the ranges).
    pub fn validate(&self, name_for_errors: &str) -> Result<(), SceneError> {
        let c = Check {
            file: name_for_errors,
        };
        // camera
        let cam = &self.camera;
        c.finite3("camera.position", cam.position)?;
        c.finite3("camera.target", cam.target)?;
        c.finite3("camera.up", cam.up)?;
        c.num(
            "camera.fov_y_deg",
            cam.fov_y_deg,
            cam.fov_y_deg > 0.0 && cam.fov_y_deg < 180.0,
            "in (0, 180)",
        )?;
        c.positive("camera.near", cam.near)?;
        c.num("camera.far", cam.far, cam.far > cam.near, "> camera.near")?;
        let dir = Vec3::from(cam.target) - Vec3::from(cam.position);
        if dir.length_squared() == 0.0 {
            return Err(c.err("camera.target", "must differ from camera.position"));
        }
        let up = Vec3::from(cam.up);
        if up.cross(dir).length_squared() <= 1e-12 * up.length_squared() * dir.length_squared() {
            return Err(c.err(
                "camera.up",
                "must be non-zero and not parallel to the view direction",
            ));
        }
        // render
        let r = &self.render;
        for (f, v) in [("render.width", r.width), ("render.height", r.height)] {
            if !(1..=16384).contains(&v) {
                return Err(c.err(f, format!("must be in 1..=16384 (got {v})")));
            }
        }
        c.finite("render.exposure_ev", r.exposure_ev)?;
        c.nonneg3("render.ambient", r.ambient)?;
        c.nonneg3("render.background", r.background)?;
        c.finite("render.normal_shrink", r.normal_shrink)?;
        if !(3..=63).contains(&r.samples) || r.samples.is_multiple_of(2) {
            return Err(c.err(
                "render.samples",
                format!("must be odd and in 3..=63 (got {})", r.samples),
            ));
        }
        if !(1..=15).contains(&r.thickness_filter) || r.thickness_filter.is_multiple_of(2) {
            return Err(c.err(
                "render.thickness_filter",
                format!("must be odd and in 1..=15 (got {})", r.thickness_filter),
            ));
        }
        if r.normal_shrink < 0.0 {
            return Err(c.err(
                "render.normal_shrink",
                format!("must be >= 0 (got {})", r.normal_shrink),
            ));
        }
        // lights
        for (i, l) in self.lights.iter().enumerate() {
            let f = |k: &str| format!("lights[{i}].{k}");
            c.finite3(&f("position"), l.position)?;
            c.finite3(&f("target"), l.target)?;
            c.nonneg3(&f("color"), l.color)?;
            c.num(&f("intensity"), l.intensity, l.intensity >= 0.0, ">= 0")?;
            c.finite(&f("inner_angle_deg"), l.inner_angle_deg)?;
            c.finite(&f("outer_angle_deg"), l.outer_angle_deg)?;
            if l.kind == LightKind::Spot {
                c.num(
                    &f("inner_angle_deg"),
                    l.inner_angle_deg,
                    l.inner_angle_deg > 0.0 && l.inner_angle_deg <= l.outer_angle_deg,
                    "> 0 and <= outer_angle_deg",
                )?;
                c.num(
                    &f("outer_angle_deg"),
                    l.outer_angle_deg,
                    l.outer_angle_deg < 90.0,
                    "< 90",
                )?;
            }
            if l.kind != LightKind::Point && l.position == l.target {
                return Err(c.err(
                    f("target"),
                    "must differ from position (it gives the light direction)",
                ));
            }
            let s = l.shadow_map_size;
            if s != 0 && !(16..=8192).contains(&s) {
                return Err(c.err(
                    f("shadow_map_size"),
                    format!("must be 0 (no shadow) or in 16..=8192 (got {s})"),
                ));
            }
            c.num(
                &f("shadow_bias"),
                l.shadow_bias,
                l.shadow_bias >= 0.0,
                ">= 0",
            )?;
        }
        // objects
        for (i, o) in self.objects.iter().enumerate() {
            let f = |k: &str| format!("objects[{i}].{k}");
            match &o.mesh {
                MeshDesc::Gltf { path } => c.path(&f("mesh.gltf"), &Some(path.clone()))?,
                MeshDesc::Slab {
                    width,
                    height,
                    thickness,
                } => {
                    c.positive(&f("mesh.width"), *width)?;
                    c.positive(&f("mesh.height"), *height)?;
                    c.positive(&f("mesh.thickness"), *thickness)?;
                }
                MeshDesc::Wedge {
                    length,
                    height,
                    max_thickness,
                } => {
                    c.positive(&f("mesh.length"), *length)?;
                    c.positive(&f("mesh.height"), *height)?;
                    c.positive(&f("mesh.max_thickness"), *max_thickness)?;
                }
                MeshDesc::Sphere { radius, segments } => {
                    c.positive(&f("mesh.radius"), *radius)?;
                    if !(3..=1024).contains(segments) {
                        return Err(c.err(
                            f("mesh.segments"),
                            format!("must be in 3..=1024 (got {segments})"),
                        ));
                    }
                }
            }
            c.positive(&f("mm_per_unit"), o.mm_per_unit)?;
            c.finite3(&f("translation"), o.translation)?;
            c.finite3(&f("rotation_deg"), o.rotation_deg)?;
            c.positive(&f("scale"), o.scale)?;
            let m = &o.material;
            let f = |k: &str| format!("objects[{i}].material.{k}");
            c.nonneg3(&f("albedo"), m.albedo)?;
            c.path(&f("albedo_texture"), &m.albedo_texture)?;
            c.path(&f("normal_texture"), &m.normal_texture)?;
            c.path(&f("specular_texture"), &m.specular_texture)?;
            c.num(
                &f("roughness"),
                m.roughness,
                m.roughness > 0.0 && m.roughness <= 1.0,
                "in (0, 1]",
            )?;
            c.num(&f("specular"), m.specular, m.specular >= 0.0, ">= 0")?;
            c.num(
                &f("sss_strength"),
                m.sss_strength,
                (0.0..=1.0).contains(&m.sss_strength),
                "in [0, 1]",
            )?;
            c.positive(&f("sss_width"), m.sss_width)?;
            c.num(
                &f("translucency"),
                m.translucency,
                m.translucency >= 0.0,
                ">= 0",
            )?;
            if m.profile.trim().is_empty() {
                return Err(c.err(f("profile"), "must not be empty"));
            }
            c.unit3(&f("kernel_strength"), m.kernel_strength)?;
            c.unit3(&f("falloff"), m.falloff)?;
        }
        Ok(())
    }
}

// ---------------------------------------------------------------- loaded scene

/// A scene with meshes and textures decoded.
#[derive(Clone)]
pub struct Scene {
    pub desc: SceneDesc,
    /// One per `desc.objects`, same order.
    pub objects: Vec<Object>,
}

/// A loaded object.
#[derive(Clone)]
pub struct Object {
    pub name: String,
    /// Object space (glTF node transforms baked in), with tangents.
    pub mesh: Mesh,
    /// Object -> world.
    pub transform: glam::Mat4,
    /// Millimetres per object-space unit (before `transform`'s scale).
    pub mm_per_unit: f32,
    /// `material.albedo` times the glTF base colour factor (if `use_gltf_color`).
    pub albedo: [f32; 3],
    /// sRGB-encoded colour texture.
    pub albedo_texture: Option<image::RgbaImage>,
    /// Linear tangent-space normal map.
    pub normal_texture: Option<image::RgbaImage>,
    /// Linear specular map.
    pub specular_texture: Option<image::RgbaImage>,
    pub material: MaterialDesc,
}

impl Object {
    /// World-space AABB of the object.
    pub fn world_bounds(&self) -> (Vec3, Vec3) {
        let (lo, hi) = self.mesh.bounds();
        let mut out = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for k in 0..8 {
            let c = Vec3::new(
                if k & 1 == 0 { lo.x } else { hi.x },
                if k & 2 == 0 { lo.y } else { hi.y },
                if k & 4 == 0 { lo.z } else { hi.z },
            );
            let p = self.transform.transform_point3(c);
            out = (out.0.min(p), out.1.max(p));
        }
        out
    }
}

/// Reads and decodes an image file as RGBA8.
pub fn load_image(path: &Path) -> Result<image::RgbaImage, SceneError> {
    let file = path.display().to_string();
    let reader = image::ImageReader::open(path).map_err(|e| SceneError::Io {
        file: file.clone(),
        msg: one_line(&e.to_string()),
    })?;
    let reader = reader.with_guessed_format().map_err(|e| SceneError::Io {
        file: file.clone(),
        msg: one_line(&e.to_string()),
    })?;
    let img = reader.decode().map_err(|e| SceneError::Image {
        file,
        msg: one_line(&e.to_string()),
    })?;
    Ok(img.to_rgba8())
}

fn load_object(
    o: &ObjectDesc,
    index: usize,
    base_dir: &Path,
    file: &str,
) -> Result<Object, SceneError> {
    let ctx = |field: &str, e: SceneError| SceneError::Asset {
        file: file.to_string(),
        field: format!("objects[{index}].{field}"),
        source: Box::new(e),
    };
    let m = &o.material;
    let mut albedo = m.albedo;
    let mut albedo_texture = None;
    let mut normal_texture = None;
    let mesh = match &o.mesh {
        MeshDesc::Gltf { path } => {
            let model = if path == BUILTIN_HAND {
                mesh::load_gltf_slice(mesh::BUILTIN_HAND_GLB, "builtin:hand (right.glb)")
            } else {
                mesh::load_gltf(&base_dir.join(path))
            }
            .map_err(|e| ctx("mesh.gltf", e))?;
            if m.use_gltf_color {
                for (a, f) in albedo.iter_mut().zip(model.base_color_factor) {
                    *a *= f;
                }
                albedo_texture = model.base_color_texture;
            }
            normal_texture = model.normal_texture;
            model.mesh
        }
        MeshDesc::Slab {
            width,
            height,
            thickness,
        } => Mesh::slab(*width, *height, *thickness),
        MeshDesc::Wedge {
            length,
            height,
            max_thickness,
        } => Mesh::wedge(*length, *height, *max_thickness),
        MeshDesc::Sphere { radius, segments } => Mesh::sphere(*radius, *segments),
    };
    let tex = |field: &str, p: &Option<String>| -> Result<Option<image::RgbaImage>, SceneError> {
        p.as_ref()
            .map(|p| load_image(&base_dir.join(p)).map_err(|e| ctx(field, e)))
            .transpose()
    };
    if let Some(t) = tex("material.albedo_texture", &m.albedo_texture)? {
        albedo_texture = Some(t);
    }
    if let Some(t) = tex("material.normal_texture", &m.normal_texture)? {
        normal_texture = Some(t);
    }
    let specular_texture = tex("material.specular_texture", &m.specular_texture)?;
    Ok(Object {
        name: if o.name.is_empty() {
            format!("object{index}")
        } else {
            o.name.clone()
        },
        mesh,
        transform: o.transform(),
        mm_per_unit: o.mm_per_unit,
        albedo,
        albedo_texture,
        normal_texture,
        specular_texture,
        material: m.clone(),
    })
}

fn union(a: (Vec3, Vec3), b: (Vec3, Vec3)) -> (Vec3, Vec3) {
    (a.0.min(b.0), a.1.max(b.1))
}

impl Scene {
    /// Reads, validates and loads a scene file; relative paths in it are
    /// resolved against the file's directory.
    pub fn load_file(path: &Path) -> Result<Scene, SceneError> {
        let name = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| SceneError::Io {
            file: name.clone(),
            msg: one_line(&e.to_string()),
        })?;
        let desc = SceneDesc::from_toml_str(&text, &name)?;
        let base = path
            .parent()
            .filter(|p| !p.as_os_str().is_empty())
            .map_or_else(|| PathBuf::from("."), Path::to_path_buf);
        Scene::from_desc(desc, &base, &name)
    }

    /// Validates `desc` and loads its meshes and textures (paths relative to `base_dir`).
    pub fn from_desc(
        desc: SceneDesc,
        base_dir: &Path,
        name_for_errors: &str,
    ) -> Result<Scene, SceneError> {
        desc.validate(name_for_errors)?;
        let objects = desc
            .objects
            .iter()
            .enumerate()
            .map(|(i, o)| load_object(o, i, base_dir, name_for_errors))
            .collect::<Result<Vec<_>, _>>()?;
        Ok(Scene { desc, objects })
    }

    /// The embedded default scene (backlit hand and wedge). Needs no files.
    pub fn default_scene() -> Scene {
        // Proven to load by the unit test `default_scene_loads`.
        let desc = SceneDesc::from_toml_str(DEFAULT_SCENE_TOML, "<default scene>")
            .expect("embedded default scene parses");
        Scene::from_desc(desc, Path::new("."), "<default scene>")
            .expect("embedded default scene loads")
    }

    /// World-space AABB of all objects; `(0, 0)` if there are none.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.objects
            .iter()
            .map(Object::world_bounds)
            .reduce(union)
            .unwrap_or((Vec3::ZERO, Vec3::ZERO))
    }

    /// `--model`: replaces all objects by this GLB (in metres: mm_per_unit
    /// 1000). The material is the default one if the file has a base colour
    /// texture, else untextured skin ([`MaterialDesc::skin`]). The camera keeps
    /// its direction and is moved so the model's bounding sphere fits the field
    /// of view; lights are moved (and point/spot intensities and shadow biases
    /// rescaled) by the similarity that maps the old scene's bounding sphere
    /// onto the new one, so the lighting setup is preserved.
    pub fn replace_model(&mut self, glb: &Path) -> Result<(), SceneError> {
        let (old_c, old_r) = bounding_sphere(self.bounds());
        let model = mesh::load_gltf(glb)?;
        let path_str = std::path::absolute(glb)
            .unwrap_or_else(|_| glb.to_path_buf())
            .display()
            .to_string();
        let material = if model.base_color_texture.is_some() {
            MaterialDesc::default()
        } else {
            MaterialDesc::skin()
        };
        let mut albedo = material.albedo;
        if material.use_gltf_color {
            for (a, f) in albedo.iter_mut().zip(model.base_color_factor) {
                *a *= f;
            }
        }
        let name = glb
            .file_stem()
            .map_or_else(|| "model".to_string(), |s| s.to_string_lossy().into_owned());
        let desc = ObjectDesc {
            name: name.clone(),
            mesh: MeshDesc::Gltf { path: path_str },
            mm_per_unit: 1000.0,
            translation: [0.0; 3],
            rotation_deg: [0.0; 3],
            scale: 1.0,
            material: material.clone(),
        };
        let object = Object {
            name,
            mesh: model.mesh,
            transform: desc.transform(),
            mm_per_unit: 1000.0,
            albedo,
            albedo_texture: if material.use_gltf_color {
                model.base_color_texture
            } else {
                None
            },
            normal_texture: model.normal_texture,
            specular_texture: None,
            material,
        };
        self.desc.objects = vec![desc];
        self.objects = vec![object];

        let (c, r) = bounding_sphere(self.bounds());
        let r = r.max(1e-6);
        // Lights: similarity transform old sphere -> new sphere.
        if old_r > 0.0 {
            let s = r / old_r;
            for l in &mut self.desc.lights {
                let map = |p: [f32; 3]| (c + (Vec3::from(p) - old_c) * s).to_array();
                l.position = map(l.position);
                l.target = map(l.target);
                if l.kind != LightKind::Directional {
                    l.intensity *= s * s;
                }
                l.shadow_bias *= s;
            }
        }
        // Camera: keep direction, fit the bounding sphere in the narrower fov.
        let cam = &mut self.desc.camera;
        let dir = (Vec3::from(cam.target) - Vec3::from(cam.position)).normalize_or(-Vec3::Z);
        let half_y = cam.fov_y_deg.to_radians() * 0.5;
        let aspect = self.desc.render.width as f32 / self.desc.render.height as f32;
        let half_x = (half_y.tan() * aspect).atan();
        let half = half_y.min(half_x);
        let dist = r / half.sin();
        cam.target = c.to_array();
        cam.position = (c - dir * dist).to_array();
        cam.near = ((dist - r) * 0.5).max(dist * 1e-3);
        cam.far = (dist + r) * 2.0;
        Ok(())
    }
}

/// Centre and radius of the sphere circumscribing an AABB.
fn bounding_sphere((lo, hi): (Vec3, Vec3)) -> (Vec3, f32) {
    ((lo + hi) * 0.5, (hi - lo).length() * 0.5)
}

#[cfg(test)]
mod tests {
    use super::*;

    const MINIMAL: &str = r#"
[camera]
position = [0.0, 0.0, 1.0]
target = [0.0, 0.0, 0.0]

[[lights]]
kind = "spot"
position = [0.0, 0.0, -1.0]
target = [0.0, 0.0, 0.0]

[[objects]]
mesh = { shape = "slab", width = 0.1, height = 0.1, thickness = 0.01 }
"#;

    fn parse(s: &str) -> Result<SceneDesc, SceneError> {
        SceneDesc::from_toml_str(s, "t.toml")
    }

    /// Parses MINIMAL with one `key = value` line appended to the `[table]`
    /// that is also given, expecting an error mentioning `field`.
    fn invalid_with(table_line: &str, insert: &str, field: &str) {
        let s = MINIMAL.replacen(table_line, &format!("{table_line}\n{insert}"), 1);
        let e = parse(&s).expect_err(&format!("{insert} should be rejected"));
        let msg = e.to_string();
        assert!(!msg.contains('\n'), "{msg}");
        assert!(msg.starts_with("t.toml"), "{msg}");
        assert!(msg.contains(field), "`{msg}` does not name `{field}`");
    }

    fn cam(line: &str, field: &str) {
        invalid_with("[camera]", line, field)
    }
    fn light(line: &str, field: &str) {
        invalid_with("kind = \"spot\"", line, field)
    }
    fn obj(line: &str, field: &str) {
        invalid_with(
            "mesh = { shape = \"slab\", width = 0.1, height = 0.1, thickness = 0.01 }",
            line,
            field,
        )
    }
    fn mat(line: &str, field: &str) {
        let s = format!("{MINIMAL}\n[objects.material]\n{line}\n");
        let e = parse(&s).expect_err(&format!("{line} should be rejected"));
        let msg = e.to_string();
        assert!(!msg.contains('\n'), "{msg}");
        assert!(msg.contains(field), "`{msg}` does not name `{field}`");
    }
    fn render(line: &str, field: &str) {
        let s = format!("{MINIMAL}\n[render]\n{line}\n");
        let e = parse(&s).expect_err(&format!("{line} should be rejected"));
        assert!(e.to_string().contains(field), "{e} does not name {field}");
    }
    fn mesh(m: &str, needle: &str) {
        let s = MINIMAL.replace(
            "mesh = { shape = \"slab\", width = 0.1, height = 0.1, thickness = 0.01 }",
            &format!("mesh = {m}"),
        );
        let e = parse(&s).expect_err(&format!("{m} should be rejected"));
        let msg = e.to_string();
        assert!(!msg.contains('\n'), "{msg}");
        assert!(msg.contains(needle), "`{msg}` does not contain `{needle}`");
    }

    #[test]
    fn minimal_scene_gets_defaults() {
        let d = parse(MINIMAL).unwrap();
        assert_eq!(d.camera.up, [0.0, 1.0, 0.0]);
        assert_eq!(d.camera.fov_y_deg, 30.0);
        assert_eq!(d.render, RenderDesc::default());
        assert_eq!(d.lights[0].kind, LightKind::Spot);
        assert_eq!(d.lights[0].shadow_map_size, 2048);
        assert_eq!(d.objects[0].mm_per_unit, 1000.0);
        assert_eq!(d.objects[0].scale, 1.0);
        assert_eq!(d.objects[0].material, MaterialDesc::default());
        let m = &d.objects[0].material;
        assert_eq!(m.roughness, 0.3);
        assert_eq!(m.specular, 0.18);
        assert_eq!(m.kernel_strength, [0.48, 0.41, 0.28]);
        assert_eq!(m.falloff, [1.0, 0.37, 0.3]);
        assert_eq!(m.profile, "skin");
    }

    #[test]
    fn mesh_forms() {
        let with = |m: &str| {
            parse(&MINIMAL.replace(
                "mesh = { shape = \"slab\", width = 0.1, height = 0.1, thickness = 0.01 }",
                &format!("mesh = {m}"),
            ))
            .unwrap()
            .objects[0]
                .mesh
                .clone()
        };
        assert_eq!(
            with(r#"{ gltf = "a/b.glb" }"#),
            MeshDesc::Gltf {
                path: "a/b.glb".into()
            }
        );
        assert_eq!(
            with(r#"{ shape = "wedge", length = 1, height = 2, max_thickness = 0.5 }"#),
            MeshDesc::Wedge {
                length: 1.0,
                height: 2.0,
                max_thickness: 0.5
            }
        );
        assert_eq!(
            with(r#"{ shape = "sphere", radius = 2 }"#),
            MeshDesc::Sphere {
                radius: 2.0,
                segments: 64
            }
        );
    }

    #[test]
    fn round_trip_all_files() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
        let mut texts = vec![("default".to_string(), DEFAULT_SCENE_TOML.to_string())];
        for entry in std::fs::read_dir(root.join("scenes")).unwrap() {
            let p = entry.unwrap().path();
            if p.extension().is_some_and(|e| e == "toml") {
                texts.push((
                    p.display().to_string(),
                    std::fs::read_to_string(&p).unwrap(),
                ));
            }
        }
        assert!(texts.len() >= 3, "expected scenes/*.toml");
        for (name, text) in texts {
            let d = SceneDesc::from_toml_str(&text, &name).unwrap();
            let s = d.to_toml_string();
            let d2 = SceneDesc::from_toml_str(&s, "round-trip")
                .unwrap_or_else(|e| panic!("{name}: {e}\n{s}"));
            assert_eq!(d, d2, "{name}\n{s}");
        }
        // Also every mesh kind and optional field.
        let mut d = parse(MINIMAL).unwrap();
        let mut o = d.objects[0].clone();
        o.material.albedo_texture = Some("a.png".into());
        o.material.use_gltf_color = false;
        o.mesh = MeshDesc::Sphere {
            radius: 0.3,
            segments: 7,
        };
        d.objects.push(o.clone());
        o.mesh = MeshDesc::Gltf {
            path: "x y/\"q\".glb".into(),
        };
        d.objects.push(o.clone());
        o.mesh = MeshDesc::Wedge {
            length: 0.1,
            height: 0.2,
            max_thickness: 0.03,
        };
        d.objects.push(o);
        d.lights.push(LightDesc {
            kind: LightKind::Directional,
            ..Default::default()
        });
        let s = d.to_toml_string();
        assert_eq!(SceneDesc::from_toml_str(&s, "rt").unwrap(), d, "{s}");
    }

    #[test]
    fn syntax_and_unknown_key_errors_have_line_col() {
        let e = parse("[camera]\nposition = [0, 0, 1]\ntarget = [0,0,0]\nfoo = 1\n")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("t.toml:4:1: "), "{e}");
        assert!(e.contains("unknown field `foo`"), "{e}");
        assert!(!e.contains('\n'));
        let e = parse("[camera\n").unwrap_err().to_string();
        assert!(e.starts_with("t.toml:1:"), "{e}");
        assert!(!e.contains('\n'));
        let e = parse(&format!("{MINIMAL}\n[bogus]\n"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("unknown field `bogus`"), "{e}");
        // unknown key in a nested table
        mat("glossiness = 0.5", "unknown field `glossiness`");
        // wrong type
        let e = parse(&MINIMAL.replace("kind = \"spot\"", "kind = \"area\""))
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("t.toml:7:"), "{e}");
        assert!(!e.contains('\n'));
        for bad in [
            "[camera]\nposition = [0, 0]\ntarget = [0, 0, 0]\n",
            "[camera]\nposition = [0, 0, 1]\ntarget = [0, 0, 0]\n[[objects]]\nmesh = { shape = \"slab\" }\n",
            "[camera]\nposition = [0, 0, 1]\ntarget = [0, 0, 0]\n[[lights]]\nkind = \"point\"\n",
            "[camera]\nposition = [0, 0, 1]\ntarget = [0, 0, 0]\n[[objects]]\nmesh = { gltf = \"a\" }\n[objects.material]\nroughness = \"x\"\n",
        ] {
            let e = parse(bad).unwrap_err().to_string();
            eprintln!("{e}");
            assert!(e.starts_with("t.toml:") && !e.contains('\n'), "{e}");
        }
        // missing camera
        let e = parse("").unwrap_err().to_string();
        assert!(e.contains("camera"), "{e}");
    }

    #[test]
    fn invalid_mesh_tables() {
        mesh(
            r#"{ shape = "slab", width = 1, height = 1 }"#,
            "needs `thickness`",
        );
        mesh(
            r#"{ shape = "slab", width = 1, height = 1, thickness = 1, radius = 2 }"#,
            "`radius` does not apply",
        );
        mesh(r#"{ gltf = "a.glb", shape = "slab" }"#, "not both");
        mesh(
            r#"{ gltf = "a.glb", radius = 1 }"#,
            "`radius` does not apply",
        );
        mesh("{}", "needs `gltf");
        mesh(r#"{ shape = "cube" }"#, "cube");
        mesh(
            r#"{ gltf = "a.glb", colour = 1 }"#,
            "unknown field `colour`",
        );
        let e = parse(&MINIMAL.replace("width = 0.1", "width = 0.1, depth = 2"))
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("t.toml:12:"), "{e}");
    }

    #[test]
    fn invalid_non_finite() {
        cam("fov_y_deg = nan", "camera.fov_y_deg");
        cam("near = inf", "camera.near");
        light("intensity = -inf", "lights[0].intensity");
        light("shadow_bias = nan", "lights[0].shadow_bias");
        obj("translation = [0.0, nan, 0.0]", "objects[0].translation[1]");
        obj(
            "rotation_deg = [inf, 0.0, 0.0]",
            "objects[0].rotation_deg[0]",
        );
        mat("roughness = nan", "objects[0].material.roughness");
        render("exposure_ev = nan", "render.exposure_ev");
        let e = parse(&MINIMAL.replace("position = [0.0, 0.0, 1.0]", "position = [0.0, nan, 1.0]"))
            .unwrap_err()
            .to_string();
        assert_eq!(e, "t.toml: camera.position[1]: must be finite (got NaN)");
    }

    #[test]
    fn invalid_camera() {
        cam("near = 0.0", "camera.near");
        cam("near = -1.0", "camera.near");
        cam("near = 2.0\nfar = 1.0", "camera.far");
        cam("fov_y_deg = 0.0", "camera.fov_y_deg");
        cam("fov_y_deg = 180.0", "camera.fov_y_deg");
        cam("up = [0.0, 0.0, 1.0]", "camera.up");
        cam("up = [0.0, 0.0, 0.0]", "camera.up");
        let e = parse(&MINIMAL.replace(
            "target = [0.0, 0.0, 0.0]\n\n[[lights]]",
            "target = [0.0, 0.0, 1.0]\n\n[[lights]]",
        ))
        .unwrap_err()
        .to_string();
        assert!(e.contains("camera.target"), "{e}");
    }

    #[test]
    fn invalid_render() {
        render("width = 0", "render.width");
        render("height = 16385", "render.height");
        render("ambient = [0.1, -0.1, 0.0]", "render.ambient[1]");
        render("background = [-1.0, 0.0, 0.0]", "render.background[0]");
        render("width = -5", "render.width");
    }

    #[test]
    fn invalid_lights() {
        light("intensity = -1.0", "lights[0].intensity");
        light("color = [1.0, -0.5, 1.0]", "lights[0].color[1]");
        light("inner_angle_deg = 0.0", "lights[0].inner_angle_deg");
        light(
            "inner_angle_deg = 40.0\nouter_angle_deg = 30.0",
            "lights[0].inner_angle_deg",
        );
        light("outer_angle_deg = 90.0", "lights[0].outer_angle_deg");
        light("shadow_map_size = 8", "lights[0].shadow_map_size");
        light("shadow_map_size = 8193", "lights[0].shadow_map_size");
        light("shadow_bias = -0.1", "lights[0].shadow_bias");
        // spot with position == target
        let e =
            parse(&MINIMAL.replace("position = [0.0, 0.0, -1.0]", "position = [0.0, 0.0, 0.0]"))
                .unwrap_err()
                .to_string();
        assert!(e.contains("lights[0].target"), "{e}");
        // point lights: angles and target are not checked beyond finiteness
        let ok = MINIMAL
            .replace(
                "kind = \"spot\"",
                "kind = \"point\"\nouter_angle_deg = 120.0",
            )
            .replace("position = [0.0, 0.0, -1.0]", "position = [0.0, 0.0, 0.0]");
        parse(&ok).unwrap();
        // shadow_map_size = 0 (no shadow) is fine
        parse(&MINIMAL.replace("kind = \"spot\"", "kind = \"spot\"\nshadow_map_size = 0")).unwrap();
    }

    #[test]
    fn invalid_objects() {
        let e = parse(&MINIMAL.replace(
            "mesh = { shape = \"slab\", width = 0.1, height = 0.1, thickness = 0.01 }",
            "mesh = { shape = \"slab\", width = 0.1, height = 0.1, thickness = 0.01 }\nmm_per_unit = -1",
        ))
        .unwrap_err()
        .to_string();
        assert_eq!(
            e,
            "t.toml: objects[0].mm_per_unit: must be finite and > 0 (got -1)"
        );
        obj("mm_per_unit = 0.0", "objects[0].mm_per_unit");
        obj("scale = 0.0", "objects[0].scale");
        mesh(
            r#"{ shape = "slab", width = 0, height = 1, thickness = 1 }"#,
            "objects[0].mesh.width",
        );
        mesh(
            r#"{ shape = "slab", width = 1, height = -1, thickness = 1 }"#,
            "objects[0].mesh.height",
        );
        mesh(
            r#"{ shape = "slab", width = 1, height = 1, thickness = 0 }"#,
            "objects[0].mesh.thickness",
        );
        mesh(
            r#"{ shape = "wedge", length = 0, height = 1, max_thickness = 1 }"#,
            "objects[0].mesh.length",
        );
        mesh(
            r#"{ shape = "wedge", length = 1, height = 1, max_thickness = -1 }"#,
            "objects[0].mesh.max_thickness",
        );
        mesh(
            r#"{ shape = "sphere", radius = 0 }"#,
            "objects[0].mesh.radius",
        );
        mesh(
            r#"{ shape = "sphere", radius = 1, segments = 2 }"#,
            "objects[0].mesh.segments",
        );
        mesh(
            r#"{ shape = "sphere", radius = 1, segments = 1025 }"#,
            "objects[0].mesh.segments",
        );
        mesh(r#"{ gltf = "" }"#, "objects[0].mesh.gltf");
    }

    #[test]
    fn invalid_materials() {
        mat("roughness = 0.0", "objects[0].material.roughness");
        mat("roughness = 1.5", "objects[0].material.roughness");
        mat("specular = -0.1", "objects[0].material.specular");
        mat("sss_strength = 1.1", "objects[0].material.sss_strength");
        mat("sss_strength = -0.1", "objects[0].material.sss_strength");
        mat("sss_width = 0.0", "objects[0].material.sss_width");
        mat("translucency = -1.0", "objects[0].material.translucency");
        mat(
            "kernel_strength = [0.5, 1.5, 0.5]",
            "objects[0].material.kernel_strength[1]",
        );
        mat(
            "falloff = [-0.1, 0.5, 0.5]",
            "objects[0].material.falloff[0]",
        );
        mat("albedo = [0.5, 0.5, -0.5]", "objects[0].material.albedo[2]");
        mat("profile = \"\"", "objects[0].material.profile");
        mat(
            "albedo_texture = \"\"",
            "objects[0].material.albedo_texture",
        );
        // Boundaries that are valid.
        let ok = format!(
            "{MINIMAL}\n[objects.material]\nroughness = 1.0\nsss_strength = 0.0\nspecular = 0.0\ntranslucency = 0.0\nkernel_strength = [0.0, 1.0, 0.0]\n"
        );
        parse(&ok).unwrap();
    }

    #[test]
    fn default_scene_loads() {
        let s = Scene::default_scene();
        assert_eq!(s.objects.len(), s.desc.objects.len());
        assert!(s.objects.len() >= 2);
        let shadowed = s
            .desc
            .lights
            .iter()
            .filter(|l| l.shadow_map_size > 0)
            .count();
        assert!(shadowed >= 2);
        let hand = &s.objects[0];
        assert_eq!(hand.mm_per_unit, 1000.0);
        assert!(hand.mesh.vertices.len() > 1000);
        let (lo, hi) = s.bounds();
        eprintln!("default scene bounds {lo} .. {hi}");
        assert!((hi - lo).max_element() < 1.0);
        // Camera looks at the scene.
        let cam = &s.desc.camera;
        let c = (lo + hi) * 0.5;
        let dir = (Vec3::from(cam.target) - Vec3::from(cam.position)).normalize();
        let to_c = (c - Vec3::from(cam.position)).normalize();
        assert!(dir.dot(to_c) > 0.95);
        // Hand orientation (see default_scene.toml): in object space the fingers
        // point to -y, the palm faces -x and the thumb is at -z; in the world the
        // fingers point up, the palm faces the camera (+z), the thumb is at +x.
        let w = |p: [f32; 3]| hand.transform.transform_point3(Vec3::from(p));
        let wrist = w([0.039, 0.056, 0.009]);
        let middle_tip = w([0.030, -0.122, 0.016]);
        let thumb_tip = w([-0.0098, -0.0359, -0.0687]);
        let pinky_tip = w([0.0174, -0.0821, 0.0611]);
        assert!(middle_tip.y - wrist.y > 0.15, "{wrist} {middle_tip}");
        assert!(thumb_tip.x - pinky_tip.x > 0.08, "{thumb_tip} {pinky_tip}");
        assert!(thumb_tip.z > pinky_tip.z);
        // The wedge: thin edge toward the hand.
        let (wlo, whi) = s.objects[1].world_bounds();
        assert!(wlo.x > hand.world_bounds().1.x);
        assert!((whi.z - wlo.z - 0.025).abs() < 1e-6);
    }

    #[test]
    fn scene_files_validate_and_refer_to_existing_assets() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
        for name in ["head.toml", "five-lights.toml"] {
            let p = root.join("scenes").join(name);
            let d = SceneDesc::from_toml_str(&std::fs::read_to_string(&p).unwrap(), name).unwrap();
            if name == "five-lights.toml" {
                assert!(d.lights.iter().filter(|l| l.shadow_map_size > 0).count() >= 5);
            }
            if !root
                .join("../shared/assets/LeePerrySmith/LeePerrySmith.glb")
                .exists()
            {
                continue;
            }
            let t0 = std::time::Instant::now();
            let s = Scene::load_file(&p).unwrap_or_else(|e| panic!("{e}"));
            eprintln!(
                "{name}: loaded in {:?}, bounds {:?}",
                t0.elapsed(),
                s.bounds()
            );
            let head = &s.objects[0];
            assert_eq!(head.mm_per_unit, 48.0);
            assert!(head.albedo_texture.is_some());
            assert!(head.normal_texture.is_some());
            assert!(head.specular_texture.is_some());
        }
    }

    #[test]
    fn asset_errors_name_scene_field_and_file() {
        let dir =
            std::env::temp_dir().join(format!("subsurface-scene-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("bad.glb"), b"glTF garbage").unwrap();
        std::fs::write(dir.join("bad.png"), b"\x89PNG\r\n\x1a\n garbage").unwrap();
        let scene = |mesh: &str, mat: &str| {
            let s = format!(
                "[camera]\nposition = [0.0, 0.0, 1.0]\ntarget = [0.0, 0.0, 0.0]\n[[objects]]\nmesh = {mesh}\n[objects.material]\n{mat}\n"
            );
            let p = dir.join("s.toml");
            std::fs::write(&p, s).unwrap();
            Scene::load_file(&p).err().expect("should fail").to_string()
        };
        let slab = r#"{ shape = "slab", width = 1, height = 1, thickness = 1 }"#;
        let e = scene(r#"{ gltf = "missing.glb" }"#, "");
        assert!(
            e.contains("s.toml: objects[0].mesh.gltf: ") && e.contains("missing.glb: cannot read"),
            "{e}"
        );
        let e = scene(r#"{ gltf = "bad.glb" }"#, "");
        assert!(e.contains("bad.glb: not a valid glTF file"), "{e}");
        let e = scene(slab, "albedo_texture = \"nope.png\"");
        assert!(
            e.contains("objects[0].material.albedo_texture: ")
                && e.contains("nope.png: cannot read"),
            "{e}"
        );
        let e = scene(slab, "normal_texture = \"bad.png\"");
        assert!(
            e.contains("objects[0].material.normal_texture: ")
                && e.contains("bad.png: cannot decode image"),
            "{e}"
        );
        assert!(!e.contains('\n'), "{e}");
        let e = Scene::load_file(&dir.join("nonexistent.toml"))
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("nonexistent.toml: cannot read"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn replace_model_refits_camera() {
        let mut s = Scene::default_scene();
        let dir0 =
            (Vec3::from(s.desc.camera.target) - Vec3::from(s.desc.camera.position)).normalize();
        // Write the hand GLB to a temp file and load it as a model scaled... it is the same
        // hand, so the new scene is just the hand.
        let dir =
            std::env::temp_dir().join(format!("subsurface-model-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("hand.glb");
        std::fs::write(&p, mesh::BUILTIN_HAND_GLB).unwrap();
        s.replace_model(&p).unwrap();
        assert_eq!(s.objects.len(), 1);
        assert_eq!(s.desc.objects.len(), 1);
        assert_eq!(s.objects[0].mm_per_unit, 1000.0);
        assert_eq!(s.objects[0].albedo, SKIN_ALBEDO);
        let cam = &s.desc.camera;
        let dir1 = (Vec3::from(cam.target) - Vec3::from(cam.position)).normalize();
        assert!(dir0.dot(dir1) > 0.9999);
        let (c, r) = bounding_sphere(s.bounds());
        assert!((Vec3::from(cam.target) - c).length() < 1e-5);
        let dist = (Vec3::from(cam.position) - c).length();
        let half = cam.fov_y_deg.to_radians() * 0.5; // 16:9, vertical is narrower
        assert!((r / dist - half.sin()).abs() < 1e-4);
        assert!(cam.near < dist - r && cam.far > dist + r);
        s.desc.validate("after replace").unwrap();
        // Round-trips with the absolute path.
        let t = s.desc.to_toml_string();
        assert_eq!(SceneDesc::from_toml_str(&t, "x").unwrap(), s.desc);
        assert!(s.replace_model(&dir.join("missing.glb")).is_err());
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn euler_convention() {
        let o = ObjectDesc {
            name: String::new(),
            mesh: MeshDesc::Sphere {
                radius: 1.0,
                segments: 8,
            },
            mm_per_unit: 1.0,
            translation: [1.0, 2.0, 3.0],
            rotation_deg: [0.0, 90.0, 0.0],
            scale: 2.0,
            material: MaterialDesc::default(),
        };
        // +x rotated 90 deg about y -> -z, scaled by 2, translated.
        let p = o.transform().transform_point3(Vec3::X);
        assert!((p - Vec3::new(1.0, 2.0, 1.0)).length() < 1e-5, "{p}");
    }
}
