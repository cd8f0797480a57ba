//! The scene's lights on the GPU: each light's uniform and where its shadow maps lie in the
//! shadow atlas.

use glam::{Mat4, Vec3};

use crate::error::RenderError;
use crate::scene::{LightDesc, LightKind, Scene};
use crate::settings::RenderSettings;
use crate::uniforms::{LightUniform, LightsUniform, MAX_LIGHTS, mat};

/// Where each light's shadow maps live in the shadow atlas (a 2-D array texture).
#[derive(Clone, Debug)]
pub struct ShadowLayer {
    /// Index of the light in the scene's `lights`.
    pub light: usize,
    /// The layer's side in texels (the light's `shadow_map_size`); the atlas may be larger.
    pub size: u32,
    /// World -> clip of the shadow camera.
    pub view_proj: Mat4,
    /// Origin that `light_distance` measures from (the light, or the directional light's
    /// shadow-camera origin).
    pub origin: Vec3,
}

/// The frame's lights as the shaders read them, and their shadow-map layers.
pub struct LightSetup {
    /// Every light, with the frame's ambient light and transmittance settings.
    pub uniform: LightsUniform,
    /// One per shadow camera: six per shadowed point light, one per shadowed spot or directional
    /// light.
    pub layers: Vec<ShadowLayer>,
    /// Side of the shadow atlas in texels: the largest `shadow_map_size`, at least 1.
    pub atlas_size: u32,
}

fn safe_up(dir: Vec3) -> Vec3 {
    if dir.y.abs() > 0.99 { Vec3::Z } else { Vec3::Y }
}

/// Light-space matrices and uniforms, with the ambient light and transmittance of `settings`.
/// Shadow near/far planes are fitted to the scene's bounding sphere so that depth precision is
/// spent where the geometry is. What the frame is made of (the transmitted map, the bounce) is the
/// frame plan's to decide and to write ([`crate::frame_plan::FramePlan::write_lights`]).
pub fn light_setup(scene: &Scene, settings: &RenderSettings) -> Result<LightSetup, RenderError> {
    let transmittance = &settings.transmittance;
    if scene.desc.lights.len() > MAX_LIGHTS {
        return Err(RenderError::invalid(
            "lights",
            format!(
                "at most {MAX_LIGHTS} lights are supported (got {})",
                scene.desc.lights.len()
            ),
        ));
    }
    let (lo, hi) = scene.bounds();
    let centre = (lo + hi) * 0.5;
    let radius = ((hi - lo).length() * 0.5).max(1e-3);
    let atlas_size = scene
        .desc
        .lights
        .iter()
        .map(|l| l.shadow_map_size)
        .max()
        .unwrap_or(0)
        .max(1);
    let mut uniform = LightsUniform::zeroed_default();
    uniform.count = scene.desc.lights.len() as u32;
    uniform.ambient = settings.ambient;
    uniform.transmittance = transmittance.method.code();
    uniform.normal_shrink = transmittance.normal_shrink;
    uniform.thickness_filter = transmittance.thickness_filter;
    uniform.lateral_taps = transmittance.lateral_taps;
    uniform.sss_runs = u32::from(settings.sss.method != crate::settings::SssMethod::None);
    uniform.bounce_cell_mm = settings.bounce.cell_mm;
    let mut layers = Vec::new();
    for (i, l) in scene.desc.lights.iter().enumerate() {
        let (u, light_layers) = light_uniform(i, l, centre, radius, atlas_size, layers.len());
        uniform.lights[i] = u;
        layers.extend(light_layers);
    }
    Ok(LightSetup {
        uniform,
        layers,
        atlas_size,
    })
}

/// A point light's cube faces see 92 degrees, slightly wider than 90, so that the PCF taps at
/// a face's edge stay inside it.
const POINT_FACE_FOV_DEG: f32 = 92.0;

/// The field of view (radians) of a spot light's shadow map: its cone and 5 % more, at most
/// 179 degrees.
fn spot_fov(outer_angle_deg: f32) -> f32 {
    (2.0 * outer_angle_deg.to_radians() * 1.05).min(179f32.to_radians())
}

