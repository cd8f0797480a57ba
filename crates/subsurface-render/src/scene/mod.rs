//! Scene description (TOML, see `docs/guide.md`) and scene loading.
//!
//! [`SceneDesc`] is the raw, serialisable description (`desc`, checked by `validate`);
//! [`Scene`] is the loaded scene with meshes and textures decoded, ready for upload.

mod desc;
pub mod error;
mod reframe;
pub mod units;
mod validate;

use std::path::{Path, PathBuf};

use glam::Vec3;

pub use desc::*;
pub use error::SceneError;
pub(crate) use error::one_line;

use crate::mesh::{self, Mesh};

/// Source of the embedded default scene.
pub const DEFAULT_SCENE_TOML: &str = include_str!("../default_scene.toml");

/// A scene with meshes and textures decoded.
#[derive(Clone)]
pub struct Scene {
    /// The scene as the file describes it.
    pub desc: SceneDesc,
    /// One per `desc.objects`, same order.
    pub objects: Vec<Object>,
}

/// A loaded object.
#[derive(Clone)]
pub struct Object {
    /// The object's label (`objectN` where the file gives none).
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
    /// The object's material as the scene file gives it.
    pub material: MaterialDesc,
}

impl Object {
    /// World-space AABB of the object.
    pub fn world_bounds(&self) -> (Vec3, Vec3) {
        let (lo, hi) = self.mesh.bounds();
        let mut out = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for c in box_corners(lo, hi) {
            let p = self.transform.transform_point3(c);
            out = (out.0.min(p), out.1.max(p));
        }
        out
    }
}

/// The eight corners of the axis-aligned box `(lo, hi)`.
pub(crate) fn box_corners(lo: Vec3, hi: Vec3) -> [Vec3; 8] {
    std::array::from_fn(|k| {
        Vec3::new(
            if k & 1 == 0 { lo.x } else { hi.x },
            if k & 2 == 0 { lo.y } else { hi.y },
            if k & 4 == 0 { lo.z } else { hi.z },
        )
    })
}

/// Reads and decodes an image file as RGBA8.
pub fn load_image(path: &Path) -> Result<image::RgbaImage, SceneError> {
    let file = path.display().to_string();
    // Only a regular file, read with a bound: a FIFO as a texture blocked forever.
    let bytes = crate::input::read_regular(path, crate::input::MAX_IMAGE_BYTES).map_err(|e| {
        SceneError::Io {
            file: file.clone(),
            msg: one_line(&e),
        }
    })?;
    let reader = image::ImageReader::new(std::io::Cursor::new(&bytes))
        .with_guessed_format()
        .map_err(|e| SceneError::Io {
            file: file.clone(),
            msg: one_line(&e.to_string()),
        })?;
    if reader.format() == Some(image::ImageFormat::Jpeg) && !jpeg_is_complete(&bytes) {
        return Err(SceneError::Image {
            file,
            msg: "the JPEG is truncated (no end-of-image marker after its last scan)".into(),
        });
    }
    let img = reader.decode().map_err(|e| SceneError::Image {
        file,
        msg: one_line(&e.to_string()),
    })?;
    Ok(img.to_rgba8())
}

/// Where a scene's file path points: relative to the scene's folder, except that a path through
/// a `shared/assets/` folder (the head, which is not in the repository) is looked up in
/// `SUBSURFACE_ASSETS` when that is set, so that one variable moves every scene's assets.
pub fn asset_path(base_dir: &Path, path: &str) -> std::path::PathBuf {
    const SHARED: &str = "shared/assets/";
    if let (Some(at), Some(assets)) = (path.find(SHARED), std::env::var_os("SUBSURFACE_ASSETS"))
        && !Path::new(path).is_absolute()
        && !assets.is_empty()
    {
        return Path::new(&assets).join(&path[at + SHARED.len()..]);
    }
    base_dir.join(path)
}

