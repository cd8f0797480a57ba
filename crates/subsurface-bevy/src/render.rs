//! The render-world step: for each [`Subsurface`] camera, between Bevy's main opaque and
//! main transparent passes (`Core3d` schedule, `Core3dSystems::MainPass`), mark the skin
//! (mark.wgsl) and run subsurface-render's `SssPass` on the camera's HDR texture in place.
//!
//! Everything here is plain wgpu on Bevy's own device: `RenderDevice::wgpu_device`,
//! `RenderQueue` (a `wgpu::Queue`), `RenderContext::command_encoder` (a
//! `wgpu::CommandEncoder` that Bevy submits in system order), `ViewTarget::main_texture` and
//! `ViewDepthStencilTexture::texture` (`wgpu::Texture`s behind Bevy's wrappers).

use bevy::app::App;
use bevy::core_pipeline::core_3d::{main_opaque_pass_3d, main_transparent_pass_3d};
use bevy::core_pipeline::schedule::{Core3d, Core3dSystems};
use bevy::diagnostic::FrameCount;
use bevy::ecs::prelude::*;
use bevy::pbr::{
    ExtractedDirectionalLight, ExtractedPointLight, LightEntity, ShadowView, ViewLightEntities,
    ViewShadowBindings,
};
use bevy::platform::collections::HashMap;
use bevy::render::RenderApp;
use bevy::render::camera::ExtractedCamera;
use bevy::render::diagnostic::RecordDiagnostics;
use bevy::render::renderer::{RenderContext, RenderDevice, RenderQueue, ViewQuery};
use bevy::render::view::{ExtractedView, ViewDepthStencilTexture, ViewTarget};
use subsurface_profile::KernelParams;
use subsurface_render::material::{MaterialCache, screen_kernels};
use subsurface_render::passes::sss::{SssInputs, SssPass};
use subsurface_render::passes::{fullscreen, sss, util};
use subsurface_render::scene::MaterialDesc;
use subsurface_render::{RenderSettings, SssFetch, SssSettings};

use crate::material::{MAX_ROWS, SkinMedia};
use crate::shadow_lights::{self, Reach};
use crate::transmit::{self, Transmit};
use crate::{Subsurface, SubsurfaceError};

const MARK_WGSL: &str = include_str!("mark.wgsl");

pub(crate) fn build(app: &mut App) {
    let Some(render_app) = app.get_sub_app_mut(RenderApp) else {
        return;
    };
    render_app.init_resource::<SubsurfaceViews>().add_systems(
        Core3d,
        subsurface_pass
            .after(main_opaque_pass_3d)
            .before(main_transparent_pass_3d)
            .in_set(Core3dSystems::MainPass),
    );
}

/// `Mark` of mark.wgsl.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct MarkUniform {
    view_from_clip: [[f32; 4]; 4],
    world_from_view: [[f32; 4]; 4],
    size: [f32; 2],
    rows: u32,
    _pad: u32,
    scale: [[f32; 4]; MAX_ROWS / 4],
    albedo: [[f32; 4]; MAX_ROWS],
}

/// The SSS settings of a quality preset, with the fetch that works on Bevy's main texture:
/// the workgroup fetch's compute passes would need it to have storage usage.
fn sss_settings(quality: crate::Quality) -> SssSettings {
    let mut settings = RenderSettings::preset(quality).sss;
    settings.fetch = SssFetch::Packed;
    settings
}

/// The profile table for the media's rows (one kernel set per row).
fn kernels(
    media: &SkinMedia,
    settings: &SssSettings,
    cache: &mut MaterialCache,
) -> Result<Vec<subsurface_profile::ScreenKernels>, SubsurfaceError> {
    let mut rows = Vec::with_capacity(media.rows.len().max(1));
    for row in &media.rows {
        let medium = row.medium.profile_medium();
        let optics = cache.get(&medium, "skin.medium")?;
        let desc = MaterialDesc {
            medium,
            ..Default::default()
        };
        rows.push(
            screen_kernels(&optics, &desc, settings.samples)
                .map_err(|e| SubsurfaceError::Medium(row.medium.to_string(), e.to_string()))?,
        );
    }
    if rows.is_empty() {
        // The pass needs a table; with no skin material yet no pixel names a row.
        let skin = MaterialDesc::default();
        let (strength, falloff) = skin.kernel_params(true);
        rows.push(
            subsurface_profile::ScreenKernels::skin(&KernelParams {
                samples: settings.samples,
                strength,
                falloff,
            })
            .map_err(subsurface_render::RenderError::from)?,
        );
    }
    Ok(rows)
}

