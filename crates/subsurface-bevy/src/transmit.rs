//! Transmittance: light through thin backlit skin (ears, fingers), from Bevy's own
//! directional and spot shadow maps, for each [`crate::Subsurface`] camera with
//! `transmittance` on.
//!
//! Per frame, inside the render step (render.rs), after the mark pass has written linear
//! depth, the SSS texture and a G-buffer (world normal rebuilt from the depth buffer, the
//! row's albedo):
//! 1. one cascade per shadow-casting directional light (the first, the finest: see
//!    [`CASCADE`]), each shadow-casting spot light's map and each
//!    shadow-casting point light's six cube faces are copied out of Bevy's shadow textures
//!    (`ViewShadowBindings`) into a forward-Z
//!    `Depth32Float` array of ours (forward_z.wgsl), the z-buffer layout subsurface-render's
//!    shadow entry pass and shadow lookups read;
//! 2. `ShadowEntryPass` turns it into the skin's shadow maps (light distance, entry normal);
//! 3. `TransmittedLightPass` adds the transmitted light into the main texture (diffuse,
//!    blurred next by `SssPass`) and its unscattered part into a scratch texture, which
//!    `Transmit::add_unscattered` adds onto the main texture after the blur.
//!
//! Units: subsurface-render's radiance is albedo x irradiance (no 1/pi); Bevy's Lambert
//! lobe is albedo / pi x illuminance x exposure. So each light's colour is Bevy's colour x
//! illuminance (a spot or point light's: intensity) x the camera's exposure / pi, and every output
//! lands in Bevy's units.

use bevy::camera::primitives::Aabb;
use bevy::ecs::prelude::*;
use bevy::math::{Mat4 as BevyMat4, Vec3 as BevyVec3};
use bevy::pbr::MeshMaterial3d;
use bevy::render::RenderApp;
use bevy::render::extract_resource::ExtractResource;
use bevy::transform::components::GlobalTransform;
use glam::Mat4;
use subsurface_render::material::MaterialCache;
use subsurface_render::passes::lighting::{self, ShadowMaps};
use subsurface_render::passes::shadow_entry::{EntryLayer, ShadowEntryPass};
use subsurface_render::passes::transmitted_light::{
    GBufferGroup, SkinGBuffer, SkinMedium, TransmittedLightPass,
};
use subsurface_render::passes::{fullscreen, maps, util};
use subsurface_render::scene::MaterialDesc;
use subsurface_render::uniforms::{CameraUniform, LightUniform, LightsUniform, MAX_LIGHTS};
use subsurface_render::{RenderSettings, gpu_scene};

use crate::SubsurfaceError;
use crate::material::{SkinMaterial, SkinMedia, SkinSpecular};
pub use crate::shadow_lights::CASCADE;
use crate::shadow_lights::{FaceMap, LightShadow, MapSource};

/// The world-space box around every skin mesh (main world, extracted each frame it
/// changes): the copy and entry passes draw only the texels of Bevy's cascade that it covers,
/// grown by [`MARGIN_MM`], rather than the whole map (a 2048² cascade costs hundreds of
/// milliseconds a frame on a software rasterizer, most of it far from any skin).
#[derive(Resource, Clone, Copy, Debug, Default, PartialEq)]
pub struct SkinBounds(pub Option<(BevyVec3, BevyVec3)>);

impl ExtractResource<RenderApp> for SkinBounds {
    type Source = SkinBounds;

    fn extract_resource(source: &Self::Source) -> Self {
        *source
    }
}

/// Profile millimetres around the skin's box that the passes still draw: the transmitted
/// light's lateral taps reach this far beside the light's chord (their spread follows the
/// medium's slowest decay, and past DIFFUSION_RANGE_MM the tables hold nothing).
pub const MARGIN_MM: f32 = 50.0;

/// The half-size of the box taken for skin without an `Aabb`: far beyond any cascade, small
/// enough that its corners project to finite clip coordinates.
const UNBOUNDED: f32 = 1e9;

