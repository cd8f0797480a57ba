//! The lighting pass: Lambert diffuse with albedo, Kelemen/Szirmay-Kalos specular, normal
//! maps, spot falloff, inverse-square attenuation and PCF-filtered linear-depth shadows. It
//! writes diffuse and specular apart (only diffuse is blurred by subsurface scattering),
//! linear depth and the per-pixel SSS strength.

use wgpu::util::DeviceExt;

use crate::gpu::GpuContext;
use crate::gpu_scene::{GpuObject, VERTEX_LAYOUT};
use crate::passes::texture_space;
use crate::timing::TimedPass;
use crate::uniforms::{CameraUniform, LightsUniform};

pub const SHADER: &str = concat!(
    include_str!("common.wgsl"),
    include_str!("lighting.wgsl"),
    include_str!("transmittance.wgsl")
);
pub const RADIANCE_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
pub const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Float;
pub const SSS_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rg32Float;

fn target(
    ctx: &GpuContext,
    label: &str,
    w: u32,
    h: u32,
    format: wgpu::TextureFormat,
) -> wgpu::Texture {
    ctx.device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d {
            width: w,
            height: h,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT
            | wgpu::TextureUsages::TEXTURE_BINDING
            | wgpu::TextureUsages::COPY_SRC
            | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    })
}

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
        Self {
            width,
            height,
            diffuse: target(ctx, "diffuse", width, height, RADIANCE_FORMAT),
            specular: target(ctx, "specular", width, height, RADIANCE_FORMAT),
            depth: target(ctx, "linear depth", width, height, DEPTH_FORMAT),
            sss: target(ctx, "sss strength", width, height, SSS_FORMAT),
            zbuffer: ctx
                .device
                .create_texture(&wgpu::TextureDescriptor {
                    label: Some("z-buffer"),
                    size: wgpu::Extent3d {
                        width,
                        height,
                        depth_or_array_layers: 1,
                    },
                    mip_level_count: 1,
                    sample_count: 1,
                    dimension: wgpu::TextureDimension::D2,
                    format: wgpu::TextureFormat::Depth32Float,
                    usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
                    view_formats: &[],
                })
                .create_view(&Default::default()),
        }
    }
}