/// What one camera keeps between frames.
struct ViewSss {
    key: ViewSssKey,
    pass: SssPass,
    mark_uniform: wgpu::Buffer,
    mark_bind_group: wgpu::BindGroup,
    /// The mark pass's targets, linear depth and the SSS texture (the views keep their
    /// textures alive).
    targets: [wgpu::TextureView; 2],
    /// Transmittance, where the camera has it on (the mark pass then writes its G-buffer).
    transmit: Option<Transmit>,
    last_frame: u64,
}

/// The marker pipeline (shared) and each camera's state. Bevy swaps a camera's two main
/// textures between frames when post-processing writes one into the other, so a camera
/// may hold one state per main texture.
#[derive(Resource, Default)]
pub struct SubsurfaceViews {
    /// The mark pipelines: without and with the transmittance's G-buffer.
    mark: Option<[wgpu::RenderPipeline; 2]>,
    transmit: Option<transmit::Pipelines>,
    views: HashMap<(Entity, bevy::render::render_resource::TextureId), ViewSss>,
    cache: Option<MaterialCache>,
    /// Cameras already told why they are skipped (once each).
    warned: bevy::platform::collections::HashSet<Entity>,
    failed: bool,
}

fn mark_pipelines(device: &wgpu::Device) -> [wgpu::RenderPipeline; 2] {
    let source = format!("{}{MARK_WGSL}", fullscreen::VERTEX_WGSL);
    let module = util::wgsl_module(device, "subsurface mark", &source);
    let targets = [
        Some(wgpu::TextureFormat::R32Float.into()),
        Some(sss::FORMAT.into()),
        Some(wgpu::TextureFormat::Rgba16Float.into()),
        Some(wgpu::TextureFormat::Rgba16Float.into()),
    ];
    // Layouts derived from the shader: uniform, colour, depth.
    [("fs_mark", 2), ("fs_mark_gbuffer", 4)]
        .map(|(entry, n)| fullscreen::pipeline(device, &module, None, entry, &targets[..n]))
}

#[allow(clippy::too_many_arguments)]
fn build_view(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    mark: &[wgpu::RenderPipeline; 2],
    transmit_pipelines: &transmit::Pipelines,
    cache: &mut MaterialCache,
    key: ViewSssKey,
    main: &wgpu::Texture,
    depth_buffer: &wgpu::Texture,
    sub: &Subsurface,
    media: &SkinMedia,
) -> Result<ViewSss, SubsurfaceError> {
    let (w, h) = key.2;
    let target = |label, format| util::render_target(device, label, w, h, format);
    let depth = target("subsurface linear depth", wgpu::TextureFormat::R32Float);
    let sss_tex = target("subsurface skin", sss::FORMAT);
    let transmit = if sub.transmittance {
        Some(Transmit::new(
            device,
            queue,
            transmit_pipelines,
            cache,
            main,
            sub.quality,
            sub.units_per_mm,
            media,
        )?)
    } else {
        None
    };
    let mark = &mark[usize::from(transmit.is_some())];
    let settings = sss_settings(sub.quality);
    let mut pass = SssPass::new(device, &settings, &kernels(media, &settings, cache)?)?;
    let view = |t: &wgpu::Texture| t.create_view(&Default::default());
    let (depth_view, sss_view) = (view(&depth), view(&sss_tex));
    pass.resize(
        device,
        &SssInputs {
            diffuse: main,
            depth: &depth_view,
            sss: &sss_view,
        },
    );
    let depth_buffer_view = depth_buffer.create_view(&wgpu::TextureViewDescriptor {
        aspect: wgpu::TextureAspect::DepthOnly,
        ..Default::default()
    });
    // Each camera its own uniform: queue writes land before the frame's commands run, so
    // cameras sharing one buffer would all read the last camera's.
    let mark_uniform = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("subsurface mark"),
        size: std::mem::size_of::<MarkUniform>() as u64,
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mark_bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("subsurface mark"),
        layout: &mark.get_bind_group_layout(0),
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: mark_uniform.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: wgpu::BindingResource::TextureView(&view(main)),
            },
            wgpu::BindGroupEntry {
                binding: 2,
                resource: wgpu::BindingResource::TextureView(&depth_buffer_view),
            },
        ],
    });
    Ok(ViewSss {
        key,
        pass,
        mark_uniform,
        mark_bind_group,
        targets: [depth_view, sss_view],
        transmit,
        last_frame: 0,
    })
}

/// What a camera's targets and passes were built for: main texture, depth texture, size,
/// quality, rows of the profile table, transmittance on, units per mm (its bits: the
/// transmittance's media are scaled by it).
type ViewSssKey = (
    bevy::render::render_resource::TextureId,
    bevy::render::render_resource::TextureId,
    (u32, u32),
    crate::Quality,
    usize,
    bool,
    u32,
);