/// Shadow-map texels coarser than this on the skin (profile millimetres) resolve no part
/// thinner: fingers are about 15 mm through, ears 2 to 5 mm.
pub const COARSE_SHADOW_TEXEL_MM: f32 = 2.0;

/// One line per shadowed light whose map's texels, where the scene lies, are coarser than
/// [`COARSE_SHADOW_TEXEL_MM`] on its finest translucent object: a wide spot cone on a small
/// map spreads few texels over the scene, and transmittance then reads the thickness of
/// whole parts from one or two texels (an 85° cone on a 512 map gave a 3 mm slab twice its
/// transmitted light, an 88° cone a third of it). Empty when every map is fine enough.
/// `subsurface render` prints them after a successful image, so a failing run still says one
/// thing, its error.
pub fn coarse_shadow_maps(scene: &Scene) -> Vec<String> {
    let skin_mm = scene
        .objects
        .iter()
        .filter(|o| o.material.translucency > 0.0 && !o.mesh.indices.is_empty())
        .map(|o| {
            crate::scene::units::world_per_mm(o.transform, o.mm_per_unit, o.material.sss_width)
        })
        .filter(|w| w.is_finite() && *w > 0.0)
        .fold(f32::INFINITY, f32::min);
    if !skin_mm.is_finite() {
        return Vec::new();
    }
    let (lo, hi) = scene.bounds();
    let (centre, radius) = ((lo + hi) * 0.5, ((hi - lo).length() * 0.5).max(1e-3));
    let mut lines = Vec::new();
    for (i, l) in scene.desc.lights.iter().enumerate() {
        if l.shadow_map_size == 0 {
            continue;
        }
        let distance = (Vec3::from(l.position) - centre).length();
        // The map's width where the scene lies, as light_uniform frames it.
        let width = match l.kind {
            LightKind::Spot => 2.0 * distance * (0.5 * spot_fov(l.outer_angle_deg)).tan(),
            LightKind::Point => 2.0 * distance * (0.5 * POINT_FACE_FOV_DEG.to_radians()).tan(),
            LightKind::Directional => 2.0 * radius,
        };
        let texel_mm = width / l.shadow_map_size as f32 / skin_mm;
        if texel_mm > COARSE_SHADOW_TEXEL_MM {
            lines.push(format!(
                "lights[{i}]: its shadow map's texels are {texel_mm:.1} mm on the skin \
                 ({} texels across the scene's distance): transmittance cannot resolve parts \
                 thinner than that; raise shadow_map_size or narrow outer_angle_deg",
                l.shadow_map_size
            ));
        }
    }
    lines
}

impl LightsUniform {
    fn zeroed_default() -> Self {
        bytemuck::Zeroable::zeroed()
    }
}