/// The skin meshes (their specular twins are the same meshes again).
type SkinMeshes = (With<MeshMaterial3d<SkinMaterial>>, Without<SkinSpecular>);

pub(crate) fn skin_bounds(
    skins: Query<(&GlobalTransform, Option<&Aabb>), SkinMeshes>,
    mut bounds: ResMut<SkinBounds>,
) {
    let mut b: Option<(BevyVec3, BevyVec3)> = None;
    for (transform, aabb) in &skins {
        // A mesh without bounds (`NoFrustumCulling`) could be anywhere: the whole map.
        let Some(aabb) = aabb else {
            b = Some((BevyVec3::splat(-UNBOUNDED), BevyVec3::splat(UNBOUNDED)));
            break;
        };
        let (centre, half) = (
            BevyVec3::from(aabb.center),
            BevyVec3::from(aabb.half_extents),
        );
        for i in 0..8 {
            let sign = |bit: usize| if i & bit == 0 { -1.0 } else { 1.0 };
            let corner = centre + half * BevyVec3::new(sign(1), sign(2), sign(4));
            let p = transform.transform_point(corner);
            b = Some(b.map_or((p, p), |(lo, hi)| (lo.min(p), hi.max(p))));
        }
    }
    bounds.set_if_neq(SkinBounds(b));
}

const FORWARD_Z_WGSL: &str = include_str!("forward_z.wgsl");
const ADD_WGSL: &str = include_str!("add.wgsl");

/// The render settings transmittance runs with: the quality preset's, with what this
/// integration does not have turned off (the bounce needs a flux pyramid, the lateral map
/// and the diffusion source's shadow shift and the thin parts' reflectance are terms of
/// subsurface-render's own lighting pass), as in subsurface-render's `skin_in_your_renderer`
/// example.
pub(crate) fn settings(quality: crate::Quality) -> RenderSettings {
    let mut s = RenderSettings::preset(quality);
    s.transmitted_map.texel_mm = 0.0;
    s.sss.source_shift = false;
    s.sss.thin_parts = false;
    s.bounce.ring = 0;
    s
}

fn mat(m: BevyMat4) -> Mat4 {
    Mat4::from_cols_array(&m.to_cols_array())
}

/// Bevy's reverse-Z clip space to the forward-Z one our copy holds: z -> w - z, so that
/// z / w becomes 1 - d as the copy writes (an orthographic cascade has w = 1; a spot light's
/// infinite perspective has d = near / depth, and 1 - d still rises from 0 at the near plane
/// to 1 at infinity).
fn forward_z(clip_from_world: BevyMat4) -> Mat4 {
    let flip = Mat4::from_cols(
        glam::Vec4::X,
        glam::Vec4::Y,
        glam::Vec4::new(0.0, 0.0, -1.0, 0.0),
        glam::Vec4::new(0.0, 0.0, 1.0, 1.0),
    );
    flip * mat(clip_from_world)
}

/// The pipelines every camera shares.
pub(crate) struct Pipelines {
    /// The copy from a layer of Bevy's texture (a cascade) ...
    forward_z: wgpu::RenderPipeline,
    /// ... and from a one-layer view of it (a spot light's map).
    forward_z_view: wgpu::RenderPipeline,
    add: wgpu::RenderPipeline,
}