/// What the step reads of its camera: the view, its targets, the settings, the exposure (for
/// the lights' units), its shadow maps and the cascades of its directional lights.
type StepView = (
    &'static ExtractedView,
    &'static ViewTarget,
    &'static ViewDepthStencilTexture,
    &'static Subsurface,
    Option<&'static ExtractedCamera>,
    Option<&'static ViewShadowBindings>,
    Option<&'static ViewLightEntities>,
);

/// The step itself (a system of the camera's `Core3d` schedule; Bevy runs it once per
/// camera with that camera as the `ViewQuery`'s entity).
#[allow(clippy::too_many_arguments)]
fn subsurface_pass(
    view: ViewQuery<StepView>,
    light_views: Query<&LightEntity>,
    directional: Query<&ExtractedDirectionalLight>,
    shadow_views: Query<(&LightEntity, &ShadowView, &ExtractedView)>,
    point_lights: Query<&ExtractedPointLight>,
    media: Option<Res<SkinMedia>>,
    bounds: Option<Res<transmit::SkinBounds>>,
    mut state: ResMut<SubsurfaceViews>,
    device: Res<RenderDevice>,
    queue: Res<RenderQueue>,
    frame_count: Res<FrameCount>,
    mut ctx: RenderContext,
) {
    let entity = view.entity();
    let (extracted, target, depth_buffer, sub, camera, shadow_bindings, light_entities) =
        view.into_inner();
    // No skin material has a row yet: no pixel is marked, nothing to do.
    let Some(media) = media.filter(|m| !m.rows.is_empty()) else {
        return;
    };
    if state.failed {
        return;
    }
    let main: &wgpu::Texture = target.main_texture();
    let depth_tex: &wgpu::Texture = depth_buffer.texture();
    let clip_from_view = extracted.clip_from_view;
    // The step reads depth as a texture and writes main-texture texels one for one; a
    // multisampled depth buffer (MSAA) or one without texture usage cannot be read, and the
    // blur's footprint needs a perspective camera's focal length.
    let unsupported = if main.format() != sss::FORMAT {
        Some("the camera is not HDR (add `Hdr`)")
    } else if depth_tex.sample_count() != 1 {
        Some("MSAA is on (use `Msaa::Off`)")
    } else if !depth_tex
        .usage()
        .contains(wgpu::TextureUsages::TEXTURE_BINDING)
    {
        Some("the depth buffer cannot be read (Camera3d::depth_texture_usages)")
    } else if clip_from_view.w_axis.w != 0.0 {
        Some("the projection is not perspective")
    } else if (extracted.viewport.z, extracted.viewport.w) != (main.width(), main.height()) {
        // The mark pass and the focal length take the whole texture as the view.
        Some("the camera draws into a viewport, not its whole target")
    } else {
        None
    };
    if let Some(reason) = unsupported {
        if state.warned.insert(entity) {
            log::warn!("subsurface: camera {entity} is skipped: {reason}");
        }
        return;
    }
    let size = (main.width(), main.height());
    let device_ref: &wgpu::Device = device.wgpu_device();
    let state = &mut *state;
    let frame = u64::from(frame_count.0);
    let queue: &wgpu::Queue = &queue;
    let mark = state.mark.get_or_insert_with(|| mark_pipelines(device_ref));
    let transmit_pipelines = state
        .transmit
        .get_or_insert_with(|| transmit::Pipelines::new(device_ref));
    let cache = state.cache.get_or_insert_with(MaterialCache::default);

    let key: ViewSssKey = (
        target.main_texture().id(),
        depth_buffer.texture().id(),
        size,
        sub.quality,
        media.rows.len(),
        sub.transmittance,
        sub.units_per_mm.to_bits(),
    );
    let slot = (entity, key.0);
    if state.views.get(&slot).is_none_or(|v| v.key != key) {
        match build_view(
            device_ref,
            queue,
            mark,
            transmit_pipelines,
            cache,
            key,
            main,
            depth_tex,
            sub,
            &media,
        ) {
            Ok(v) => {
                log::debug!(
                    "subsurface: camera {entity} bound to main texture {:?}, {}x{}, {} rows",
                    key.0,
                    size.0,
                    size.1,
                    key.4
                );
                state.views.insert(slot, v);
            }
            Err(e) => {
                // Not retried every frame: the same inputs would fail the same way.
                log::error!("subsurface: {e}; scattering is off");
                state.failed = true;
                return;
            }
        }
    }
    // Forget cameras and main textures not drawn for 8 frames (their targets are large).
    state
        .views
        .retain(|k, v| *k == slot || frame.saturating_sub(v.last_frame) < 8);
    let Some(v) = state.views.get_mut(&slot) else {
        return;
    };
    v.last_frame = frame;

    let mut scale = [[0.0f32; 4]; MAX_ROWS / 4];
    let mut albedo = [[0.0f32; 4]; MAX_ROWS];
    for (i, row) in media.rows.iter().enumerate() {
        scale[i / 4][i % 4] = sub.units_per_mm * row.width;
        albedo[i] = [row.albedo[0], row.albedo[1], row.albedo[2], 1.0];
    }
    let world_from_view = extracted.world_from_view.to_matrix();
    let uniform = MarkUniform {
        view_from_clip: clip_from_view.inverse().to_cols_array_2d(),
        world_from_view: world_from_view.to_cols_array_2d(),
        size: [size.0 as f32, size.1 as f32],
        rows: media.rows.len() as u32,
        _pad: 0,
        scale,
        albedo,
    };
    queue.write_buffer(&v.mark_uniform, 0, bytemuck::bytes_of(&uniform));
    // Focal length in pixels: clip_from_view's y scale is 1 / tan(fov_y / 2).
    let focal_px = 0.5 * size.1 as f32 * clip_from_view.y_axis.y;
    v.pass.prepare(queue, focal_px);
    // The camera's shadow-casting directional lights, in the layers of Bevy's texture, then
    // the shadow-casting spot and point lights.
    let skin_box = bounds.and_then(|b| b.0);
    let lights = match (&v.transmit, light_entities, shadow_bindings, skin_box) {
        (Some(_), Some(views), Some(bindings), Some(skin_box)) => {
            let widest = media.rows.iter().map(|r| r.width).fold(0.0, f32::max);
            let reach = Reach {
                skin_box,
                margin: transmit::MARGIN_MM * sub.units_per_mm * widest,
                size: bindings.directional_light_depth_texture.width(),
                exposure: camera.map_or(1.0, |c| c.exposure),
            };
            let mut lights =
                shadow_lights::directional(entity, views, &light_views, &directional, &reach);
            lights.extend(shadow_lights::spot_and_point(
                &shadow_views,
                &point_lights,
                &reach,
            ));
            lights
        }
        _ => Vec::new(),
    };
    let clip_from_world = clip_from_view * world_from_view.inverse();

    // The step's GPU time, as Bevy's render diagnostics report every pass's
    // (`render/subsurface/elapsed_gpu` with `RenderDiagnosticsPlugin`; nothing without it).
    let diagnostics = ctx.diagnostic_recorder();
    let diagnostics = diagnostics.as_deref();
    let encoder = ctx.command_encoder();
    let span = diagnostics.time_span(encoder, "subsurface");
    {
        let attach =
            |view| util::color_attachment(view, wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT));
        let mut targets = vec![attach(&v.targets[0]), attach(&v.targets[1])];
        if let Some(t) = &v.transmit {
            targets.extend([attach(&t.normal), attach(&t.albedo)]);
        }
        let mut pass = util::color_pass(encoder, "subsurface mark", &targets, None);
        pass.set_pipeline(&mark[usize::from(v.transmit.is_some())]);
        pass.set_bind_group(0, &v.mark_bind_group, &[]);
        pass.draw(0..3, 0..1);
    }
    // Transmitted light joins the diffuse light before the blur; its unscattered part is
    // added after it. Without a shadow-casting light there is nothing to
    // add.
    let transmitting = match (&mut v.transmit, shadow_bindings) {
        (Some(t), Some(bindings)) if !lights.is_empty() => {
            let forward = world_from_view.transform_vector3(bevy::math::Vec3::NEG_Z);
            let frame = transmit::Frame {
                camera: subsurface_render::uniforms::CameraUniform {
                    view_proj: clip_from_world.to_cols_array_2d(),
                    position: world_from_view.w_axis.truncate().to_array(),
                    near: clip_from_view.w_axis.z,
                    forward: forward.normalize().to_array(),
                    // Bevy's perspective has no far plane.
                    far: f32::MAX,
                    focal_px,
                    viewport: [size.0 as f32, size.1 as f32],
                    _pad: 0.0,
                },
                clip_from_world,
                lights: &lights,
                bevy_shadows: &bindings.directional_light_depth_texture,
                depth: &v.targets[0],
                sss: &v.targets[1],
                units_per_mm: sub.units_per_mm,
            };
            t.encode(device_ref, queue, transmit_pipelines, encoder, &frame);
            true
        }
        _ => false,
    };
    v.pass.encode(encoder, None);
    if let (true, Some(t)) = (transmitting, &v.transmit) {
        t.add_unscattered(transmit_pipelines, encoder);
    }
    span.end(encoder);
}
