//! The lighting pass: Lambert diffuse with albedo, the rough boundary's specular (Cook-Torrance
//! with Beckmann facets and Smith masking, `subsurface_profile::specular`), normal
//! maps, spot falloff, inverse-square attenuation and shadows filtered by percentage-closer
//! gathers on the shadow maps' z-buffer (linear light distance stays for thickness). A depth
//! pre-pass first keeps the nearest surface, so the shader runs once per pixel. It writes
//! diffuse and specular apart (only diffuse is blurred by subsurface scattering), linear depth
//! and the per-pixel SSS strength.
//!
//! Group 0 (camera, lights, shadow maps, translucent shadow maps) is built by [`frame_layout`];
//! group 1 is the object's (`gpu_scene::object_layout`), group 2 the object's texture-space
//! maps ([`maps::maps_layout`]). The texture-space pass draws its UV-space irradiance with the
//! same three groups (`texture_space::irradiance`); this module knows nothing of it.

use wgpu::util::DeviceExt;

use crate::gpu::GpuContext;
use crate::gpu_scene::GpuObject;
use crate::passes::maps;
use crate::passes::util;
use crate::timing::TimedPass;
use crate::uniforms::{CameraUniform, LightsUniform};

pub const SHADER: &str = concat!(
    include_str!("common.wgsl"),
    include_str!("lighting.wgsl"),
    include_str!("shadow_lookup.wgsl"),
    include_str!("transmittance.wgsl")
);
pub const RADIANCE_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
pub const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Float;
/// r = SSS strength, g = scene units per profile millimetre, b = profile index (exact in f16
/// up to 2048), a unused. Half floats keep the four targets within the 32 bytes per sample
/// every adapter allows.
pub const SSS_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;

/// What the lighting pass writes, and what screen-space SSS reads.
pub struct LightingTargets {
    pub width: u32,
    pub height: u32,
    /// Diffuse radiance (irradiance x albedo), linear HDR: the image that is blurred.
    pub diffuse: wgpu::Texture,
    /// Specular radiance, linear HDR: added after the blur.
    pub specular: wgpu::Texture,
    /// Linear view depth in scene units (the camera's far plane where nothing was drawn).
    pub depth: wgpu::Texture,
    /// r = SSS strength (0 = not skin), g = scene units per profile millimetre.
    pub sss: wgpu::Texture,
    zbuffer: wgpu::TextureView,
}

impl LightingTargets {
    pub fn new(ctx: &GpuContext, width: u32, height: u32) -> Self {
        let device = &ctx.device;
        let target = |label, format| util::render_target(device, label, width, height, format);
        Self {
            width,
            height,
            // Storage too where the adapter can: the workgroup fetch's vertical SSS pass
            // writes it from a compute shader.
            diffuse: util::render_target_with(
                device,
                "diffuse",
                width,
                height,
                RADIANCE_FORMAT,
                if util::supports_compute_storage(device) {
                    wgpu::TextureUsages::STORAGE_BINDING
                } else {
                    wgpu::TextureUsages::empty()
                },
            ),
            specular: target("specular", RADIANCE_FORMAT),
            depth: target("linear depth", DEPTH_FORMAT),
            sss: target("sss strength", SSS_FORMAT),
            zbuffer: util::depth_buffer(device, "z-buffer", width, height),
        }
    }
}

/// Layout of group 0 of the lighting pass (`camera`, `lights`, `shadow_atlas`, `tsm_atlas`,
/// `shadow_depth` and `shadow_compare` in lighting.wgsl). Equal layouts are interchangeable,
/// so other pipelines built on the lighting shader (the texture-space irradiance) may bind
/// [`LightingPass::frame_bind_group`].
pub fn frame_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    let uniform = |binding| util::uniform_entry(binding, wgpu::ShaderStages::VERTEX_FRAGMENT);
    // Shadow and translucent shadow map arrays: 32-bit floats, so not filterable.
    let atlas = |binding| {
        util::float_texture_entry(
            binding,
            wgpu::ShaderStages::FRAGMENT,
            false,
            wgpu::TextureViewDimension::D2Array,
        )
    };
    // The shadow maps' z-buffer, read through a comparison sampler: each gather tests a 2x2
    // block of texels in the texture unit (hardware PCF).
    let depth = wgpu::BindGroupLayoutEntry {
        binding: 4,
        visibility: wgpu::ShaderStages::FRAGMENT,
        ty: wgpu::BindingType::Texture {
            sample_type: wgpu::TextureSampleType::Depth,
            view_dimension: wgpu::TextureViewDimension::D2Array,
            multisampled: false,
        },
        count: None,
    };
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("lighting frame"),
        entries: &[
            uniform(0),
            uniform(1),
            atlas(2),
            atlas(3),
            depth,
            util::sampler_entry(
                5,
                wgpu::ShaderStages::FRAGMENT,
                wgpu::SamplerBindingType::Comparison,
            ),
        ],
    })
}