impl Pipelines {
    pub fn new(device: &wgpu::Device) -> Self {
        let module = |label, wgsl: &str| {
            util::wgsl_module(device, label, &format!("{}{wgsl}", fullscreen::VERTEX_WGSL))
        };
        let copy = module("subsurface forward z", FORWARD_Z_WGSL);
        let forward_z = |entry| {
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some("subsurface forward z"),
                layout: None,
                vertex: wgpu::VertexState {
                    module: &copy,
                    entry_point: Some("vs_fullscreen"),
                    compilation_options: Default::default(),
                    buffers: &[],
                },
                primitive: Default::default(),
                depth_stencil: Some(wgpu::DepthStencilState {
                    format: wgpu::TextureFormat::Depth32Float,
                    depth_write_enabled: Some(true),
                    depth_compare: Some(wgpu::CompareFunction::Always),
                    stencil: Default::default(),
                    bias: Default::default(),
                }),
                multisample: Default::default(),
                fragment: Some(wgpu::FragmentState {
                    module: &copy,
                    entry_point: Some(entry),
                    compilation_options: Default::default(),
                    targets: &[],
                }),
                multiview_mask: None,
                cache: None,
            })
        };
        let (forward_z, forward_z_view) =
            (forward_z("fs_forward_z"), forward_z("fs_forward_z_view"));
        let add_module = module("subsurface add unscattered", ADD_WGSL);
        // Colour added, destination alpha kept (it is 1 after the blur, and the specular
        // twin's blending relies on it).
        let add_blend = fullscreen::ADD;
        let add = fullscreen::pipeline(
            device,
            &add_module,
            None,
            "fs_add",
            &[Some(wgpu::ColorTargetState {
                format: lighting::RADIANCE_FORMAT,
                blend: Some(add_blend),
                write_mask: wgpu::ColorWrites::ALL,
            })],
        );
        Self {
            forward_z,
            forward_z_view,
            add,
        }
    }
}

/// The parts bound to Bevy's shadow texture and the number of lights.
struct Shadows {
    key: ShadowKey,
    copies: Vec<LayerCopy>,
    entry: ShadowEntryPass,
    frame: wgpu::BindGroup,
}

struct LayerCopy {
    /// A cascade's layer in Bevy's texture (a spot light's view needs none).
    uniform: Option<wgpu::Buffer>,
    bind_group: wgpu::BindGroup,
    target: wgpu::TextureView,
}

/// Bevy's directional shadow texture, its size, the lights read from it (a spot light by its
/// map's view).
type ShadowKey = (
    bevy::render::render_resource::TextureId,
    u32,
    Vec<Option<bevy::render::render_resource::TextureViewId>>,
);

/// One camera's transmittance state (for one main texture, as `render::ViewSss`).
pub(crate) struct Transmit {
    /// The quality preset's, as [`settings`] adapts them (the view is rebuilt when the
    /// quality changes).
    settings: RenderSettings,
    pass: TransmittedLightPass,
    media: Vec<SkinMedium>,
    camera: wgpu::Buffer,
    lights: wgpu::Buffer,
    /// G-buffer targets the mark pass writes: world normal, albedo.
    pub normal: wgpu::TextureView,
    pub albedo: wgpu::TextureView,
    /// The unscattered part, added after the blur.
    scratch: wgpu::TextureView,
    add_bind_group: wgpu::BindGroup,
    main_view: wgpu::TextureView,
    shadows: Option<Shadows>,
    /// The G-buffer's group (made on the first frame, its camera matrix rewritten after).
    gbuffer: Option<GBufferGroup>,
}

/// What the frame's transmittance draws with.
pub(crate) struct Frame<'a> {
    pub camera: CameraUniform,
    pub clip_from_world: BevyMat4,
    pub lights: &'a [LightShadow],
    /// `ViewShadowBindings::directional_light_depth_texture`.
    pub bevy_shadows: &'a bevy::render::render_resource::Texture,
    pub depth: &'a wgpu::TextureView,
    pub sss: &'a wgpu::TextureView,
    pub units_per_mm: f32,
}

