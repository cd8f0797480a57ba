//! The skin material: Bevy's `StandardMaterial` extended with a scattering medium and width.
//!
//! Every distinct (medium, width) pair among the skin materials is one row of the profile
//! table that the blur reads ([`SkinMedia`]); a material's pixels carry their row.
//!
//! Bevy's forward pass writes one colour per pixel, so diffuse and specular light are drawn
//! apart: the skin mesh itself draws its diffuse light (opaque, blurred by the render step),
//! and a child entity the plugin adds ([`SkinSpecular`]) draws the same mesh again with a twin
//! of the material in `AlphaMode::Add`, which Bevy draws in its transparent pass, after the
//! blur: the specular light is added on top, sharp.

use bevy::asset::{Asset, AssetEvent, AssetId, Assets, Handle};
use bevy::ecs::message::MessageReader;
use bevy::ecs::prelude::*;
use bevy::light::NotShadowCaster;
use bevy::material::AlphaMode;
use bevy::mesh::Mesh3d;
use bevy::pbr::MeshMaterial3d;
use bevy::pbr::{ExtendedMaterial, MaterialExtension, StandardMaterial};
use bevy::platform::collections::HashMap;
use bevy::platform::collections::HashSet;
use bevy::reflect::Reflect;
use bevy::render::RenderApp;
use bevy::render::extract_resource::ExtractResource;
use bevy::render::render_asset::RenderAssets;
use bevy::render::render_resource::{AsBindGroup, AsBindGroupShaderType, ShaderType};
use bevy::render::texture::GpuImage;
use bevy::shader::ShaderRef;
use bevy::transform::components::Transform;

use crate::SubsurfaceError;

/// Most rows of the profile table: the marker pass's uniform holds this many scales
/// (mark.wgsl's `array<vec4<f32>, 64>`).
pub const MAX_ROWS: usize = 256;

/// A skin: Bevy's PBR material whose diffuse light scatters under the surface.
pub type SkinMaterial = ExtendedMaterial<StandardMaterial, Skin>;

/// The scattering part of a [`SkinMaterial`].
#[derive(Asset, AsBindGroup, Reflect, Clone, Debug)]
#[uniform(100, SkinUniform)]
pub struct Skin {
    /// The medium: a preset of subsurface-profile by name (`"skin"`, d'Eon's skin profile,
    /// or a medium Jensen et al. 2001 measured, such as `"skin1"`, `"marble"`), or measured
    /// coefficients ([`SkinMedium::Measured`]).
    pub medium: SkinMedium,
    /// Multiplier on the physical size of the scattering profile, > 0.
    pub width: f32,
    /// This material's row of [`SkinMedia`], set by the plugin (`None` until then, or when
    /// the medium or width is invalid: the material is then drawn as plain PBR).
    #[reflect(ignore)]
    pub(crate) row: Option<u32>,
    /// True for the specular twin the plugin draws over the skin (see [`SkinSpecular`]).
    #[reflect(ignore)]
    pub(crate) specular: bool,
}

/// What a skin scatters light as: the media scene files take under `medium`.
#[derive(Reflect, Clone, Debug, PartialEq)]
pub enum SkinMedium {
    /// A preset of subsurface-profile by name (`subsurface_profile::material_names`).
    Preset(String),
    /// Measured coefficients per millimetre, red/green/blue: absorption `sigma_a`, reduced
    /// scattering `sigma_s` (sigma_s (1 - g)), each in subsurface-profile's range, and the
    /// boundary's relative index of refraction `eta` (1.3 for skin).
    Measured {
        sigma_a: [f64; 3],
        sigma_s: [f64; 3],
        eta: f64,
    },
}

impl SkinMedium {
    /// subsurface-profile's description of this medium.
    pub fn profile_medium(&self) -> subsurface_profile::Medium {
        match self {
            SkinMedium::Preset(name) => subsurface_profile::Medium::Preset(name.clone()),
            SkinMedium::Measured {
                sigma_a,
                sigma_s,
                eta,
            } => subsurface_profile::Medium::Coefficients(subsurface_profile::Coefficients {
                sigma_a: *sigma_a,
                sigma_s: *sigma_s,
                eta: *eta,
            }),
        }
    }
}