/// Whether a JPEG's last scan (start-of-scan marker FF DA) is followed by the end-of-image
/// marker FF D9: the decoder fills a truncated file's missing rows with grey without a word.
/// (Inside a scan FF is always followed by 00 or a restart marker, so FF D9 ends it.)
fn jpeg_is_complete(bytes: &[u8]) -> bool {
    let last_scan = bytes.windows(2).rposition(|w| w == [0xFF, 0xDA]);
    last_scan.is_some_and(|s| bytes[s..].windows(2).any(|w| w == [0xFF, 0xD9]))
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
                mesh::load_gltf(&asset_path(base_dir, path))
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
        MeshDesc::Cylinder {
            radius,
            length,
            segments,
        } => Mesh::cylinder(*radius, *length, *segments),
    };
    let mesh = if o.tessellate > 1 {
        let triangles = mesh.triangle_count() * (o.tessellate * o.tessellate) as usize;
        if triangles * 3 > mesh::MAX_GLTF_INDICES {
            return Err(SceneError::Invalid {
                file: file.to_string(),
                field: format!("objects[{index}].tessellate"),
                msg: format!(
                    "{} triangles tessellated {}x{} make {triangles}, more than {}",
                    mesh.triangle_count(),
                    o.tessellate,
                    o.tessellate,
                    mesh::MAX_GLTF_INDICES / 3
                ),
            });
        }
        mesh.phong_tessellate(o.tessellate)
    } else {
        mesh
    };
    let tex = |field: &str, p: &Option<String>| -> Result<Option<image::RgbaImage>, SceneError> {
        p.as_ref()
            .map(|p| load_image(&asset_path(base_dir, p)).map_err(|e| ctx(field, e)))
            .transpose()
    };
    if let Some(t) = tex("material.albedo_texture", &m.albedo_texture)? {
        albedo_texture = Some(t);
    }
    if let Some(t) = tex("material.normal_texture", &m.normal_texture)? {
        normal_texture = Some(t);
    }
    let mut specular_texture = tex("material.specular_texture", &m.specular_texture)?;
    if m.texture_flip_v {
        for t in [
            &mut albedo_texture,
            &mut normal_texture,
            &mut specular_texture,
        ]
        .into_iter()
        .flatten()
        {
            image::imageops::flip_vertical_in_place(t);
        }
    }
    let object = Object {
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
    };
    check_world_extent(&object, o, index, file)?;
    Ok(object)
}

/// The object in world space must fit in f32, extent included: a mesh extent times `scale`
/// (or plus `translation`) past f32::MAX rendered nothing and exported infinite vertices, with
/// exit 0, and so did a mesh from -3e38 to 3e38, whose corners are finite but whose extent is
/// not.
fn check_world_extent(
    object: &Object,
    o: &ObjectDesc,
    index: usize,
    file: &str,
) -> Result<(), SceneError> {
    let fits = |(lo, hi): (Vec3, Vec3)| lo.is_finite() && hi.is_finite() && (hi - lo).is_finite();
    if fits(object.world_bounds()) {
        return Ok(());
    }
    let (mlo, mhi) = object.mesh.bounds();
    let extent = (mhi - mlo).max_element() * o.scale;
    let (field, msg) = if !fits((mlo, mhi)) {
        (
            match &o.mesh {
                MeshDesc::Gltf { .. } => "mesh.gltf".to_string(),
                m => format!("mesh.{}", m.sizes().first().map_or("size", |s| s.0)),
            },
            format!(
                "the mesh's extent ({} to {}) overflows 32-bit floats",
                sci(mlo),
                sci(mhi)
            ),
        )
    } else if extent.is_finite() {
        (
            "translation".to_string(),
            "the object's world-space bounds overflow 32-bit floats".to_string(),
        )
    } else {
        (
            "scale".to_string(),
            "the mesh's extent times the scale overflows 32-bit floats".to_string(),
        )
    };
    Err(SceneError::Invalid {
        file: file.to_string(),
        field: format!("objects[{index}].{field}"),
        msg,
    })
}

/// A point with its coordinates in exponent form: `[-3e38, 0e0, 1.5e-2]`.
pub(crate) fn sci(v: Vec3) -> String {
    format!("[{:e}, {:e}, {:e}]", v.x, v.y, v.z)
}

fn union(a: (Vec3, Vec3), b: (Vec3, Vec3)) -> (Vec3, Vec3) {
    (a.0.min(b.0), a.1.max(b.1))
}

impl Scene {
    /// Reads, validates and loads a scene file; relative paths in it are
    /// resolved against the file's directory.
    pub fn load_file(path: &Path) -> Result<Scene, SceneError> {
        let name = path.display().to_string();
        let text =
            crate::input::read_regular_text(path, crate::input::MAX_TEXT_BYTES).map_err(|e| {
                SceneError::Io {
                    file: name.clone(),
                    msg: one_line(&e),
                }
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

    /// Changes the material of every object, in the description and in the loaded objects
    /// alike (the command line's per-material flags, the viewer's edits).
    pub fn edit_materials(&mut self, mut edit: impl FnMut(&mut MaterialDesc)) {
        for d in &mut self.desc.objects {
            edit(&mut d.material);
        }
        for o in &mut self.objects {
            edit(&mut o.material);
        }
    }

    /// World-space AABB of all objects; `(0, 0)` if there are none.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.objects
            .iter()
            .map(Object::world_bounds)
            .reduce(union)
            .unwrap_or((Vec3::ZERO, Vec3::ZERO))
    }
}

#[cfg(test)]
mod tests;
