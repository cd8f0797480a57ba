//! The lights transmittance reads, found in Bevy's render world: each shadow-casting
//! directional light through its first cascade, each shadow-casting spot light through its
//! map (both in `ViewShadowBindings::directional_light_depth_texture`), each shadow-casting
//! point light through the six faces of its cube map (`point_light_depth_texture`). All are
//! reverse-Z.

use bevy::ecs::prelude::*;
use bevy::math::{Mat4 as BevyMat4, Vec3 as BevyVec3};
use bevy::pbr::{
    ExtractedDirectionalLight, ExtractedPointLight, LightEntity, ShadowView, ViewLightEntities,
};
use bevy::platform::collections::HashMap;
use bevy::render::view::ExtractedView;
use glam::Vec3;

/// `KIND_POINT`, `KIND_SPOT` and `KIND_DIRECTIONAL` of subsurface-render's common.wgsl.
pub(crate) const KIND_POINT: f32 = 0.0;
pub(crate) const KIND_SPOT: f32 = 1.0;
pub(crate) const KIND_DIRECTIONAL: f32 = 2.0;

/// The cascade of each directional light that transmittance reads: the first, whose texels
/// are the finest (a Bevy cascade spans its slice of the view frustum with the same number
/// of texels, so later ones are coarser than most thin parts). Skin beyond its far bound
/// (`CascadeShadowConfig::bounds[0]`) gets no transmitted light.
pub const CASCADE: usize = 0;

/// Where a light's depth map lies in Bevy's shadow textures.
#[derive(Clone, Debug)]
pub(crate) enum MapSource {
    /// A directional cascade: its layer (the camera's `ViewLightEntities` lists cascades in
    /// layer order).
    Layer(u32),
    /// A spot light or a point light's face: the one-layer view Bevy draws it through
    /// (`ShadowView`). These maps are shared by every camera (a spot light's placed after all
    /// cameras' cascades), so the view, not a layer counted from this camera's lights, says
    /// where the map is.
    View(bevy::render::render_resource::TextureView),
}

/// One depth map of a light.
#[derive(Clone, Debug)]
pub(crate) struct FaceMap {
    pub source: MapSource,
    /// The map's `clip_from_world` (reverse-Z; orthographic for a cascade, perspective with
    /// an infinite far plane for a spot light or a cube face).
    pub clip_from_world: BevyMat4,
    /// Its texels a side.
    pub size: u32,
    /// The texels the skin covers (see [`region`]).
    pub region: [u32; 4],
}

/// One light as transmittance reads it, from Bevy's extracted data.
#[derive(Clone, Debug)]
pub(crate) struct LightShadow {
    /// One map, or a point light's six in subsurface-render's face order (+X, -X, +Y, -Y,
    /// +Z, -Z).
    pub faces: Vec<FaceMap>,
    /// `KIND_DIRECTIONAL`, `KIND_SPOT` or `KIND_POINT`.
    pub kind: f32,
    /// Where light distances are measured from: the cascade's near-plane centre, or the spot
    /// light itself.
    pub origin: Vec3,
    /// Unit direction, light to target.
    pub direction: Vec3,
    /// Linear colour x the light's strength x exposure / pi: illuminance for a directional
    /// light, intensity (candela) for a spot light, whose inverse square the shader applies.
    pub color: [f32; 3],
    /// Cosines of the spot cone's outer and inner angles (-1 for a directional light).
    pub cone: [f32; 2],
    /// A map texel's width, world units, at the skin.
    pub texel_size: f32,
}

/// Where the skin lies for the shadow maps: its world box, the margin around it (world
/// units), the directional maps' size, the camera's exposure.
pub(crate) struct Reach {
    pub skin_box: (BevyVec3, BevyVec3),
    pub margin: f32,
    pub size: u32,
    pub exposure: f32,
}

impl Reach {
    fn face(&self, source: MapSource, clip_from_world: BevyMat4, size: u32) -> FaceMap {
        FaceMap {
            source,
            clip_from_world,
            size,
            region: region(clip_from_world, size, self.skin_box, self.margin),
        }
    }

    /// A texel's width at the skin of a perspective map spanning `2 tan_half` per unit of
    /// depth over `size` texels, seen from `position`.
    fn texel_at_skin(&self, position: BevyVec3, tan_half: f32, size: u32) -> f32 {
        let (lo, hi) = self.skin_box;
        let depth = position.distance(0.5 * (lo + hi)).max(1e-3);
        2.0 * tan_half * depth / size as f32
    }
}

/// A light view's `clip_from_world` (Bevy leaves `ExtractedView::clip_from_world` unset on
/// its shadow views) and its map's size.
fn view_map(extracted: &ExtractedView) -> (BevyMat4, u32) {
    let world_from_view = extracted.world_from_view.to_matrix();
    (
        extracted.clip_from_view * world_from_view.inverse(),
        extracted.viewport.z,
    )
}

