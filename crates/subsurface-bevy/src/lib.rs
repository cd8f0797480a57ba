//! Subsurface scattering for skin in Bevy 0.20.
//!
//! ```no_run
//! use bevy::prelude::*;
//! use bevy::camera::Hdr;
//! use subsurface_bevy::{Skin, SkinMaterial, Subsurface, SubsurfacePlugin};
//!
//! fn setup(
//!     mut commands: Commands,
//!     mut meshes: ResMut<Assets<Mesh>>,
//!     mut skins: ResMut<Assets<SkinMaterial>>,
//! ) {
//!     commands.spawn((Camera3d::default(), Hdr, Msaa::Off, Subsurface::default()));
//!     commands.spawn((
//!         Mesh3d(meshes.add(Sphere::new(0.1))),
//!         MeshMaterial3d(skins.add(SkinMaterial {
//!             base: StandardMaterial::from_color(Color::srgb(0.8, 0.55, 0.45)),
//!             extension: Skin::new("skin1", 1.0),
//!         })),
//!     ));
//! }
//!
//! App::new()
//!     .add_plugins((DefaultPlugins, SubsurfacePlugin))
//!     .add_systems(Startup, setup)
//!     .run();
//! ```
//!
//! What happens each frame, for every camera with [`Subsurface`]:
//! 1. The skin material ([`SkinMaterial`]: Bevy's `StandardMaterial` extended by [`Skin`])
//!    lights its pixels with Bevy's own PBR code in Bevy's main opaque pass, diffuse light
//!    only, and marks them as skin in the alpha channel of the camera's HDR texture
//!    (`skin.wesl`).
//! 2. Between Bevy's opaque and transparent passes, [`render`]'s step turns the camera's
//!    depth buffer and that marker into subsurface-render's inputs (linear depth; strength,
//!    scale, profile row) and runs `SssPass` on the HDR texture itself.
//!    With [`Subsurface::transmittance`] (the default), the step first adds the light that
//!    crosses thin backlit skin, read from Bevy's directional, spot and point shadow maps
//!    ([`transmit`]).
//! 3. Bevy's transparent pass then adds the skin's specular light, drawn by a child entity
//!    ([`SkinSpecular`]) with an additive twin of the material: highlights stay sharp.
//!
//! Limits of this version: transmittance reads one cascade of each directional light and
//! takes each material row's base colour as albedo; cameras need `Msaa::Off` (the plugin sets
//! it) and a perspective projection; each skin mesh is drawn twice in the main passes.

use bevy::app::{App, Plugin, PostUpdate};
use bevy::asset::embedded_asset;
use bevy::camera::{Camera3d, Hdr};
use bevy::ecs::prelude::*;
use bevy::pbr::MaterialPlugin;
use bevy::render::RenderApp;
use bevy::render::extract_component::{ExtractComponent, ExtractComponentPlugin};
use bevy::render::extract_resource::ExtractResourcePlugin;
use bevy::render::render_resource::TextureUsages;
use bevy::render::sync_component::SyncComponent;
use bevy::render::view::Msaa;

mod material;
pub mod render;
mod shadow_lights;
pub mod transmit;

pub use material::{Skin, SkinMaterial, SkinMedia, SkinMedium, SkinRow, SkinSpecular};
pub use subsurface_render::settings::Quality;

/// Errors of this crate. Nothing in the library panics on bad input: a medium that is not
/// known, or a GPU step that cannot be built, is logged with one of these and the skin is
/// left unscattered.
#[derive(Debug, thiserror::Error)]
pub enum SubsurfaceError {
    #[error("skin medium {0}: {1}")]
    Medium(String, String),
    #[error("skin width {0} must be finite and > 0")]
    Width(f32),
    #[error("more than {max} distinct skin (medium, width) pairs")]
    TooManyRows { max: usize },
    #[error("subsurface pass: {0}")]
    Render(#[from] subsurface_render::RenderError),
}

/// Put this on a `Camera3d` to scatter light under the skin it sees. The camera must be HDR
/// (the step works on its `Rgba16Float` main texture), so `Subsurface` requires `Hdr`.
#[derive(Component, Clone, Copy, Debug, PartialEq)]
#[require(Hdr)]
pub struct Subsurface {
    /// The quality preset of subsurface-render (`low`, `medium`, `high`): the number of
    /// kernel taps and whether they are jittered.
    pub quality: Quality,
    /// Scene units per millimetre of skin. Bevy's unit is the metre, so 0.001; a skin
    /// material's width multiplies it.
    pub units_per_mm: f32,
    /// Light through thin backlit skin (ears, fingers) from the shadow-casting directional,
    /// spot and point lights, read from Bevy's shadow maps (a directional light's first
    /// cascade: see [`transmit::CASCADE`]). On by default; a camera without such a light
    /// skips it.
    pub transmittance: bool,
}

impl Default for Subsurface {
    fn default() -> Self {
        Self {
            quality: Quality::Medium,
            units_per_mm: 0.001,
            transmittance: true,
        }
    }
}

impl SyncComponent<RenderApp> for Subsurface {
    type Target = Self;
}

impl ExtractComponent<RenderApp> for Subsurface {
    type QueryData = &'static Self;
    type QueryFilter = bevy::ecs::query::With<Camera3d>;
    type Out = Self;

    fn extract_component(item: &Self) -> Option<Self> {
        Some(*item)
    }
}

/// Adds the skin material, the extraction of [`Subsurface`] cameras and the render step.
pub struct SubsurfacePlugin;

impl Plugin for SubsurfacePlugin {
    fn build(&self, app: &mut App) {
        embedded_asset!(app, "skin.wesl");
        app.init_resource::<SkinMedia>()
            .init_resource::<material::SpecularTwins>()
            .init_resource::<transmit::SkinBounds>()
            .add_plugins((
                MaterialPlugin::<SkinMaterial>::default(),
                ExtractComponentPlugin::<Subsurface>::default(),
                ExtractResourcePlugin::<SkinMedia>::default(),
                ExtractResourcePlugin::<transmit::SkinBounds>::default(),
            ))
            .add_systems(
                PostUpdate,
                (
                    material::assign_rows,
                    material::spawn_specular_twins,
                    material::remove_stale_twins,
                    material::sync_specular_twins,
                    prepare_cameras,
                )
                    .chain(),
            )
            .add_systems(
                PostUpdate,
                transmit::skin_bounds
                    .after(bevy::camera::visibility::VisibilitySystems::CalculateBounds)
                    .after(bevy::transform::TransformSystems::Propagate),
            );
        render::build(app);
    }
}

/// The render step reads the camera's depth buffer, so it must be a texture; and a
/// multisampled colour or depth target would need resolving first, which this version
/// does not do: such cameras get `Msaa::Off`.
fn prepare_cameras(mut cameras: Query<(&mut Camera3d, &mut Msaa), Added<Subsurface>>) {
    for (mut camera, mut msaa) in &mut cameras {
        let usages = TextureUsages::from(camera.depth_texture_usages);
        if !usages.contains(TextureUsages::TEXTURE_BINDING) {
            camera.depth_texture_usages = (usages | TextureUsages::TEXTURE_BINDING).into();
        }
        if *msaa != Msaa::Off {
            log::info!("subsurface: MSAA is not supported yet; the camera gets Msaa::Off");
            *msaa = Msaa::Off;
        }
    }
}