/// The shadow maps the lighting pass reads ([`crate::passes::shadow::ShadowPass::maps`]).
#[derive(Clone, Copy)]
pub struct ShadowMaps<'a> {
    /// Linear light distance and entry normal per texel (`Rg32Float` array): thickness.
    pub atlas: &'a wgpu::TextureView,
    /// The same layers' z-buffer (`Depth32Float` array): percentage-closer filtering through
    /// a comparison sampler.
    pub depth: &'a wgpu::TextureView,
}

pub struct LightingPass {
    /// Depth only, the lighting shader's vertex stage: the nearest surface per pixel.
    prepass: wgpu::RenderPipeline,
    pipeline: wgpu::RenderPipeline,
    frame_bind_group: wgpu::BindGroup,
    /// Group 2 for objects without texture-space maps.
    default_maps: wgpu::BindGroup,
    pub camera: wgpu::Buffer,
    pub lights: wgpu::Buffer,
}

impl LightingPass {
    /// Without texture-space maps or translucent shadow maps.
    pub fn new(
        ctx: &GpuContext,
        object_layout: &wgpu::BindGroupLayout,
        camera: &CameraUniform,
        lights: &LightsUniform,
        shadow: ShadowMaps<'_>,
    ) -> Self {
        let maps_layout = maps::maps_layout(&ctx.device);
        let tsm = maps::dummy_tsm_view(&ctx.device);
        Self::with_maps(
            ctx,
            object_layout,
            &maps_layout,
            camera,
            lights,
            shadow,
            &tsm,
        )
    }