impl From<subsurface_profile::Medium> for SkinMedium {
    fn from(medium: subsurface_profile::Medium) -> Self {
        match medium {
            subsurface_profile::Medium::Preset(name) => SkinMedium::Preset(name),
            subsurface_profile::Medium::Coefficients(c) => SkinMedium::Measured {
                sigma_a: c.sigma_a,
                sigma_s: c.sigma_s,
                eta: c.eta,
            },
        }
    }
}

impl From<&str> for SkinMedium {
    fn from(name: &str) -> Self {
        SkinMedium::Preset(name.to_string())
    }
}

impl From<String> for SkinMedium {
    fn from(name: String) -> Self {
        SkinMedium::Preset(name)
    }
}

impl std::fmt::Display for SkinMedium {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SkinMedium::Preset(name) => write!(f, "{name:?}"),
            SkinMedium::Measured {
                sigma_a,
                sigma_s,
                eta,
            } => write!(
                f,
                "measured (sigma_a {sigma_a:?}, sigma_s {sigma_s:?} per mm, eta {eta})"
            ),
        }
    }
}

impl Skin {
    /// A skin of `medium` (a preset's name, or [`SkinMedium::Measured`]) whose profile is
    /// `width` times its physical size.
    pub fn new(medium: impl Into<SkinMedium>, width: f32) -> Self {
        Self {
            medium: medium.into(),
            width,
            row: None,
            specular: false,
        }
    }
}

impl Default for Skin {
    fn default() -> Self {
        Self::new("skin", 1.0)
    }
}

/// `SkinUniform` of skin.wesl.
#[derive(Clone, Default, ShaderType)]
pub struct SkinUniform {
    pub marker: f32,
    pub specular: u32,
}

impl AsBindGroupShaderType<SkinUniform> for Skin {
    fn as_bind_group_shader_type(&self, _images: &RenderAssets<GpuImage>) -> SkinUniform {
        SkinUniform {
            // 1 is what an opaque material writes anyway: "not skin".
            marker: self.row.map_or(1.0, |row| -(row as f32 + 1.0)),
            specular: self.specular as u32,
        }
    }
}

impl MaterialExtension for Skin {
    fn fragment_shader() -> ShaderRef {
        "embedded://subsurface_bevy/skin.wesl".into()
    }
}

/// One row of the profile table.
#[derive(Clone, Debug, PartialEq)]
pub struct SkinRow {
    pub medium: SkinMedium,
    pub width: f32,
    /// Linear diffuse albedo (`base_color` x (1 - metallic)) of the first material that took
    /// the row: the transmitted light's, as Bevy's forward pass keeps no albedo per pixel.
    /// Materials sharing a (medium, width) share it; textures are not read.
    pub albedo: [f32; 3],
}

/// The profile table: every (medium, width) pair the skin materials have used, in order of
/// first use. Rows are never removed, so a row number stays valid for the app's life.
#[derive(Resource, Clone, Debug, Default)]
pub struct SkinMedia {
    pub rows: Vec<SkinRow>,
}

impl SkinMedia {
    /// The row of this medium and width, added if new. The medium must be a known preset
    /// or coefficients in subsurface-profile's range.
    pub fn row(&mut self, medium: &SkinMedium, width: f32) -> Result<u32, SubsurfaceError> {
        if !(width.is_finite() && width > 0.0) {
            return Err(SubsurfaceError::Width(width));
        }
        // Every material asks each frame: a row already there was checked when it was added,
        // so only a new medium builds its optics to check them.
        if let Some(i) = self
            .rows
            .iter()
            .position(|r| r.medium == *medium && r.width == width)
        {
            return Ok(i as u32);
        }
        medium
            .profile_medium()
            .material()
            .map_err(|e| SubsurfaceError::Medium(medium.to_string(), e.to_string()))?;
        let key = SkinRow {
            medium: medium.clone(),
            width,
            albedo: [1.0; 3],
        };
        if self.rows.len() == MAX_ROWS {
            return Err(SubsurfaceError::TooManyRows { max: MAX_ROWS });
        }
        self.rows.push(key);
        Ok(self.rows.len() as u32 - 1)
    }
}