fn depth_view(shadow_view: &ShadowView) -> Option<MapSource> {
    match &shadow_view.depth_attachment.depth_stencil_views {
        bevy::render::texture::DepthStencilViews::DepthOnly { depth_view } => {
            Some(MapSource::View(depth_view.clone()))
        }
        _ => None,
    }
}

fn to_glam(v: BevyVec3) -> Vec3 {
    Vec3::from_array(v.to_array())
}

fn forward(transform: &bevy::transform::components::GlobalTransform) -> BevyVec3 {
    transform
        .to_matrix()
        .transform_vector3(BevyVec3::NEG_Z)
        .normalize()
}

/// The camera's shadow-casting directional lights: for each, the layer of Bevy's
/// directional shadow texture that holds its cascade [`CASCADE`], and that cascade's
/// matrices from the extracted light.
pub(crate) fn directional(
    view: Entity,
    views: &ViewLightEntities,
    light_views: &Query<&LightEntity>,
    directional: &Query<&ExtractedDirectionalLight>,
    reach: &Reach,
) -> Vec<LightShadow> {
    let mut lights = Vec::new();
    for (layer, e) in views.lights.iter().enumerate() {
        let Ok(LightEntity::Directional {
            light_entity,
            cascade_index,
        }) = light_views.get(*e)
        else {
            continue;
        };
        if *cascade_index != CASCADE {
            continue;
        }
        let Ok(light) = directional.get(*light_entity) else {
            continue;
        };
        let Some(cascade) = light.cascades.get(&view).and_then(|c| c.get(CASCADE)) else {
            continue;
        };
        if !light.shadow_maps_enabled {
            continue;
        }
        let c = light.color;
        let scale = light.illuminance * reach.exposure / std::f32::consts::PI;
        lights.push(LightShadow {
            faces: vec![reach.face(
                MapSource::Layer(layer as u32),
                cascade.clip_from_world,
                reach.size,
            )],
            kind: KIND_DIRECTIONAL,
            origin: to_glam(cascade.world_from_cascade.w_axis.truncate()),
            direction: to_glam(forward(&light.transform)),
            color: [c.red * scale, c.green * scale, c.blue * scale],
            cone: [-1.0, -1.0 + 1e-4],
            texel_size: cascade.texel_size,
        });
    }
    lights
}

/// The shadow-casting spot and point lights whose maps Bevy drew this frame (their
/// `LightEntity::Spot` and `LightEntity::Point` views), with the matrices Bevy drew them
/// with: spot lights first, then point lights, each in entity order.
pub(crate) fn spot_and_point(
    light_views: &Query<(&LightEntity, &ShadowView, &ExtractedView)>,
    point_lights: &Query<&ExtractedPointLight>,
    reach: &Reach,
) -> Vec<LightShadow> {
    let mut spots = Vec::new();
    // Bevy's cube faces are +X, -X, +Y, -Y, -Z, +Z (bevy_camera's CUBE_MAP_FACES);
    // subsurface-render's shadow lookups pick +Z as face 4 and -Z as face 5.
    const OUR_FACE: [usize; 6] = [0, 1, 2, 3, 5, 4];
    let mut cubes: HashMap<Entity, [Option<FaceMap>; 6]> = HashMap::default();
    for (light_view, shadow_view, extracted) in light_views {
        let Some(source) = depth_view(shadow_view) else {
            continue;
        };
        let (clip_from_world, size) = view_map(extracted);
        match light_view {
            LightEntity::Spot { light_entity } => {
                spots.push((*light_entity, reach.face(source, clip_from_world, size)))
            }
            LightEntity::Point {
                light_entity,
                face_index,
            } if *face_index < 6 => {
                cubes.entry(*light_entity).or_default()[OUR_FACE[*face_index]] =
                    Some(reach.face(source, clip_from_world, size));
            }
            _ => {}
        }
    }
    spots.sort_by_key(|(e, _)| *e);
    let mut cubes: Vec<_> = cubes.into_iter().collect();
    cubes.sort_by_key(|(e, _)| *e);
    let mut lights = Vec::new();
    for (entity, face) in spots {
        let Ok(light) = point_lights.get(entity) else {
            continue;
        };
        let Some((inner, outer)) = light.spot_light_angles else {
            continue;
        };
        if !light.shadow_maps_enabled {
            continue;
        }
        let position = light.transform.translation();
        let texel_size = reach.texel_at_skin(position, outer.tan(), face.size);
        lights.push(LightShadow {
            faces: vec![face],
            kind: KIND_SPOT,
            origin: to_glam(position),
            direction: to_glam(forward(&light.transform)),
            color: candela(light, reach.exposure),
            cone: [outer.cos(), inner.cos().max(outer.cos() + 1e-4)],
            texel_size,
        });
    }
    for (entity, faces) in cubes {
        let Ok(light) = point_lights.get(entity) else {
            continue;
        };
        let Some(faces): Option<Vec<FaceMap>> = faces.into_iter().collect() else {
            continue;
        };
        if !light.shadow_maps_enabled || light.spot_light_angles.is_some() {
            continue;
        }
        let position = light.transform.translation();
        // A cube face spans 90 degrees: tan 45 = 1.
        let texel_size = reach.texel_at_skin(position, 1.0, faces[0].size);
        lights.push(LightShadow {
            faces,
            kind: KIND_POINT,
            origin: to_glam(position),
            direction: glam::Vec3::NEG_Z,
            color: candela(light, reach.exposure),
            cone: [-1.0, -1.0 + 1e-4],
            texel_size,
        });
    }
    lights
}