fn light_uniform(
    index: usize,
    l: &LightDesc,
    centre: Vec3,
    radius: f32,
    atlas_size: u32,
    first_layer: usize,
) -> (LightUniform, Vec<ShadowLayer>) {
    let pos = Vec3::from(l.position);
    let dir = (Vec3::from(l.target) - pos).normalize_or(Vec3::NEG_Z);
    let colour = Vec3::from(l.color) * l.intensity;
    let kind = match l.kind {
        LightKind::Point => 0.0,
        LightKind::Spot => 1.0,
        LightKind::Directional => 2.0,
    };
    let far = ((pos - centre).length() + radius) * 1.05;
    let near = (far * 1e-3)
        .max(((pos - centre).length() - radius) * 0.5)
        .max(far * 1e-4);
    let mut views: Vec<(Mat4, Vec3)> = Vec::new();
    let mut origin = pos;
    if l.shadow_map_size > 0 {
        match l.kind {
            LightKind::Spot => {
                let fov = spot_fov(l.outer_angle_deg);
                let v = Mat4::look_at_rh(pos, pos + dir, safe_up(dir));
                views.push((Mat4::perspective_rh(fov, 1.0, near, far) * v, pos));
            }
            LightKind::Point => {
                let faces = [
                    (Vec3::X, Vec3::NEG_Y),
                    (Vec3::NEG_X, Vec3::NEG_Y),
                    (Vec3::Y, Vec3::Z),
                    (Vec3::NEG_Y, Vec3::NEG_Z),
                    (Vec3::Z, Vec3::NEG_Y),
                    (Vec3::NEG_Z, Vec3::NEG_Y),
                ];
                // Slightly wider than 90 degrees so PCF taps at face edges stay inside.
                let proj = Mat4::perspective_rh(POINT_FACE_FOV_DEG.to_radians(), 1.0, near, far);
                for (d, up) in faces {
                    views.push((proj * Mat4::look_at_rh(pos, pos + d, up), pos));
                }
            }
            LightKind::Directional => {
                origin = centre - dir * (2.0 * radius);
                let v = Mat4::look_at_rh(origin, centre, safe_up(dir));
                let p = Mat4::orthographic_rh(
                    -radius,
                    radius,
                    -radius,
                    radius,
                    0.5 * radius,
                    3.5 * radius,
                );
                views.push((p * v, origin));
            }
        }
    }
    let mut vp = [[[0.0; 4]; 4]; 6];
    for (k, (m, _)) in views.iter().enumerate() {
        vp[k] = mat(*m);
    }
    let first = if views.is_empty() {
        -1.0
    } else {
        first_layer as f32
    };
    let cos_outer = l.outer_angle_deg.to_radians().cos();
    let cos_inner = l.inner_angle_deg.to_radians().cos().max(cos_outer + 1e-4);
    let u = LightUniform {
        position: origin.to_array(),
        kind,
        direction: dir.to_array(),
        first_layer: first,
        color: colour.to_array(),
        shadow_bias: l.shadow_bias,
        cos_outer,
        cos_inner,
        shadow_uv_scale: l.shadow_map_size.max(1) as f32 / atlas_size as f32,
        atlas_texel: 1.0 / atlas_size as f32,
        view_proj: vp,
    };
    let layers = views
        .into_iter()
        .map(|(view_proj, origin)| ShadowLayer {
            light: index,
            size: l.shadow_map_size,
            view_proj,
            origin,
        })
        .collect();
    (u, layers)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn slab_under_spot(outer_deg: f32, size: u32) -> Scene {
        let toml = format!(
            "[camera]\nposition = [0.0, 0.0, 0.3]\ntarget = [0.0, 0.0, 0.0]\n\
             [[lights]]\nkind = \"spot\"\nposition = [0.0, 0.0, -0.2]\ntarget = [0.0, 0.0, 0.0]\n\
             outer_angle_deg = {outer_deg:?}\ninner_angle_deg = 10.0\nshadow_map_size = {size}\n\
             [[objects]]\nmesh = {{ shape = \"slab\", width = 0.1, height = 0.1, thickness = 0.003 }}\n\
             mm_per_unit = 1000.0\n"
        );
        let desc = crate::scene::SceneDesc::from_toml_str(&toml, "t.toml").unwrap();
        Scene::from_desc(desc, std::path::Path::new("."), "t.toml").unwrap()
    }

    /// A wide cone on a small map is named (its texels are 59.7 mm across a 3 mm slab), and on
    /// the largest map still (3.7 mm); narrower cones on the small map and the default scene
    /// are not.
    #[test]
    fn coarse_shadow_maps_are_named() {
        let coarse = coarse_shadow_maps(&slab_under_spot(85.0, 512));
        assert_eq!(coarse.len(), 1, "{coarse:?}");
        assert!(coarse[0].starts_with("lights[0]: its shadow map's texels are 59.7 mm"));
        let largest = coarse_shadow_maps(&slab_under_spot(85.0, 8192));
        assert!(largest[0].contains("3.7 mm"), "{largest:?}");
        assert!(coarse_shadow_maps(&slab_under_spot(60.0, 512)).is_empty());
        assert!(coarse_shadow_maps(&slab_under_spot(30.0, 512)).is_empty());
        assert!(coarse_shadow_maps(&Scene::default_scene()).is_empty());
    }
}