impl ExtractResource<RenderApp> for SkinMedia {
    type Source = SkinMedia;

    fn extract_resource(source: &Self::Source) -> Self {
        source.clone()
    }
}

/// Gives each skin material its row. A material whose row is already right is not touched,
/// so this changes (and re-uploads) a material only when it is new or its medium or width
/// changed. An invalid medium or width is logged once per material and leaves the material
/// drawn as plain PBR.
pub(crate) fn assign_rows(
    mut materials: ResMut<Assets<SkinMaterial>>,
    mut media: ResMut<SkinMedia>,
    mut reported: Local<HashSet<AssetId<SkinMaterial>>>,
) {
    let rows_before = media.rows.len();
    let mut updates = Vec::new();
    for (id, m) in materials.iter() {
        let skin = &m.extension;
        // A specular twin is a copy of its skin material, row included (it writes no
        // marker anyway): looking it up would only report the same error twice.
        if skin.specular {
            continue;
        }
        // Change detection on the table is set below only when a row was added: looking a
        // row up every frame must not re-extract the table every frame.
        let table = media.bypass_change_detection();
        let rows = table.rows.len();
        let row = match table.row(&skin.medium, skin.width) {
            Ok(row) => {
                reported.remove(&id);
                if table.rows.len() > rows {
                    let c = m.base.base_color.to_linear();
                    let diffuse = 1.0 - m.base.metallic.clamp(0.0, 1.0);
                    table.rows[row as usize].albedo =
                        [c.red, c.green, c.blue].map(|x| x.max(0.0) * diffuse);
                }
                Some(row)
            }
            Err(e) => {
                if reported.insert(id) {
                    log::error!("subsurface: {e}; the material is drawn without scattering");
                }
                None
            }
        };
        if row != skin.row {
            updates.push((id, row));
        }
    }
    for (id, row) in updates {
        if let Some(mut m) = materials.get_mut(id) {
            m.extension.row = row;
        }
    }
    if media.rows.len() != rows_before {
        media.set_changed();
    }
}

/// The child entity that draws a skin mesh's specular light (see the module's
/// documentation). It casts no shadow: the skin mesh does.
#[derive(Component, Clone, Copy, Debug)]
pub struct SkinSpecular;

/// Each skin material's specular twin.
#[derive(Resource, Default)]
pub(crate) struct SpecularTwins(HashMap<AssetId<SkinMaterial>, Handle<SkinMaterial>>);

fn twin_of(material: &SkinMaterial) -> SkinMaterial {
    let mut twin = material.clone();
    twin.base.alpha_mode = AlphaMode::Add;
    twin.extension.specular = true;
    twin
}

/// Gives every skin mesh its specular child (again when its mesh or material changes).
#[allow(clippy::type_complexity)]
pub(crate) fn spawn_specular_twins(
    mut commands: Commands,
    skins: Query<
        (Entity, &Mesh3d, &MeshMaterial3d<SkinMaterial>),
        (
            Without<SkinSpecular>,
            Or<(Changed<MeshMaterial3d<SkinMaterial>>, Changed<Mesh3d>)>,
        ),
    >,
    children: Query<&Children>,
    specular: Query<(), With<SkinSpecular>>,
    mut twins: ResMut<SpecularTwins>,
    mut materials: ResMut<Assets<SkinMaterial>>,
) {
    for (entity, mesh, material) in &skins {
        for child in children.get(entity).into_iter().flatten() {
            if specular.contains(*child) {
                commands.entity(*child).despawn();
            }
        }
        let id = material.id();
        let twin = match twins.0.get(&id) {
            Some(twin) => twin.clone(),
            None => {
                let Some(copy) = materials.get(id).map(twin_of) else {
                    continue;
                };
                let twin = materials.add(copy);
                twins.0.insert(id, twin.clone());
                twin
            }
        };
        commands.spawn((
            Mesh3d(mesh.0.clone()),
            MeshMaterial3d(twin),
            // The parent's transform exactly, so the twin's depth equals the skin's and
            // passes the transparent pass's depth test.
            Transform::IDENTITY,
            NotShadowCaster,
            SkinSpecular,
            ChildOf(entity),
        ));
    }
}

