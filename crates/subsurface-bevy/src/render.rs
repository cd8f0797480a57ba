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
use bevy::platform::collections::HashMap;
use bevy::render::RenderApp;
use bevy::render::renderer::{RenderContext, RenderDevice, RenderQueue, ViewQuery};
use bevy::render::view::{ExtractedView, ViewDepthStencilTexture, ViewTarget};
use subsurface_profile::KernelParams;
use subsurface_render::material::{MaterialCache, screen_kernels};
use subsurface_render::passes::sss::{SssInputs, SssPass};
use subsurface_render::passes::{fullscreen, sss, util};
use subsurface_render::scene::MaterialDesc;
use subsurface_render::{RenderSettings, SssFetch, SssSettings};

use crate::material::{MAX_ROWS, SkinMedia};
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
    size: [f32; 2],
    rows: u32,
    _pad: u32,
    scale: [[f32; 4]; MAX_ROWS / 4],
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
        let medium = subsurface_profile::Medium::Preset(row.medium.clone());
        let optics = cache.get(&medium, "skin.medium")?;
        let desc = MaterialDesc {
            medium,
            ..Default::default()
        };
        rows.push(
            screen_kernels(&optics, &desc, settings.samples)
                .map_err(|e| SubsurfaceError::Medium(row.medium.clone(), e.to_string()))?,
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
    last_frame: u64,
}

/// The marker pipeline (shared) and each camera's state. Bevy swaps a camera's two main
/// textures between frames when post-processing writes one into the other, so a camera
/// may hold one state per main texture.
#[derive(Resource, Default)]
pub struct SubsurfaceViews {
    mark: Option<wgpu::RenderPipeline>,
    views: HashMap<(Entity, bevy::render::render_resource::TextureId), ViewSss>,
    cache: Option<MaterialCache>,
    /// Cameras already told why they are skipped (once each).
    warned: bevy::platform::collections::HashSet<Entity>,
    failed: bool,
}

fn mark_pipeline(device: &wgpu::Device) -> wgpu::RenderPipeline {
    let source = format!("{}{MARK_WGSL}", fullscreen::VERTEX_WGSL);
    let module = util::wgsl_module(device, "subsurface mark", &source);
    fullscreen::pipeline(
        device,
        &module,
        None, // layout derived from the shader: uniform, colour, depth
        "fs_mark",
        &[
            Some(wgpu::TextureFormat::R32Float.into()),
            Some(sss::FORMAT.into()),
        ],
    )
}

#[allow(clippy::too_many_arguments)]
fn build_view(
    device: &wgpu::Device,
    mark: &wgpu::RenderPipeline,
    cache: &mut MaterialCache,
    key: ViewSssKey,
    main: &wgpu::Texture,
    depth_buffer: &wgpu::Texture,
    sub: &Subsurface,
    media: &SkinMedia,
) -> Result<ViewSss, SubsurfaceError> {
    let (w, h) = key.2;
    let target = |label, format| {
        util::texture_2d(
            device,
            label,
            w,
            h,
            1,
            format,
            wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
        )
    };
    let depth = target("subsurface linear depth", wgpu::TextureFormat::R32Float);
    let sss_tex = target("subsurface skin", sss::FORMAT);
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
        last_frame: 0,
    })
}

/// What a camera's targets and passes were built for: main texture, depth texture, size,
/// quality, rows of the profile table.
type ViewSssKey = (
    bevy::render::render_resource::TextureId,
    bevy::render::render_resource::TextureId,
    (u32, u32),
    crate::Quality,
    usize,
);

/// The step itself (a system of the camera's `Core3d` schedule; Bevy runs it once per
/// camera with that camera as the `ViewQuery`'s entity).
#[allow(clippy::too_many_arguments)]
fn subsurface_pass(
    view: ViewQuery<(
        &ExtractedView,
        &ViewTarget,
        &ViewDepthStencilTexture,
        &Subsurface,
    )>,
    media: Option<Res<SkinMedia>>,
    mut state: ResMut<SubsurfaceViews>,
    device: Res<RenderDevice>,
    queue: Res<RenderQueue>,
    frame_count: Res<FrameCount>,
    mut ctx: RenderContext,
) {
    let entity = view.entity();
    let (extracted, target, depth_buffer, sub) = view.into_inner();
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
    let mark = state.mark.get_or_insert_with(|| mark_pipeline(device_ref));
    let cache = state.cache.get_or_insert_with(MaterialCache::default);

    let key: ViewSssKey = (
        target.main_texture().id(),
        depth_buffer.texture().id(),
        size,
        sub.quality,
        media.rows.len(),
    );
    let slot = (entity, key.0);
    if state.views.get(&slot).is_none_or(|v| v.key != key) {
        match build_view(device_ref, mark, cache, key, main, depth_tex, sub, &media) {
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
    for (i, row) in media.rows.iter().enumerate() {
        scale[i / 4][i % 4] = sub.units_per_mm * row.width;
    }
    let uniform = MarkUniform {
        view_from_clip: clip_from_view.inverse().to_cols_array_2d(),
        size: [size.0 as f32, size.1 as f32],
        rows: media.rows.len() as u32,
        _pad: 0,
        scale,
    };
    let queue: &wgpu::Queue = &queue;
    queue.write_buffer(&v.mark_uniform, 0, bytemuck::bytes_of(&uniform));
    // Focal length in pixels: clip_from_view's y scale is 1 / tan(fov_y / 2).
    v.pass
        .prepare(queue, 0.5 * size.1 as f32 * clip_from_view.y_axis.y);

    let encoder = ctx.command_encoder();
    {
        let attach =
            |view| util::color_attachment(view, wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT));
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("subsurface mark"),
            color_attachments: &[attach(&v.targets[0]), attach(&v.targets[1])],
            depth_stencil_attachment: None,
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(mark);
        pass.set_bind_group(0, &v.mark_bind_group, &[]);
        pass.draw(0..3, 0..1);
    }
    v.pass.encode(encoder, None);
}
