//! The transmitted light pass: transmittance through thin parts for a renderer that is not
//! ours. Our lighting pass evaluates it per fragment ([`crate::passes::lighting`]); this pass
//! evaluates the same WGSL (`transmittance` in transmittance.wgsl, every method but the
//! translucent shadow maps) per pixel of a caller's G-buffer and adds it to the caller's
//! diffuse target, before the SSS blur ([`crate::passes::sss::SssPass`]), and `diffusion`'s
//! unscattered part to its specular target.
//!
//! Inputs, all the caller's:
//! - group 0, [`crate::passes::lighting::frame_bind_group`]: the camera and the lights
//!   (`CameraUniform`, `LightsUniform`), its shadow maps' z-buffer, and the skin's shadow maps
//!   made from it by [`crate::passes::shadow_entry::ShadowEntryPass`];
//! - group 1, one [`SkinMedium`] per row of the SSS profile table: the medium's optics and T(s)
//!   tables;
//! - group 2, [`SkinGBuffer`]: linear depth, the vertex normal, the albedo and the SSS
//!   pass's per-pixel medium row.
//!
//! With `bounce.ring > 0` the pass also adds the bounce, the light the lit surfaces around
//! send across the air, gathered per pixel from a [`crate::passes::bounce::FluxPyramid`] built
//! on the skin's shadow maps (given to group 0 as [`crate::passes::lighting::ShadowMaps::flux`];
//! the `LightsUniform`'s `bounce_ring` and `bounce_cell_mm` set). `diffusion`'s lateral taps
//! run per pixel here too (the transmitted map, a lower-rate evaluation, is our renderer's).

use glam::Mat4;
use wgpu::util::DeviceExt;

use crate::error::RenderError;
use crate::gpu::GpuContext;
use crate::gpu::object::object_layout;
use crate::material::MaterialOptics;
use crate::passes::lighting::{self, RADIANCE_FORMAT};
use crate::passes::overrides::{
    BOUNCE_SOURCE, DIFFUSION_TERMS, LATERAL_SOURCE, TRANSMITTANCE_METHOD, Terms, bounce, lateral,
};
use crate::passes::{fullscreen, transmittance, util};
use crate::settings::{RenderSettings, TransmittanceMethod};
use crate::timing::TimedPass;
use crate::uniforms::ObjectUniform;

/// The pass's WGSL: the lighting shader's files and transmitted_light.wgsl.
pub const SHADER: &str = lighting_shader!(
    include_str!("../fullscreen.wgsl"),
    include_str!("transmitted_light.wgsl")
);

/// The caller's G-buffer, one texel per pixel of the frame, all readable as unfilterable
/// floats (`R32Float`, `Rgba16Float`, `Rgba32Float`, ...).
#[derive(Clone, Copy)]
pub struct SkinGBuffer<'a> {
    /// Linear view depth in scene units, measured along the camera's forward axis
    /// (`CameraUniform::forward`), as [`crate::passes::sss::SssInputs::depth`].
    pub depth: &'a wgpu::TextureView,
    /// xyz: the interpolated vertex normal in world space, turned toward the camera (not the
    /// normal-mapped one: thickness and the light's way out follow the geometry).
    pub normal: &'a wgpu::TextureView,
    /// rgb: the linear albedo the diffuse light is multiplied by.
    pub albedo: &'a wgpu::TextureView,
    /// The SSS pass's per-pixel input ([`crate::passes::sss::SssInputs::sss`]): strength (0 =
    /// not skin), scene units per profile millimetre, profile row.
    pub medium: &'a wgpu::TextureView,
}

/// One medium's group 1: its [`ObjectUniform`] (optics, boundary, scale) and T(s) tables.
pub struct SkinMedium {
    /// Group 1 of the pass: the uniform and the medium's T(s) tables.
    pub bind_group: wgpu::BindGroup,
    /// The medium's [`ObjectUniform`].
    pub uniform: wgpu::Buffer,
}