impl Transmit {
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        pipelines: &Pipelines,
        cache: &mut MaterialCache,
        main: &wgpu::Texture,
        quality: crate::Quality,
        units_per_mm: f32,
        media: &SkinMedia,
    ) -> Result<Self, SubsurfaceError> {
        let settings = settings(quality);
        let pass = TransmittedLightPass::new(device, &settings);
        let mut skin_media = Vec::with_capacity(media.rows.len());
        for (i, row) in media.rows.iter().enumerate() {
            let medium = row.medium.profile_medium();
            let optics = cache.get(&medium, "skin.medium")?;
            let desc = MaterialDesc {
                medium,
                ..Default::default()
            };
            let uniform =
                gpu_scene::medium_uniform(&desc, &optics, units_per_mm * row.width, 0.0, i as u32);
            skin_media.push(SkinMedium::on_device(device, queue, &optics, uniform)?);
        }
        let (w, h) = (main.width(), main.height());
        let target = |label, format| {
            util::render_target(device, label, w, h, format).create_view(&Default::default())
        };
        let f16 = lighting::RADIANCE_FORMAT;
        let scratch = target("subsurface unscattered", f16);
        let add_bind_group = util::bind_group(
            device,
            "subsurface add unscattered",
            &pipelines.add.get_bind_group_layout(0),
            [(0, wgpu::BindingResource::TextureView(&scratch))],
        );
        let uniform = |label, size: usize| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: size as u64,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        };
        Ok(Self {
            settings,
            pass,
            media: skin_media,
            camera: uniform("subsurface camera", std::mem::size_of::<CameraUniform>()),
            lights: uniform("subsurface lights", std::mem::size_of::<LightsUniform>()),
            normal: target("subsurface normal", f16),
            albedo: target("subsurface albedo", f16),
            scratch,
            add_bind_group,
            main_view: main.create_view(&Default::default()),
            shadows: None,
            gbuffer: None,
        })
    }

    /// Writes the frame's uniforms, (re)binds what changed, and encodes steps 1-3 of the
    /// module's documentation. `frame.lights` is not empty.
    pub fn encode(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        pipelines: &Pipelines,
        encoder: &mut wgpu::CommandEncoder,
        frame: &Frame<'_>,
    ) {
        let lights = &frame.lights[..frame.lights.len().min(MAX_LIGHTS)];
        // Every map in one array of ours, a light's faces in a row, as large as the largest
        // (a smaller one fills its top-left corner).
        let faces: Vec<(&LightShadow, &FaceMap)> = lights
            .iter()
            .flat_map(|l| l.faces.iter().map(move |f| (l, f)))
            .collect();
        let size = faces.iter().map(|(_, f)| f.size).max().unwrap_or(1);
        let views = faces
            .iter()
            .map(|(_, f)| match &f.source {
                MapSource::Layer(_) => None,
                MapSource::View(v) => Some(v.id()),
            })
            .collect();
        let key: ShadowKey = (frame.bevy_shadows.id(), size, views);
        let entry_layers: Vec<EntryLayer> = faces
            .iter()
            .map(|(l, f)| EntryLayer {
                view_proj: forward_z(f.clip_from_world),
                kind: l.kind,
                origin: l.origin,
                direction: l.direction,
                size: f.size,
            })
            .collect();
        if self.shadows.as_ref().is_none_or(|s| s.key != key) {
            self.shadows =
                Some(self.bind_shadows(device, pipelines, frame, key, &faces, &entry_layers));
        }
        let Some(shadows) = &mut self.shadows else {
            return;
        };
        shadows.entry.set_layers(queue, &entry_layers);
        for (i, (_, face)) in faces.iter().enumerate() {
            shadows.entry.set_region(i, Some(face.region));
        }
        for (copy, (_, face)) in shadows.copies.iter().zip(&faces) {
            if let (Some(uniform), MapSource::Layer(layer)) = (&copy.uniform, &face.source) {
                let layer = [*layer as i32, 0, 0, 0];
                queue.write_buffer(uniform, 0, bytemuck::cast_slice(&layer));
            }
        }
        queue.write_buffer(&self.camera, 0, bytemuck::bytes_of(&frame.camera));
        let uniform = lights_uniform(lights, &self.settings, frame.units_per_mm, size);
        queue.write_buffer(&self.lights, 0, bytemuck::bytes_of(&uniform));
        // The G-buffer's textures are this view's for its life; only the camera moves.
        let view_proj = mat(frame.clip_from_world);
        match &self.gbuffer {
            Some(g) => g.set_view_proj(queue, view_proj),
            None => {
                let gbuffer = SkinGBuffer {
                    depth: frame.depth,
                    normal: &self.normal,
                    albedo: &self.albedo,
                    medium: frame.sss,
                };
                self.gbuffer = Some(self.pass.bind_gbuffer(device, &gbuffer, view_proj));
            }
        }

        for (copy, (_, face)) in shadows.copies.iter().zip(&faces) {
            let mut pass = util::depth_pass(
                encoder,
                "subsurface forward z",
                &copy.target,
                wgpu::LoadOp::Clear(1.0),
                None,
            );
            // Outside the region the layer stays cleared: empty.
            let [x, y, w, h] = face.region;
            if w > 0 && h > 0 {
                pass.set_scissor_rect(x, y, w, h);
                pass.set_pipeline(match face.source {
                    MapSource::Layer(_) => &pipelines.forward_z,
                    MapSource::View(_) => &pipelines.forward_z_view,
                });
                pass.set_bind_group(0, &copy.bind_group, &[]);
                pass.draw(0..3, 0..1);
            }
        }
        shadows.entry.encode(encoder, None);
        // The scratch target starts each frame empty; the pass adds into it.
        drop(util::color_pass(
            encoder,
            "subsurface clear unscattered",
            &[util::color_attachment(
                &self.scratch,
                wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
            )],
            None,
        ));
        if let Some(gbuffer) = &self.gbuffer {
            self.pass.encode(
                encoder,
                &shadows.frame,
                &gbuffer.bind_group,
                &self.media,
                [&self.main_view, &self.scratch],
                None,
            );
        }
    }

    /// Adds the unscattered part onto the main texture; run after the blur.
    pub fn add_unscattered(&self, pipelines: &Pipelines, encoder: &mut wgpu::CommandEncoder) {
        let mut pass = util::color_pass(
            encoder,
            "subsurface add unscattered",
            &[util::color_attachment(&self.main_view, wgpu::LoadOp::Load)],
            None,
        );
        pass.set_pipeline(&pipelines.add);
        pass.set_bind_group(0, &self.add_bind_group, &[]);
        pass.draw(0..3, 0..1);
    }

    fn bind_shadows(
        &self,
        device: &wgpu::Device,
        pipelines: &Pipelines,
        frame: &Frame<'_>,
        key: ShadowKey,
        faces: &[(&LightShadow, &FaceMap)],
        entry_layers: &[EntryLayer],
    ) -> Shadows {
        let (_, size, ref views) = key;
        let depth = util::texture_2d(
            device,
            "subsurface forward-z shadow maps",
            size,
            size,
            views.len() as u32,
            wgpu::TextureFormat::Depth32Float,
            wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
        );
        let depth_array = util::array_view(&depth);
        let bevy_shadows: &wgpu::Texture = frame.bevy_shadows;
        let bevy_view = bevy_shadows.create_view(&wgpu::TextureViewDescriptor {
            label: Some("bevy directional shadow maps"),
            dimension: Some(wgpu::TextureViewDimension::D2Array),
            aspect: wgpu::TextureAspect::DepthOnly,
            ..Default::default()
        });
        let copies = (0..views.len() as u32)
            .zip(faces)
            .map(|(i, (_, face))| {
                let (uniform, bind_group) = match &face.source {
                    MapSource::Layer(_) => {
                        let uniform = device.create_buffer(&wgpu::BufferDescriptor {
                            label: Some("subsurface forward z layer"),
                            size: 16,
                            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                            mapped_at_creation: false,
                        });
                        let bind_group = util::bind_group(
                            device,
                            "subsurface forward z",
                            &pipelines.forward_z.get_bind_group_layout(0),
                            [
                                (0, wgpu::BindingResource::TextureView(&bevy_view)),
                                (1, uniform.as_entire_binding()),
                            ],
                        );
                        (Some(uniform), bind_group)
                    }
                    MapSource::View(view) => {
                        let bind_group = util::bind_group(
                            device,
                            "subsurface forward z (spot)",
                            &pipelines.forward_z_view.get_bind_group_layout(0),
                            [(2, wgpu::BindingResource::TextureView(view))],
                        );
                        (None, bind_group)
                    }
                };
                LayerCopy {
                    uniform,
                    bind_group,
                    target: util::layer_view(&depth, i),
                }
            })
            .collect();
        let entry = ShadowEntryPass::new(device, &depth_array, size, entry_layers);
        let tsm = maps::dummy_tsm_view(device);
        let frame_group = lighting::frame_bind_group(
            device,
            self.pass.frame_layout(),
            [&self.camera, &self.lights],
            ShadowMaps {
                atlas: entry.atlas_view(),
                depth: &depth_array,
                flux: None,
            },
            &tsm,
        );
        Shadows {
            key,
            copies,
            entry,
            frame: frame_group,
        }
    }
}

