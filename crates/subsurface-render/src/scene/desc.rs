//! The scene description as written in a scene file (TOML, `docs/guide.md`).

use glam::{EulerRot, Mat4, Quat, Vec3};
use serde::{Deserialize, Serialize};

use subsurface_profile::exact_array::{exact, exact_opt};
use subsurface_profile::{DEFAULT_FALLOFF, DEFAULT_STRENGTH, Medium};

use crate::settings::RenderSettings;

/// The gltf path that names the embedded vendored WebXR right hand.
pub const BUILTIN_HAND: &str = "builtin:hand";

/// The functions serde's `default = "..."` attributes below name, one per default value.
macro_rules! default_fns {
    ($($name:ident: $t:ty = $value:expr;)*) => {$(
        fn $name() -> $t {
            $value
        }
    )*};
}

default_fns! {
    d_up: [f32; 3] = [0.0, 1.0, 0.0];
    d_fov: f32 = 30.0;
    d_near: f32 = 0.01;
    d_far: f32 = 100.0;
    d_white: [f32; 3] = [1.0, 1.0, 1.0];
    d_zero3: [f32; 3] = [0.0, 0.0, 0.0];
    d_one: f32 = 1.0;
    d_inner: f32 = 20.0;
    d_outer: f32 = 30.0;
    d_shadow_size: u32 = 2048;
    d_shadow_bias: f32 = 0.001;
    d_mm_per_unit: f32 = 1000.0;
    d_tessellate: u32 = 1;
    d_true: bool = true;
}

fn is_one(n: &u32) -> bool {
    *n == 1
}

fn is_true(b: &bool) -> bool {
    *b
}

/// The whole scene file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneDesc {
    /// The `[camera]` table.
    pub camera: CameraDesc,
    /// The `[render]` table: the frame's settings, one sub-table per effect.
    #[serde(default)]
    pub render: RenderSettings,
    /// The `[render]` keys the file set itself (key below `[render]`, value as TOML), which
    /// override its quality preset's: kept so that another preset (`--quality`) keeps them.
    #[serde(skip)]
    pub render_keys: RenderKeys,
    /// The `[[lights]]`, at most 8.
    #[serde(default)]
    pub lights: Vec<LightDesc>,
    /// The `[[objects]]`.
    #[serde(default)]
    pub objects: Vec<ObjectDesc>,
}

/// Perspective camera.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraDesc {
    /// Eye position, scene units.
    #[serde(deserialize_with = "exact")]
    pub position: [f32; 3],
    /// The point looked at, scene units; must differ from `position`.
    #[serde(deserialize_with = "exact")]
    pub target: [f32; 3],
    /// Up vector: non-zero and not parallel to the view direction.
    #[serde(deserialize_with = "exact", default = "d_up")]
    pub up: [f32; 3],
    /// Vertical field of view in degrees, 0 < fov < 180.
    #[serde(default = "d_fov")]
    pub fov_y_deg: f32,
    /// Near plane distance in scene units, > 0 and at least `far / 1e6`.
    #[serde(default = "d_near")]
    pub near: f32,
    /// Far plane distance in scene units, > `near`.
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

/// The kind of a light, `kind` in the scene file.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum LightKind {
    /// Shines in every direction from `position`.
    Point,
    /// A cone from `position` toward `target`, between the inner and outer half-angles.
    Spot,
    /// Parallel light along `target - position`, from infinitely far away.
    Directional,
}