pub struct LightingPass {
    pipeline: wgpu::RenderPipeline,
    /// The same lighting with the mesh laid out by its uv (texture-space diffusion).
    irradiance_pipeline: wgpu::RenderPipeline,
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
        shadow_atlas: &wgpu::TextureView,
    ) -> Self {
        let maps_layout = texture_space::maps_layout(&ctx.device);
        let tsm = texture_space::dummy_tsm_view(&ctx.device);
        Self::with_maps(
            ctx,
            object_layout,
            &maps_layout,
            camera,
            lights,
            shadow_atlas,
            &tsm,
        )
    }

    /// `maps_layout` is [`texture_space::maps_layout`] (group 2, per object); `tsm_atlas` the
    /// translucent shadow maps (`Rg32Float` array, same layers as `shadow_atlas`).
    pub fn with_maps(
        ctx: &GpuContext,
        object_layout: &wgpu::BindGroupLayout,
        maps_layout: &wgpu::BindGroupLayout,
        camera: &CameraUniform,
        lights: &LightsUniform,
        shadow_atlas: &wgpu::TextureView,
        tsm_atlas: &wgpu::TextureView,
    ) -> Self {
        let device = &ctx.device;
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("lighting.wgsl"),
            source: wgpu::ShaderSource::Wgsl(SHADER.into()),
        });
        let uniform = |binding| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Uniform,
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        };
        let frame_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("lighting frame"),
            entries: &[
                uniform(0),
                uniform(1),
                wgpu::BindGroupLayoutEntry {
                    binding: 2,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Float { filterable: false },
                        view_dimension: wgpu::TextureViewDimension::D2Array,
                        multisampled: false,
                    },
                    count: None,
                },
                wgpu::BindGroupLayoutEntry {
                    binding: 3,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Texture {
                        sample_type: wgpu::TextureSampleType::Float { filterable: false },
                        view_dimension: wgpu::TextureViewDimension::D2Array,
                        multisampled: false,
                    },
                    count: None,
                },
            ],
        });
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
                    resource: wgpu::BindingResource::TextureView(shadow_atlas),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: wgpu::BindingResource::TextureView(tsm_atlas),
                },
            ],
        });
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("lighting"),
            bind_group_layouts: &[Some(&frame_layout), Some(object_layout), Some(maps_layout)],
            immediate_size: 0,
        });
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("lighting"),
            layout: Some(&layout),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs_main"),
                compilation_options: Default::default(),
                buffers: &[Some(VERTEX_LAYOUT)],
            },
            // Not culled: glTF skin meshes are often open (wrists, necks) and the shader flips
            // the normal of back faces.
            primitive: wgpu::PrimitiveState::default(),
            depth_stencil: Some(wgpu::DepthStencilState {
                format: wgpu::TextureFormat::Depth32Float,
                depth_write_enabled: Some(true),
                depth_compare: Some(wgpu::CompareFunction::Less),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("fs_main"),
                compilation_options: Default::default(),
                targets: &[
                    Some(RADIANCE_FORMAT.into()),
                    Some(RADIANCE_FORMAT.into()),
                    Some(DEPTH_FORMAT.into()),
                    Some(SSS_FORMAT.into()),
                ],
            }),
            multiview_mask: None,
            cache: None,
        });
        let uv_module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("texture_space.wgsl (irradiance)"),
            source: wgpu::ShaderSource::Wgsl(texture_space::SHADER.into()),
        });
        let irradiance_pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("texture-space irradiance"),
            layout: Some(&layout),
            vertex: wgpu::VertexState {
                module: &uv_module,
                entry_point: Some("vs_irradiance"),
                compilation_options: Default::default(),
                buffers: &[Some(VERTEX_LAYOUT)],
            },
            // UV islands may be laid out with either winding; no depth (one surface per texel).
            primitive: wgpu::PrimitiveState::default(),
            depth_stencil: None,
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &uv_module,
                entry_point: Some("fs_irradiance"),
                compilation_options: Default::default(),
                targets: &[
                    Some(texture_space::MAP_FORMAT.into()),
                    Some(texture_space::STRETCH_FORMAT.into()),
                ],
            }),
            multiview_mask: None,
            cache: None,
        });
        let default_maps = texture_space::default_maps_bind_group(device, maps_layout);
        Self {
            pipeline,
            irradiance_pipeline,
            default_maps,
            frame_bind_group,
            camera,
            lights,
        }
    }

    /// Draws one object into UV space with the texture-space irradiance pipeline (the caller
    /// begins the pass on the irradiance and stretch maps).
    pub fn draw_uv_irradiance(
        &self,
        pass: &mut wgpu::RenderPass<'_>,
        object: &GpuObject,
        maps: &wgpu::BindGroup,
    ) {
        pass.set_pipeline(&self.irradiance_pipeline);
        pass.set_bind_group(0, &self.frame_bind_group, &[]);
        pass.set_bind_group(2, maps, &[]);
        object.draw(pass);
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
        let clear = |c: wgpu::Color| wgpu::Operations {
            load: wgpu::LoadOp::Clear(c),
            store: wgpu::StoreOp::Store,
        };
        let attach = |v, c| {
            Some(wgpu::RenderPassColorAttachment {
                view: v,
                depth_slice: None,
                resolve_target: None,
                ops: clear(c),
            })
        };
        let bg = wgpu::Color {
            r: background[0] as f64,
            g: background[1] as f64,
            b: background[2] as f64,
            a: 1.0,
        };
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
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &targets.zbuffer,
                    depth_ops: Some(wgpu::Operations {
                        load: wgpu::LoadOp::Clear(1.0),
                        store: wgpu::StoreOp::Discard,
                    }),
                    stencil_ops: None,
                }),
                timestamp_writes: timer.writes(),
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, &self.frame_bind_group, &[]);
            for (i, o) in objects.iter().enumerate() {
                pass.set_bind_group(2, maps.get(i).unwrap_or(&self.default_maps), &[]);
                o.draw(&mut pass);
            }
        }
        timer.end(profiler, encoder);
    }
}