/// Removes the specular child of an entity that is no longer skin (its skin material was
/// removed or replaced by another material type): it would keep drawing the old skin's
/// highlights.
pub(crate) fn remove_stale_twins(
    mut commands: Commands,
    mut removed: RemovedComponents<MeshMaterial3d<SkinMaterial>>,
    skins: Query<(), (With<MeshMaterial3d<SkinMaterial>>, Without<SkinSpecular>)>,
    children: Query<&Children>,
    specular: Query<(), With<SkinSpecular>>,
) {
    for entity in removed.read() {
        // Removed and added again in the same frame: spawn_specular_twins handles it.
        if skins.contains(entity) {
            continue;
        }
        for child in children.get(entity).into_iter().flatten() {
            if specular.contains(*child) {
                commands.entity(*child).despawn();
            }
        }
    }
}

/// Keeps each twin a copy of its skin material (base parameters, medium, width).
pub(crate) fn sync_specular_twins(
    mut events: MessageReader<AssetEvent<SkinMaterial>>,
    twins: Res<SpecularTwins>,
    mut materials: ResMut<Assets<SkinMaterial>>,
) {
    for event in events.read() {
        let AssetEvent::Modified { id } = event else {
            continue;
        };
        // Twins' own events are not keys of the map, so this does not feed itself.
        let Some(twin) = twins.0.get(id) else {
            continue;
        };
        let Some(copy) = materials.get(*id).map(twin_of) else {
            continue;
        };
        if let Some(mut t) = materials.get_mut(twin) {
            *t = copy;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bevy::MinimalPlugins;
    use bevy::app::{App, Update};
    use bevy::asset::{AssetApp, AssetPlugin};

    /// The twin systems alone (no renderer): an app with skin material assets.
    fn twin_app() -> App {
        let mut app = App::new();
        app.add_plugins((MinimalPlugins, AssetPlugin::default()))
            .init_asset::<SkinMaterial>()
            .init_resource::<SpecularTwins>()
            .add_systems(Update, (spawn_specular_twins, remove_stale_twins).chain());
        app
    }

    fn twins_of(app: &mut App, entity: Entity) -> Vec<Entity> {
        let world = app.world_mut();
        let children: Vec<Entity> = world
            .get::<Children>(entity)
            .map(|c| c.iter().collect())
            .unwrap_or_default();
        children
            .into_iter()
            .filter(|c| world.get::<SkinSpecular>(*c).is_some())
            .collect()
    }

    #[test]
    fn a_skin_mesh_gets_one_additive_twin_and_loses_it_when_no_longer_skin() {
        let mut app = twin_app();
        let skin = app
            .world_mut()
            .resource_mut::<Assets<SkinMaterial>>()
            .add(SkinMaterial::default());
        let entity = app
            .world_mut()
            .spawn((Mesh3d::default(), MeshMaterial3d(skin.clone())))
            .id();
        app.update();
        let twins = twins_of(&mut app, entity);
        assert_eq!(twins.len(), 1);
        let twin_material = app
            .world()
            .get::<MeshMaterial3d<SkinMaterial>>(twins[0])
            .unwrap()
            .0
            .clone();
        assert_ne!(twin_material.id(), skin.id());
        let materials = app.world().resource::<Assets<SkinMaterial>>();
        let twin = materials.get(&twin_material).unwrap();
        assert!(twin.extension.specular);
        assert_eq!(twin.base.alpha_mode, AlphaMode::Add);
        // Frames without a change spawn nothing more.
        app.update();
        app.update();
        assert_eq!(twins_of(&mut app, entity), twins);

        app.world_mut()
            .entity_mut(entity)
            .remove::<MeshMaterial3d<SkinMaterial>>();
        app.update();
        assert!(twins_of(&mut app, entity).is_empty());
        assert!(app.world().get_entity(twins[0]).is_err());
    }

    #[test]
    fn rows_are_shared_per_medium_and_width() {
        let mut media = SkinMedia::default();
        assert_eq!(media.row(&"skin1".into(), 1.0).unwrap(), 0);
        assert_eq!(media.row(&"marble".into(), 1.0).unwrap(), 1);
        assert_eq!(media.row(&"skin1".into(), 2.0).unwrap(), 2);
        assert_eq!(media.row(&"skin1".into(), 1.0).unwrap(), 0);
        assert_eq!(media.rows.len(), 3);
        // Measured media: equal coefficients share a row, others take their own.
        let measured = |a: f64| SkinMedium::Measured {
            sigma_a: [a, 0.17, 0.48],
            sigma_s: [0.74, 0.88, 1.01],
            eta: 1.3,
        };
        assert_eq!(media.row(&measured(0.032), 1.0).unwrap(), 3);
        assert_eq!(media.row(&measured(0.04), 1.0).unwrap(), 4);
        assert_eq!(media.row(&measured(0.032), 1.0).unwrap(), 3);
        // A scene file's medium converts both ways.
        let scene = measured(0.032).profile_medium();
        assert_eq!(SkinMedium::from(scene), measured(0.032));
    }

    #[test]
    fn bad_media_and_widths_are_errors_not_rows() {
        let mut media = SkinMedia::default();
        let e = media.row(&"unobtainium".into(), 1.0).unwrap_err();
        assert!(
            matches!(e, SubsurfaceError::Medium(ref m, _) if m == "\"unobtainium\""),
            "{e}"
        );
        for w in [0.0, -1.0, f32::NAN, f32::INFINITY] {
            assert!(matches!(
                media.row(&"skin".into(), w),
                Err(SubsurfaceError::Width(_))
            ));
        }
        let bad = SkinMedium::Measured {
            sigma_a: [0.032, 0.0, 0.48],
            sigma_s: [0.74, 0.88, 1.01],
            eta: 1.3,
        };
        let e = media.row(&bad, 1.0).unwrap_err().to_string();
        assert!(e.contains("sigma_a.g"), "{e}");
        assert!(media.rows.is_empty());
    }

    #[test]
    fn the_table_stops_at_its_size() {
        let mut media = SkinMedia::default();
        for i in 0..MAX_ROWS {
            media.row(&"skin".into(), 1.0 + i as f32).unwrap();
        }
        assert!(matches!(
            media.row(&"skin".into(), 0.5),
            Err(SubsurfaceError::TooManyRows { .. })
        ));
        // An existing row is still found.
        assert_eq!(media.row(&"skin".into(), 1.0).unwrap(), 0);
    }

    #[test]
    fn the_marker_names_the_row() {
        let mut skin = Skin::new("skin", 1.0);
        let images = RenderAssets::<GpuImage>::default();
        let uniform = |s: &Skin| -> SkinUniform { s.as_bind_group_shader_type(&images) };
        assert_eq!(uniform(&skin).marker, 1.0);
        skin.row = Some(0);
        assert_eq!(uniform(&skin).marker, -1.0);
        skin.row = Some(5);
        assert_eq!(uniform(&skin).marker, -6.0);
        assert_eq!(uniform(&skin).specular, 0);
        let twin = twin_of(&SkinMaterial::default());
        assert_eq!(uniform(&twin.extension).specular, 1);
        assert_eq!(twin.base.alpha_mode, AlphaMode::Add);
    }
}