/// subsurface-render's `LightsUniform` for these lights, their faces in the layers of our
/// copy in turn (`size` texels square; a smaller map in its top-left corner).
fn lights_uniform(
    lights: &[LightShadow],
    settings: &RenderSettings,
    units_per_mm: f32,
    size: u32,
) -> LightsUniform {
    let t = &settings.transmittance;
    let mut u: LightsUniform = bytemuck::Zeroable::zeroed();
    u.count = lights.len() as u32;
    u.transmittance = t.method.code();
    u.thickness_filter = t.thickness_filter;
    // The skin's own scale, not subsurface-render's default scene's (0.5 mm there).
    u.normal_shrink = 0.5 * units_per_mm;
    u.lateral_taps = t.lateral_taps;
    u.map_downsample = 1;
    u.sss_runs = 1;
    u.bounce_cell_mm = settings.bounce.cell_mm;
    let mut first_layer = 0;
    for (i, l) in lights.iter().enumerate() {
        let mut view_proj = [[[0.0; 4]; 4]; 6];
        for (m, face) in view_proj.iter_mut().zip(&l.faces) {
            *m = forward_z(face.clip_from_world).to_cols_array_2d();
        }
        u.lights[i] = LightUniform {
            position: l.origin.to_array(),
            kind: l.kind,
            direction: l.direction.to_array(),
            first_layer: first_layer as f32,
            color: l.color,
            // Two texels along the light: the receiver's own depth, quantized and filtered
            // over 3x3 texels, must not shadow it.
            shadow_bias: 2.0 * l.texel_size,
            cos_outer: l.cone[0],
            cos_inner: l.cone[1],
            // A light's faces share one size (a point light's cube).
            shadow_uv_scale: l.faces.first().map_or(1.0, |f| f.size as f32 / size as f32),
            atlas_texel: 1.0 / size as f32,
            view_proj,
        };
        first_layer += l.faces.len();
    }
    u
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A Bevy cascade's reverse-Z depths become forward-Z through `forward_z`: a point on the
    /// near plane (Bevy 1) lands at 0, one on the far plane (Bevy 0) at 1, as the copy writes.
    #[test]
    fn forward_z_flips_a_cascades_depth() {
        // Bevy's cascade projection (bevy_light cascade.rs): z_clip = z / depth + 1.
        let depth = 4.0;
        let clip_from_world = BevyMat4::from_cols(
            bevy::math::Vec4::new(0.5, 0.0, 0.0, 0.0),
            bevy::math::Vec4::new(0.0, 0.5, 0.0, 0.0),
            bevy::math::Vec4::new(0.0, 0.0, 1.0 / depth, 0.0),
            bevy::math::Vec4::new(0.0, 0.0, 1.0, 1.0),
        );
        for (z, bevy_d) in [(0.0f32, 1.0f32), (-1.0, 0.75), (-4.0, 0.0)] {
            let p = bevy::math::Vec4::new(0.3, -0.2, z, 1.0);
            assert!(((clip_from_world * p).z - bevy_d).abs() < 1e-6);
            let ours = forward_z(clip_from_world) * glam::Vec4::new(0.3, -0.2, z, 1.0);
            assert!((ours.z / ours.w - (1.0 - bevy_d)).abs() < 1e-6, "{ours}");
            assert!((ours.x - 0.15).abs() < 1e-6 && (ours.y + 0.1).abs() < 1e-6);
        }
    }
}