/// A light source.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LightDesc {
    /// Point, spot or directional.
    pub kind: LightKind,
    /// Light position, scene units; a directional light uses it only with `target`.
    #[serde(deserialize_with = "exact")]
    pub position: [f32; 3],
    /// Spot and directional: direction = target - position. Unused by point lights.
    #[serde(deserialize_with = "exact", default = "d_zero3")]
    pub target: [f32; 3],
    /// Linear RGB colour, each >= 0; multiplies `intensity`.
    #[serde(deserialize_with = "exact", default = "d_white")]
    pub color: [f32; 3],
    /// Point/spot: radiant intensity (falls off as 1/d^2 in scene units);
    /// directional: irradiance.
    #[serde(default = "d_one")]
    pub intensity: f32,
    /// Spot only: half-angle in degrees of the full-intensity cone, 0 < inner <= outer < 90.
    #[serde(default = "d_inner")]
    pub inner_angle_deg: f32,
    /// Spot only: half-angle in degrees where the light reaches zero.
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
    /// Label; empty is shown as `objectN`.
    #[serde(default)]
    pub name: String,
    /// The geometry: a glTF file or a built-in shape.
    pub mesh: MeshDesc,
    /// Millimetres per scene unit of this object's mesh (before `scale`):
    /// 1000 for metres (glTF), ~48 for the Lee Perry-Smith head.
    #[serde(default = "d_mm_per_unit")]
    pub mm_per_unit: f32,
    /// Position in the scene, scene units.
    #[serde(deserialize_with = "exact", default = "d_zero3")]
    pub translation: [f32; 3],
    /// Euler angles in degrees, `glam::EulerRot::XYZ`: R = Rx * Ry * Rz.
    #[serde(deserialize_with = "exact", default = "d_zero3")]
    pub rotation_deg: [f32; 3],
    /// Uniform scale, > 0: the object is `scale * mm_per_unit` mm per scene unit.
    #[serde(default = "d_one")]
    pub scale: f32,
    /// Phong tessellation level (Boubekeur & Alexa 2008), 1..=8: each triangle becomes
    /// `tessellate²` triangles on the smooth surface its vertex normals describe, so that a
    /// low-poly mesh's silhouette, shadow maps and exported reference are as round as its
    /// shading (a faceted finger's outline glows several times too bright in the path
    /// tracer). 1 = the mesh as authored.
    #[serde(default = "d_tessellate", skip_serializing_if = "is_one")]
    pub tessellate: u32,
    /// Surface and scattering parameters.
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
/// `mesh = { shape = "sphere", radius = 0.05, segments = 64 }` (segments optional),
/// `mesh = { shape = "cylinder", radius = 0.007, length = 0.12, segments = 64 }` (segments
/// optional).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "MeshDescToml", into = "MeshDescToml")]
pub enum MeshDesc {
    /// Path relative to the scene file, or [`BUILTIN_HAND`].
    Gltf {
        /// The `.glb` or `.gltf` file, or [`BUILTIN_HAND`].
        path: String,
    },
    /// A box centred at the origin; lit from behind along z, a slab of skin.
    Slab {
        /// Extent along x, the mesh's units.
        width: f32,
        /// Extent along y, the mesh's units.
        height: f32,
        /// Extent along z, the mesh's units: the thickness backlight crosses.
        thickness: f32,
    },
    /// A triangular prism whose thickness along z grows linearly from 0 at x = -length/2 to
    /// `max_thickness` at x = +length/2: transmittance against thickness in one image.
    Wedge {
        /// Extent along x, the mesh's units.
        length: f32,
        /// Extent along y, the mesh's units.
        height: f32,
        /// Thickness along z at the thick end, the mesh's units.
        max_thickness: f32,
    },
    /// A UV sphere centred at the origin, poles on y.
    Sphere {
        /// Radius, the mesh's units.
        radius: f32,
        /// Segments around the equator, 3..=1024.
        segments: u32,
    },
    /// Closed cylinder along y: a finger's cross-section, the same at every height.
    Cylinder {
        /// Radius, the mesh's units.
        radius: f32,
        /// Extent along y, the mesh's units.
        length: f32,
        /// Segments around the axis, 3..=1024.
        segments: u32,
    },
}

