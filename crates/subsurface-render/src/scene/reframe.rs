//! `--model`: one glTF in place of a scene's objects, with the camera and lights refitted.

use std::path::Path;

use glam::Vec3;

use super::{LightKind, MaterialDesc, MeshDesc, Object, ObjectDesc, Scene, SceneError};
use crate::mesh;

impl Scene {
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
            tessellate: 1,
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
pub(crate) fn bounding_sphere((lo, hi): (Vec3, Vec3)) -> (Vec3, f32) {
    ((lo + hi) * 0.5, (hi - lo).length() * 0.5)
}