/// A spot or point light's colour in the units of [`LightShadow::color`]: `intensity` is
/// Bevy's candela (lumens / 4 pi); the shader divides by the squared distance and, for a spot
/// light, shapes the cone with a smoothstep between the cosines (Bevy squares a linear ramp
/// there, and fades the light near its `range`, which the transmitted light does not).
fn candela(light: &ExtractedPointLight, exposure: f32) -> [f32; 3] {
    let c = light.color;
    let scale = light.intensity * exposure / std::f32::consts::PI;
    [c.red * scale, c.green * scale, c.blue * scale]
}

/// The texels `[x, y, width, height]` of a `size`² map (`clip_from_world`) that the box
/// `bounds` covers, grown by `margin` world units; empty when it lies outside. A box that
/// reaches behind a perspective map's eye covers the whole map.
pub(crate) fn region(
    clip_from_world: BevyMat4,
    size: u32,
    (lo, hi): (BevyVec3, BevyVec3),
    margin: f32,
) -> [u32; 4] {
    let (lo, hi) = (lo - BevyVec3::splat(margin), hi + BevyVec3::splat(margin));
    let (mut min, mut max) = (bevy::math::Vec2::splat(f32::MAX), bevy::math::Vec2::MIN);
    for i in 0..8 {
        let pick = |bit: usize, a: f32, b: f32| if i & bit == 0 { a } else { b };
        let corner = BevyVec3::new(
            pick(1, lo.x, hi.x),
            pick(2, lo.y, hi.y),
            pick(4, lo.z, hi.z),
        );
        let clip = clip_from_world * corner.extend(1.0);
        if clip.w <= 0.0 {
            return [0, 0, size, size];
        }
        let ndc = clip.truncate() / clip.w;
        let uv = bevy::math::Vec2::new(0.5 * ndc.x + 0.5, 0.5 - 0.5 * ndc.y);
        min = min.min(uv);
        max = max.max(uv);
    }
    // Whole texels, and one more each side for the entry pass's neighbours.
    let s = size as f32;
    let x0 = (min.x * s - 1.0).floor().clamp(0.0, s) as u32;
    let y0 = (min.y * s - 1.0).floor().clamp(0.0, s) as u32;
    let x1 = (max.x * s + 1.0).ceil().clamp(0.0, s) as u32;
    let y1 = (max.y * s + 1.0).ceil().clamp(0.0, s) as u32;
    [x0, y0, x1.saturating_sub(x0), y1.saturating_sub(y0)]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The texels a box covers: a cascade 4 units wide on 16 texels sees a 1-unit box at its
    /// centre on texels 6..10, 5..11 with the neighbour each side; grown by a margin of 1
    /// (3 units: texels 2..14), 1..15; a box beside the cascade covers none.
    #[test]
    fn region_covers_the_box_and_its_margin() {
        let clip_from_world = BevyMat4::from_cols(
            bevy::math::Vec4::new(0.5, 0.0, 0.0, 0.0),
            bevy::math::Vec4::new(0.0, 0.5, 0.0, 0.0),
            bevy::math::Vec4::new(0.0, 0.0, 0.25, 0.0),
            bevy::math::Vec4::new(0.0, 0.0, 1.0, 1.0),
        );
        let unit = (BevyVec3::splat(-0.5), BevyVec3::new(0.5, 0.5, -1.0));
        assert_eq!(region(clip_from_world, 16, unit, 0.0), [5, 5, 6, 6]);
        assert_eq!(region(clip_from_world, 16, unit, 1.0), [1, 1, 14, 14]);
        let beside = (BevyVec3::new(5.0, 0.0, -1.0), BevyVec3::new(6.0, 1.0, -0.5));
        let [_, _, w, _] = region(clip_from_world, 16, beside, 0.0);
        assert_eq!(w, 0);
    }

    /// A spot light's perspective map: a box straddling the light's eye plane covers the
    /// whole map rather than a region of corners projected through w <= 0.
    #[test]
    fn a_box_around_a_spot_light_covers_its_whole_map() {
        let clip = bevy::light::spot_light_clip_from_view(0.5, 0.1);
        let around = (BevyVec3::splat(-1.0), BevyVec3::splat(1.0));
        assert_eq!(region(clip, 64, around, 0.0), [0, 0, 64, 64]);
        let ahead = (
            BevyVec3::new(-0.1, -0.1, -5.1),
            BevyVec3::new(0.1, 0.1, -4.9),
        );
        let r = region(clip, 64, ahead, 0.0);
        assert!(r[2] > 0 && r[2] < 16 && r[0] > 16, "{r:?}");
    }
}