impl MeshDesc {
    /// The sizes of a built-in shape (scene units, each must be > 0), by field name; none
    /// for a glTF mesh.
    pub fn sizes(&self) -> Vec<(&'static str, f32)> {
        let t = MeshDescToml::from(self.clone());
        // In the order of each shape's fields.
        [
            ("width", t.width),
            ("length", t.length),
            ("height", t.height),
            ("thickness", t.thickness),
            ("max_thickness", t.max_thickness),
            ("radius", t.radius),
        ]
        .into_iter()
        .filter_map(|(name, size)| Some((name, size?)))
        .collect()
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
enum ShapeKind {
    Slab,
    Wedge,
    Sphere,
    Cylinder,
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
                Err("needs `gltf = \"path\"` or `shape = \"slab\" | \"wedge\" | \"sphere\" | \"cylinder\"`".into())
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
            (None, Some(ShapeKind::Cylinder)) => {
                only(&["radius", "length", "segments"], "shape \"cylinder\"")?;
                Ok(MeshDesc::Cylinder {
                    radius: need(t.radius, "radius", "cylinder")?,
                    length: need(t.length, "length", "cylinder")?,
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
            MeshDesc::Cylinder {
                radius,
                length,
                segments,
            } => MeshDescToml {
                shape: Some(ShapeKind::Cylinder),
                radius: Some(radius),
                length: Some(length),
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
    #[serde(deserialize_with = "exact")]
    pub albedo: [f32; 3],
    /// sRGB colour texture, path relative to the scene file (overrides the glTF's).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub albedo_texture: Option<String>,
    /// Tangent-space normal map (linear), path relative to the scene file (overrides the
    /// glTF's).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub normal_texture: Option<String>,
    /// Specular intensity map (linear, red channel scales `specular`), path relative to the
    /// scene file.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub specular_texture: Option<String>,
    /// glTF meshes: multiply `albedo` by the glTF base colour factor and use
    /// the glTF base colour texture when `albedo_texture` is not given.
    #[serde(default = "d_true", skip_serializing_if = "is_true")]
    pub use_gltf_color: bool,
    /// Flip every texture of the material vertically (v -> 1 - v) when it is loaded: for
    /// maps authored for bottom-up sampling (OpenGL/three.js `flipY`), such as the separate
    /// colour, normal and specular maps of the Lee Perry-Smith head. The normal map needs no
    /// other change: its green channel still follows +v of the mesh's UVs.
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub texture_flip_v: bool,
    /// Beckmann roughness m, in (0, 1].
    pub roughness: f32,
    /// Specular intensity rho_s on the boundary's Cook-Torrance reflection, >= 0.
    pub specular: f32,
    /// 0 = not skin (no subsurface scattering), 1 = full.
    pub sss_strength: f32,
    /// Multiplier on the physical profile size, > 0.
    pub sss_width: f32,
    /// Thickness scale for transmittance, >= 0.
    pub translucency: f32,
    /// The scattering medium: a preset name of `subsurface profile --help` (`"skin"`, d'Eon's
    /// three-layer Gaussians, or a measured material such as `"skin1"`) or measured
    /// coefficients `{ sigma_a = [r, g, b], sigma_s = [r, g, b], eta = 1.3 }` (1/mm,
    /// `sigma_s` reduced). The profile, T(s) and, for a measured medium, the diffuse albedo
    /// are derived from it. `profile` is accepted as an older name.
    #[serde(alias = "profile")]
    pub medium: Medium,
    /// Separable kernel: per-channel share of the light that scatters, each in [0, 1].
    /// Unset: Jimenez's skin values (0.48, 0.41, 0.28) for the `skin` preset, 1 for a
    /// measured material (its fitted profile already holds the colour's spread).
    #[serde(
        default,
        deserialize_with = "exact_opt",
        skip_serializing_if = "Option::is_none"
    )]
    pub kernel_strength: Option<[f32; 3]>,
    /// Separable kernel: per-channel falloff, each in [0, 1] (smaller = narrower in that
    /// channel). Unset: (1, 0.37, 0.3) for `skin`, 1 for a measured material.
    #[serde(
        default,
        deserialize_with = "exact_opt",
        skip_serializing_if = "Option::is_none"
    )]
    pub falloff: Option<[f32; 3]>,
}

impl Default for MaterialDesc {
    fn default() -> Self {
        MaterialDesc {
            albedo: [1.0, 1.0, 1.0],
            albedo_texture: None,
            normal_texture: None,
            specular_texture: None,
            use_gltf_color: true,
            texture_flip_v: false,
            roughness: 0.3,
            specular: 0.18,
            sss_strength: 1.0,
            sss_width: 1.0,
            translucency: 1.0,
            medium: Medium::default(),
            kernel_strength: None,
            falloff: None,
        }
    }
}

impl MaterialDesc {
    /// The separable kernel's (strength, falloff): the material's own, else the default for
    /// its kind of profile (see the fields).
    pub fn kernel_params(&self, skin_preset: bool) -> ([f32; 3], [f32; 3]) {
        let (strength, falloff) = if skin_preset {
            (DEFAULT_STRENGTH, DEFAULT_FALLOFF)
        } else {
            ([1.0; 3], [1.0; 3])
        };
        (
            self.kernel_strength.unwrap_or(strength),
            self.falloff.unwrap_or(falloff),
        )
    }

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

/// A scene file's own `[render]` keys ([`SceneDesc::render_keys`]). Not part of what a scene
/// is: two descriptions with the same settings are equal whichever keys their files spelled.
#[derive(Clone, Debug, Default)]
pub struct RenderKeys(
    /// `(key, value)`: the key below `[render]` (`sss.samples`), the value as TOML.
    pub Vec<(String, String)>,
);

impl PartialEq for RenderKeys {
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

impl SceneDesc {
    /// Sets the quality preset, the file's own `[render]` keys kept over it.
    pub fn set_quality(
        &mut self,
        quality: crate::settings::Quality,
    ) -> Result<(), crate::settings::InvalidSetting> {
        // Unchecked: the ranges are left to the caller's `validate`, so that the error names
        // the key that is out of them.
        self.render.apply_quality(quality);
        for (key, value) in &self.render_keys.0 {
            self.render.set_unchecked(key, value)?;
        }
        Ok(())
    }
}