impl SkinMedium {
    /// `uniform.profile` is the medium's row in the SSS profile table: the pixels whose
    /// [`SkinGBuffer::medium`] names that row take this medium. `uniform.lut_range_mm` is
    /// set here, from the tables made of `optics`
    /// ([`crate::gpu_scene::object_uniform`] fills the rest from a scene object).
    pub fn new(
        ctx: &GpuContext,
        optics: &MaterialOptics,
        uniform: ObjectUniform,
    ) -> Result<Self, RenderError> {
        Self::on_device(&ctx.device, &ctx.queue, optics, uniform)
    }

    /// [`Self::new`] on a bare device and queue (an engine's, e.g. Bevy's render device).
    pub fn on_device(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        optics: &MaterialOptics,
        uniform: ObjectUniform,
    ) -> Result<Self, RenderError> {
        let (lut, range) = transmittance::lut_texture_on(device, queue, optics)?;
        let uniform = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("skin medium"),
            contents: bytemuck::bytes_of(&ObjectUniform {
                lut_range_mm: range,
                ..uniform
            }),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        });
        // The material maps of group 1 belong to the lighting pass; this pass never reads them.
        let unused = util::dummy_view(
            device,
            "skin medium (no maps)",
            wgpu::TextureFormat::Rgba8Unorm,
            wgpu::TextureUsages::TEXTURE_BINDING,
        );
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("transmittance lut"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            ..Default::default()
        });
        let view = wgpu::BindingResource::TextureView;
        let bind_group = util::bind_group(
            device,
            "skin medium",
            &object_layout(device),
            [
                (0, uniform.as_entire_binding()),
                (1, view(&unused)),
                (2, view(&unused)),
                (3, view(&unused)),
                (4, wgpu::BindingResource::Sampler(&sampler)),
                (5, view(&lut)),
                (6, wgpu::BindingResource::Sampler(&sampler)),
            ],
        );
        Ok(Self {
            bind_group,
            uniform,
        })
    }
}

/// Group 2 of [`TransmittedLightPass`]: the caller's G-buffer and the camera's inverse
/// view-projection, which unprojects each pixel's depth.
pub struct GBufferGroup {
    /// The bind group [`TransmittedLightPass::encode`] takes.
    pub bind_group: wgpu::BindGroup,
    view: wgpu::Buffer,
}

impl GBufferGroup {
    /// The camera moved: its new view-projection (`CameraUniform`'s), written in place.
    pub fn set_view_proj(&self, queue: &wgpu::Queue, view_proj: Mat4) {
        queue.write_buffer(
            &self.view,
            0,
            bytemuck::cast_slice(&view_proj.inverse().to_cols_array()),
        );
    }
}

/// Adds transmitted light to a caller's targets (see the module's documentation).
pub struct TransmittedLightPass {
    pipeline: wgpu::RenderPipeline,
    frame_layout: wgpu::BindGroupLayout,
    gbuffer_layout: wgpu::BindGroupLayout,
    method: TransmittanceMethod,
    bounce: bool,
}

