//! Shadow maps that store linear light distance (scene units) in an R32Float array texture.
//! Jimenez et al. 2010 read thickness from exactly such standard maps, so transmittance needs
//! no extra shadow data.

use wgpu::util::DeviceExt;

use crate::error::RenderError;
use crate::gpu::GpuContext;
use crate::gpu_scene::{GpuObject, ShadowLayer};
use crate::passes::util;
use crate::timing::TimedPass;
use crate::uniforms::{ShadowViewUniform, mat, v4};

pub const SHADER: &str = concat!(include_str!("common.wgsl"), include_str!("shadow.wgsl"));
pub const FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Float;

pub struct ShadowPass {
    pipeline: wgpu::RenderPipeline,
    layers: Vec<(
        ShadowLayer,
        wgpu::BindGroup,
        wgpu::TextureView,
        wgpu::Buffer,
    )>,
    depth: wgpu::TextureView,
    /// All shadow maps: one layer per spot/directional light, six per point light.
    pub atlas: wgpu::Texture,
    pub atlas_view: wgpu::TextureView,
}

impl ShadowPass {
    pub fn new(
        ctx: &GpuContext,
        object_layout: &wgpu::BindGroupLayout,
        layers: &[ShadowLayer],
        atlas_size: u32,
        light_kinds: &[[f32; 4]],
    ) -> Result<Self, RenderError> {
        let device = &ctx.device;
        let limits = device.limits();
        if atlas_size > limits.max_texture_dimension_2d {
            return Err(RenderError::invalid(
                "lights.shadow_map_size",
                format!(
                    "{atlas_size} exceeds this device's limit {}",
                    limits.max_texture_dimension_2d
                ),
            ));
        }
        if layers.len() as u32 > limits.max_texture_array_layers {
            return Err(RenderError::invalid(
                "lights",
                format!(
                    "{} shadow layers exceed this device's limit {}",
                    layers.len(),
                    limits.max_texture_array_layers
                ),
            ));
        }
        let module = util::wgsl_module(device, "shadow.wgsl", SHADER);
        let view_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("shadow view"),
            entries: &[util::uniform_entry(0, wgpu::ShaderStages::VERTEX_FRAGMENT)],
        });
        let layout = util::pipeline_layout(device, "shadow", &[&view_layout, object_layout]);
        let pipeline = util::MeshPipeline {
            label: "shadow",
            layout: &layout,
            module: &module,
            vertex: "vs_main",
            fragment: "fs_main",
            targets: &[FORMAT],
            // No culling: thickness needs the surface nearest the light whichever way it faces.
            cull_mode: None,
            depth_test: true,
        }
        .create(device);
        let layer_count = layers.len().max(1) as u32;
        let size = atlas_size.max(1);
        let atlas = util::texture_2d(
            device,
            "shadow atlas",
            size,
            size,
            layer_count,
            FORMAT,
            wgpu::TextureUsages::RENDER_ATTACHMENT
                | wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::COPY_SRC,
        );
        let atlas_view = util::array_view(&atlas);
        let depth = util::depth_buffer(device, "shadow depth", size, size);
        let layers = layers
            .iter()
            .enumerate()
            .map(|(i, l)| {
                let u = view_uniform(l, light_kinds);
                let buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some("shadow view"),
                    contents: bytemuck::bytes_of(&u),
                    usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                });
                let bg = device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("shadow view"),
                    layout: &view_layout,
                    entries: &[wgpu::BindGroupEntry {
                        binding: 0,
                        resource: buffer.as_entire_binding(),
                    }],
                });
                let view = util::layer_view(&atlas, i as u32);
                (l.clone(), bg, view, buffer)
            })
            .collect();
        Ok(Self {
            pipeline,
            layers,
            depth,
            atlas,
            atlas_view,
        })
    }

    /// Moves the shadow cameras (same layers and sizes as at creation: the viewer moving a
    /// light). Changed sizes or light counts need a new `ShadowPass`.
    pub fn update_layers(
        &mut self,
        queue: &wgpu::Queue,
        layers: &[ShadowLayer],
        light_kinds: &[[f32; 4]],
    ) {
        for ((layer, _, _, buffer), new) in self.layers.iter_mut().zip(layers) {
            *layer = new.clone();
            queue.write_buffer(
                buffer,
                0,
                bytemuck::bytes_of(&view_uniform(new, light_kinds)),
            );
        }
    }

    /// Number of shadow-map layers rendered each frame.
    pub fn layer_count(&self) -> usize {
        self.layers.len()
    }

    /// Renders every shadow layer, each in its own timed render pass named "shadow".
    pub fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        objects: &[GpuObject],
        profiler: Option<&wgpu_profiler::GpuProfiler>,
    ) {
        for (layer, bind_group, view, _) in &self.layers {
            let timer = TimedPass::begin(profiler, "shadow", encoder);
            {
                let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: Some("shadow"),
                    // Empty texels read as infinitely far: nothing occludes there.
                    color_attachments: &[util::color_attachment(
                        view,
                        wgpu::LoadOp::Clear(wgpu::Color {
                            r: f32::MAX as f64,
                            g: 0.0,
                            b: 0.0,
                            a: 0.0,
                        }),
                    )],
                    depth_stencil_attachment: util::depth_attachment(&self.depth),
                    timestamp_writes: timer.writes(),
                    occlusion_query_set: None,
                    multiview_mask: None,
                });
                pass.set_viewport(0.0, 0.0, layer.size as f32, layer.size as f32, 0.0, 1.0);
                pass.set_scissor_rect(0, 0, layer.size, layer.size);
                pass.set_pipeline(&self.pipeline);
                pass.set_bind_group(0, bind_group, &[]);
                for o in objects {
                    o.draw(&mut pass);
                }
            }
            timer.end(profiler, encoder);
        }
    }
}

fn view_uniform(l: &ShadowLayer, light_kinds: &[[f32; 4]]) -> ShadowViewUniform {
    let kind = light_kinds[l.light];
    ShadowViewUniform {
        view_proj: mat(l.view_proj),
        light_position: v4(l.origin, kind[0]),
        light_direction: [kind[1], kind[2], kind[3], 0.0],
        _pad: Default::default(),
    }
}