    /// `maps_layout` is [`maps::maps_layout`] (group 2, per object); `tsm_atlas` the
    /// translucent shadow maps (`Rg32Float` array, same layers as the shadow maps).
    pub fn with_maps(
        ctx: &GpuContext,
        object_layout: &wgpu::BindGroupLayout,
        maps_layout: &wgpu::BindGroupLayout,
        camera: &CameraUniform,
        lights: &LightsUniform,
        shadow: ShadowMaps<'_>,
        tsm_atlas: &wgpu::TextureView,
    ) -> Self {
        let device = &ctx.device;
        let shadow_compare = device.create_sampler(&wgpu::SamplerDescriptor {
            label: Some("shadow compare"),
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            // Lit where the receiver's biased depth is at most the occluder's.
            compare: Some(wgpu::CompareFunction::LessEqual),
            ..Default::default()
        });
        let module = util::wgsl_module(device, "lighting.wgsl", SHADER);
        let frame_layout = frame_layout(device);
        let camera = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("camera"),
            contents: bytemuck::bytes_of(camera),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        });
        let lights = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("lights"),
            contents: bytemuck::bytes_of(lights),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        });
        let frame_bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("lighting frame"),
            layout: &frame_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: camera.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: lights.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::TextureView(shadow.atlas),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: wgpu::BindingResource::TextureView(tsm_atlas),
                },
                wgpu::BindGroupEntry {
                    binding: 4,
                    resource: wgpu::BindingResource::TextureView(shadow.depth),
                },
                wgpu::BindGroupEntry {
                    binding: 5,
                    resource: wgpu::BindingResource::Sampler(&shadow_compare),
                },
            ],
        });
        let layout = util::pipeline_layout(
            device,
            "lighting",
            &[&frame_layout, object_layout, maps_layout],
        );
        let pipeline = util::MeshPipeline {
            label: "lighting",
            layout: &layout,
            module: &module,
            vertex: "vs_main",
            fragment: "fs_main",
            targets: &[RADIANCE_FORMAT, RADIANCE_FORMAT, DEPTH_FORMAT, SSS_FORMAT],
            // Not culled: glTF skin meshes are often open (wrists, necks) and the shader flips
            // the normal of back faces.
            cull_mode: None,
            depth: util::DepthTest::Prepassed,
        }
        .create(device);
        // Meshes drawn without culling in any order would shade every surface a pixel covers
        // that lands before the nearest one (the back of a head, the far side of a hand): a
        // depth-only pass first leaves the lighting shader one fragment per pixel.
        let prepass = util::depth_prepass_pipeline(device, &layout, &module, "vs_main");
        let default_maps = maps::default_maps_bind_group(device, maps_layout);
        Self {
            prepass,
            pipeline,
            default_maps,
            frame_bind_group,
            camera,
            lights,
        }
    }

    /// Group 0 (see [`frame_layout`]): camera, lights, shadow maps, translucent shadow maps.
    pub fn frame_bind_group(&self) -> &wgpu::BindGroup {
        &self.frame_bind_group
    }

    /// Writes the per-frame uniforms (the camera and the lights).
    pub fn prepare(&self, queue: &wgpu::Queue, camera: &CameraUniform, lights: &LightsUniform) {
        queue.write_buffer(&self.camera, 0, bytemuck::bytes_of(camera));
        queue.write_buffer(&self.lights, 0, bytemuck::bytes_of(lights));
    }

    /// Draws every object with `pipeline` and the pass's groups (the depth pre-pass and the
    /// lighting pass bind the same ones).
    fn draw_objects(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        pipeline: &wgpu::RenderPipeline,
        objects: &[GpuObject],
        maps: &[wgpu::BindGroup],
    ) {
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, &self.frame_bind_group, &[]);
        for (i, o) in objects.iter().enumerate() {
            pass.set_bind_group(2, maps.get(i).unwrap_or(&self.default_maps), &[]);
            o.draw(pass);
        }
    }

    pub fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        targets: &LightingTargets,
        objects: &[GpuObject],
        background: [f32; 3],
        far: f32,
        profiler: Option<&wgpu_profiler::GpuProfiler>,
    ) {
        self.encode_with_maps(encoder, targets, objects, &[], background, far, profiler);
    }

    /// As `encode`, with each object's texture-space bind group (`maps[i]` for `objects[i]`;
    /// objects beyond `maps` are lit plainly).
    #[allow(clippy::too_many_arguments)]
    pub fn encode_with_maps(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        targets: &LightingTargets,
        objects: &[GpuObject],
        maps: &[wgpu::BindGroup],
        background: [f32; 3],
        far: f32,
        profiler: Option<&wgpu_profiler::GpuProfiler>,
    ) {
        let view = |t: &wgpu::Texture| t.create_view(&Default::default());
        let (diffuse, specular, depth, sss) = (
            view(&targets.diffuse),
            view(&targets.specular),
            view(&targets.depth),
            view(&targets.sss),
        );
        let attach = |v, c| util::color_attachment(v, wgpu::LoadOp::Clear(c));
        let bg = wgpu::Color {
            r: background[0] as f64,
            g: background[1] as f64,
            b: background[2] as f64,
            a: 1.0,
        };
        let timer = TimedPass::begin(profiler, "depth prepass", encoder);
        {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("depth prepass"),
                color_attachments: &[],
                depth_stencil_attachment: util::depth_attachment(
                    &targets.zbuffer,
                    wgpu::LoadOp::Clear(1.0),
                    wgpu::StoreOp::Store,
                ),
                timestamp_writes: timer.writes(),
                occlusion_query_set: None,
                multiview_mask: None,
            });
            self.draw_objects(&mut pass, &self.prepass, objects, maps);
        }
        timer.end(profiler, encoder);
        let timer = TimedPass::begin(profiler, "lighting", encoder);
        {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("lighting"),
                color_attachments: &[
                    attach(&diffuse, bg),
                    attach(&specular, wgpu::Color::TRANSPARENT),
                    attach(
                        &depth,
                        wgpu::Color {
                            r: far as f64,
                            g: 0.0,
                            b: 0.0,
                            a: 0.0,
                        },
                    ),
                    attach(&sss, wgpu::Color::TRANSPARENT),
                ],
                depth_stencil_attachment: util::depth_attachment(
                    &targets.zbuffer,
                    wgpu::LoadOp::Load,
                    wgpu::StoreOp::Discard,
                ),
                timestamp_writes: timer.writes(),
                occlusion_query_set: None,
                multiview_mask: None,
            });
            self.draw_objects(&mut pass, &self.pipeline, objects, maps);
        }
        timer.end(profiler, encoder);
    }
}