impl TransmittedLightPass {
    /// The pass for `settings`' transmittance (method, lateral taps, terms) and bounce (on where
    /// `bounce.ring > 0`), drawing into `RADIANCE_FORMAT` (`Rgba16Float`) diffuse and specular
    /// targets.
    pub fn new(device: &wgpu::Device, settings: &RenderSettings) -> Self {
        let t = &settings.transmittance;
        let module = util::wgsl_module(device, "transmitted_light.wgsl", SHADER);
        let frame_layout = lighting::frame_layout(device);
        let texture = |binding| {
            util::float_texture_entry(
                binding,
                wgpu::ShaderStages::FRAGMENT,
                false,
                wgpu::TextureViewDimension::D2,
            )
        };
        let gbuffer_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("skin g-buffer"),
            entries: &[
                util::uniform_entry(16, wgpu::ShaderStages::FRAGMENT),
                texture(17),
                texture(18),
                texture(19),
                texture(20),
            ],
        });
        let layout = util::pipeline_layout(
            device,
            "transmitted light",
            &[&frame_layout, &object_layout(device), &gbuffer_layout],
        );
        // Taps per pixel (2), or none where `diffusion` has none or another method runs (0).
        let taps = t.method == TransmittanceMethod::Diffusion && t.lateral_taps > 0;
        let constants = [
            (TRANSMITTANCE_METHOD, f64::from(t.method.code())),
            (
                LATERAL_SOURCE,
                f64::from(if taps { lateral::TAPS } else { lateral::NONE }),
            ),
            (DIFFUSION_TERMS, f64::from(Terms::of(settings).0)),
            (
                BOUNCE_SOURCE,
                f64::from(if settings.bounce.enabled() {
                    bounce::GATHER
                } else {
                    bounce::NONE
                }),
            ),
        ];
        let target = Some(util::additive_target(RADIANCE_FORMAT));
        let pipeline = fullscreen::pipeline_with(
            device,
            &module,
            Some(&layout),
            "fs_deferred_transmitted",
            &[target.clone(), target],
            &constants,
            None,
        );
        Self {
            pipeline,
            frame_layout,
            gbuffer_layout,
            method: t.method,
            bounce: settings.bounce.enabled(),
        }
    }

    /// The layout of group 0, for [`crate::passes::lighting::frame_bind_group`].
    pub fn frame_layout(&self) -> &wgpu::BindGroupLayout {
        &self.frame_layout
    }

    /// Group 2 from the caller's G-buffer; `view_proj` is the camera's (`CameraUniform`'s).
    /// Made once per set of G-buffer textures: a moving camera only needs
    /// [`GBufferGroup::set_view_proj`].
    pub fn bind_gbuffer(
        &self,
        device: &wgpu::Device,
        gbuffer: &SkinGBuffer<'_>,
        view_proj: Mat4,
    ) -> GBufferGroup {
        let view = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("skin view"),
            contents: bytemuck::cast_slice(&view_proj.inverse().to_cols_array()),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        });
        let texture = wgpu::BindingResource::TextureView;
        let bind_group = util::bind_group(
            device,
            "skin g-buffer",
            &self.gbuffer_layout,
            [
                (16, view.as_entire_binding()),
                (17, texture(gbuffer.depth)),
                (18, texture(gbuffer.normal)),
                (19, texture(gbuffer.albedo)),
                (20, texture(gbuffer.medium)),
            ],
        );
        GBufferGroup { bind_group, view }
    }

    /// Adds the transmitted light (and the bounce) of every medium into `diffuse` and
    /// `specular` (both `RADIANCE_FORMAT`, loaded and stored). Nothing is drawn without a
    /// bounce for `off` and for translucent shadow maps, which need texture-space diffusion.
    pub fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        frame: &wgpu::BindGroup,
        gbuffer: &wgpu::BindGroup,
        media: &[SkinMedium],
        [diffuse, specular]: [&wgpu::TextureView; 2],
        profiler: Option<&wgpu_profiler::GpuProfiler>,
    ) {
        if !self.bounce
            && matches!(
                self.method,
                TransmittanceMethod::Off | TransmittanceMethod::Tsm
            )
        {
            return;
        }
        let timer = TimedPass::begin(profiler, "transmitted light", encoder);
        {
            let load = |v| util::color_attachment(v, wgpu::LoadOp::Load);
            let mut pass = util::render_pass(
                encoder,
                "transmitted light",
                &[load(diffuse), load(specular)],
                None,
                timer.writes(),
            );
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, frame, &[]);
            pass.set_bind_group(2, gbuffer, &[]);
            for medium in media {
                pass.set_bind_group(1, &medium.bind_group, &[]);
                pass.draw(0..3, 0..1);
            }
        }
        timer.end(profiler, encoder);
    }
}
