//! Translucent shadow maps: each shadow layer is rendered a second time storing the (u, v) of
//! the surface nearest the light (`Rg32Float`, beside the `R32Float` distance: the three
//! floats per texel the papers count). With `TransmittanceMethod::Tsm` the lighting pass adds
//! `T(s) x E_widest(u_in, v_in)` per light: the thickness `s` and `T(s)` as in the 2010 method
//! (same LUT, same filtered distance), but the back-side irradiance read from the widest
//! blurred Gaussian of texture-space diffusion at the entry point instead of estimated from the
//! vertex normal.

use wgpu::util::DeviceExt;

use crate::gpu::GpuContext;
use crate::gpu_scene::{GpuObject, ShadowLayer};
use crate::passes::util;
use crate::timing::TimedPass;
use crate::uniforms::{TsmViewUniform, mat};

pub use crate::passes::maps::{TSM_FORMAT, dummy_tsm_view};

/// common.wgsl (`Object`, `VertexIn`) and tsm.wgsl.
pub const SHADER: &str = concat!(include_str!("../common.wgsl"), include_str!("tsm.wgsl"));

/// One shadow layer: its size in texels, its light camera and the atlas layer it renders to.
struct TsmLayer {
    size: u32,
    view_buffer: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
    target: wgpu::TextureView,
}

/// The (u, v) of the surface nearest each light, one layer per shadow layer, at the shadow
/// atlas's size: rendered as a second pass over the same layers ("tsm").
pub struct TsmPass {
    pipeline: wgpu::RenderPipeline,
    layers: Vec<TsmLayer>,
    depth: wgpu::TextureView,
    pub atlas: wgpu::Texture,
    pub atlas_view: wgpu::TextureView,
}

impl TsmPass {
    pub fn new(
        ctx: &GpuContext,
        object_layout: &wgpu::BindGroupLayout,
        layers: &[ShadowLayer],
        atlas_size: u32,
    ) -> Self {
        let device = &ctx.device;
        let module = util::wgsl_module(device, "tsm.wgsl", SHADER);
        let view_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("tsm view"),
            entries: &[util::uniform_entry(14, wgpu::ShaderStages::VERTEX)],
        });
        let layout = util::pipeline_layout(device, "tsm", &[&view_layout, object_layout]);
        let pipeline = util::MeshPipeline {
            label: "tsm",
            layout: &layout,
            module: &module,
            vertex: "vs_tsm",
            fragment: "fs_tsm",
            targets: &[TSM_FORMAT],
            // As the shadow maps: the surface nearest the light, whichever way it faces.
            cull_mode: None,
            depth_test: true,
        }
        .create(device);
        let size = atlas_size.max(1);
        let atlas = util::texture_2d(
            device,
            "translucent shadow maps",
            size,
            size,
            layers.len().max(1) as u32,
            TSM_FORMAT,
            wgpu::TextureUsages::RENDER_ATTACHMENT
                | wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::COPY_SRC,
        );
        let atlas_view = util::array_view(&atlas);
        let depth = util::depth_buffer(device, "tsm depth", size, size);
        let layers = layers
            .iter()
            .enumerate()
            .map(|(i, l)| {
                let view_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some("tsm view"),
                    contents: bytemuck::bytes_of(&view_uniform(l)),
                    usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                });
                let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("tsm view"),
                    layout: &view_layout,
                    entries: &[wgpu::BindGroupEntry {
                        binding: 14,
                        resource: view_buffer.as_entire_binding(),
                    }],
                });
                TsmLayer {
                    size: l.size,
                    view_buffer,
                    bind_group,
                    target: util::layer_view(&atlas, i as u32),
                }
            })
            .collect();
        Self {
            pipeline,
            layers,
            depth,
            atlas,
            atlas_view,
        }
    }

    /// Moves the light cameras (same layers and sizes as at creation).
    pub fn prepare(&self, queue: &wgpu::Queue, layers: &[ShadowLayer]) {
        for (layer, l) in self.layers.iter().zip(layers) {
            queue.write_buffer(&layer.view_buffer, 0, bytemuck::bytes_of(&view_uniform(l)));
        }
    }

    /// [`Self::prepare`], under the name the renderer calls.
    pub fn update_layers(&mut self, queue: &wgpu::Queue, layers: &[ShadowLayer]) {
        self.prepare(queue, layers);
    }

    /// Renders every layer ("tsm"); texels where nothing is drawn hold (-1, -1).
    pub fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        objects: &[GpuObject],
        profiler: Option<&wgpu_profiler::GpuProfiler>,
    ) {
        for layer in &self.layers {
            let timer = TimedPass::begin(profiler, "tsm", encoder);
            {
                let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: Some("tsm"),
                    color_attachments: &[util::color_attachment(
                        &layer.target,
                        wgpu::LoadOp::Clear(wgpu::Color {
                            r: -1.0,
                            g: -1.0,
                            b: 0.0,
                            a: 0.0,
                        }),
                    )],
                    depth_stencil_attachment: util::depth_attachment(&self.depth),
                    timestamp_writes: timer.writes(),
                    occlusion_query_set: None,
                    multiview_mask: None,
                });
                let size = layer.size;
                pass.set_viewport(0.0, 0.0, size as f32, size as f32, 0.0, 1.0);
                pass.set_scissor_rect(0, 0, size, size);
                pass.set_pipeline(&self.pipeline);
                pass.set_bind_group(0, &layer.bind_group, &[]);
                for o in objects {
                    o.draw(&mut pass);
                }
            }
            timer.end(profiler, encoder);
        }
    }
}

fn view_uniform(layer: &ShadowLayer) -> TsmViewUniform {
    TsmViewUniform {
        view_proj: mat(layer.view_proj),
    }
}
