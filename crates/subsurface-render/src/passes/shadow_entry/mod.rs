//! The shadow entry pass: from a caller's own shadow maps to what the skin's transmittance
//! reads. Jimenez et al. 2010 take thickness from standard shadow maps; this pass reads such a
//! map (a `Depth32Float` array, one layer per spot or directional light and six per point
//! light, drawn with the light's view-projection, cleared to 1) and writes, per texel, the
//! linear light distance of the surface nearest the light and that surface's normal, the two
//! channels our own shadow pass ([`crate::passes::shadow`]) writes while it rasterizes. The
//! normal is rebuilt from the neighbouring texels, on the side whose distance changes least, so
//! a silhouette does not tilt it; the caller's meshes are never drawn again.
//!
//! The caller's z-buffer stays the percentage-closer filter's input
//! ([`crate::passes::lighting::ShadowMaps::depth`]); the pass's [`ShadowEntryPass::atlas_view`]
//! is [`crate::passes::lighting::ShadowMaps::atlas`].

use glam::{Mat4, Vec3};
use wgpu::util::DeviceExt;

use crate::passes::{fullscreen, shadow, util};
use crate::timing::TimedPass;

/// The pass's WGSL: the full-screen triangle, common declarations and shadow_entry.wgsl.
pub const SHADER: &str = concat!(
    include_str!("../fullscreen.wgsl"),
    include_str!("../common.wgsl"),
    include_str!("shadow_entry.wgsl")
);

/// Which light one layer of the caller's shadow map belongs to.
#[derive(Clone, Copy, Debug)]
pub struct EntryLayer {
    /// The matrix the caller drew the layer with (world to clip, depth 0 near, 1 far).
    pub view_proj: Mat4,
    /// The light's kind: `KIND_POINT`, `KIND_SPOT` or `KIND_DIRECTIONAL` of common.wgsl (0, 1,
    /// 2), as in [`crate::uniforms::LightUniform::kind`].
    pub kind: f32,
    /// Where distances are measured from: the light, or a directional light's shadow-camera
    /// origin ([`crate::uniforms::LightUniform::position`]).
    pub origin: Vec3,
    /// The light's unit direction, light to target.
    pub direction: Vec3,
    /// The texels of the layer the caller drew into (from its top-left corner).
    pub size: u32,
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct EntryViewUniform {
    inverse_view_proj: [[f32; 4]; 4],
    light_position: [f32; 4],
    light_direction: [f32; 4],
    layer: i32,
    size: i32,
    _pad: [i32; 2],
}

struct Layer {
    uniform: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
    target: wgpu::TextureView,
    size: u32,
    /// Texels written (x, y, width, height); `None`: the whole layer.
    region: Option<[u32; 4]>,
}

/// Writes the skin's shadow maps from the caller's z-buffer (see the module's documentation).
pub struct ShadowEntryPass {
    pipeline: wgpu::RenderPipeline,
    layers: Vec<Layer>,
    atlas: wgpu::Texture,
    atlas_view: wgpu::TextureView,
}

impl ShadowEntryPass {
    /// `depth`: the caller's shadow maps as one `texture_depth_2d_array` view, `atlas_size`
    /// texels square, with `layers[i]` describing its layer `i`.
    pub fn new(
        device: &wgpu::Device,
        depth: &wgpu::TextureView,
        atlas_size: u32,
        layers: &[EntryLayer],
    ) -> Self {
        let module = util::wgsl_module(device, "shadow_entry.wgsl", SHADER);
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("shadow entry"),
            entries: &[
                util::uniform_entry(0, wgpu::ShaderStages::FRAGMENT),
                util::depth_array_entry(1, wgpu::ShaderStages::FRAGMENT),
            ],
        });
        let pipeline_layout = util::pipeline_layout(device, "shadow entry", &[&layout]);
        let pipeline = fullscreen::pipeline(
            device,
            &module,
            Some(&pipeline_layout),
            "fs_entry",
            &[Some(shadow::FORMAT.into())],
        );
        let atlas = util::texture_2d(
            device,
            "shadow entry atlas",
            atlas_size.max(1),
            atlas_size.max(1),
            layers.len().max(1) as u32,
            shadow::FORMAT,
            wgpu::TextureUsages::RENDER_ATTACHMENT
                | wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::COPY_SRC,
        );
        let layers = layers
            .iter()
            .enumerate()
            .map(|(i, l)| {
                let uniform = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some("shadow entry view"),
                    contents: bytemuck::bytes_of(&entry_uniform(i, l)),
                    usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                });
                let bind_group = util::bind_group(
                    device,
                    "shadow entry",
                    &layout,
                    [
                        (0, uniform.as_entire_binding()),
                        (1, wgpu::BindingResource::TextureView(depth)),
                    ],
                );
                Layer {
                    uniform,
                    bind_group,
                    target: util::layer_view(&atlas, i as u32),
                    size: l.size,
                    region: None,
                }
            })
            .collect();
        Self {
            pipeline,
            layers,
            atlas_view: util::array_view(&atlas),
            atlas,
        }
    }

    /// Moves the layers' cameras: `layers[i]` for layer `i`, as many as at creation and no
    /// larger than the atlas (an engine's shadow cascades follow its camera every frame).
    pub fn set_layers(&mut self, queue: &wgpu::Queue, layers: &[EntryLayer]) {
        for (i, (layer, l)) in self.layers.iter_mut().zip(layers).enumerate() {
            layer.size = l.size;
            queue.write_buffer(&layer.uniform, 0, bytemuck::bytes_of(&entry_uniform(i, l)));
        }
    }

    /// Writes only the texels `[x, y, width, height]` of layer `layer` (clipped to the layer;
    /// `None`: all of it, as at creation); the others read as empty (nothing drawn there).
    /// An engine whose cascade spans far more than its skin saves the rest: the pass costs
    /// per texel.
    pub fn set_region(&mut self, layer: usize, region: Option<[u32; 4]>) {
        if let Some(l) = self.layers.get_mut(layer) {
            l.region = region;
        }
    }

    /// The skin's shadow maps (`Rg32Float` array, same layers as the caller's): the
    /// [`crate::passes::lighting::ShadowMaps::atlas`] of the passes that read them.
    pub fn atlas_view(&self) -> &wgpu::TextureView {
        &self.atlas_view
    }

    /// The maps as a texture, for reading back.
    pub fn atlas(&self) -> &wgpu::Texture {
        &self.atlas
    }

    /// Writes every layer; run after the caller has drawn its shadow maps.
    pub fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        profiler: Option<&wgpu_profiler::GpuProfiler>,
    ) {
        for layer in &self.layers {
            let timer = TimedPass::begin(profiler, "shadow entry", encoder);
            {
                let mut pass = util::render_pass(
                    encoder,
                    "shadow entry",
                    &[util::color_attachment(
                        &layer.target,
                        wgpu::LoadOp::Clear(wgpu::Color {
                            r: f32::MAX as f64,
                            g: 0.0,
                            b: 0.0,
                            a: 0.0,
                        }),
                    )],
                    None,
                    timer.writes(),
                );
                pass.set_viewport(0.0, 0.0, layer.size as f32, layer.size as f32, 0.0, 1.0);
                let [x, y, w, h] = layer.region.unwrap_or([0, 0, layer.size, layer.size]);
                let (x, y) = (x.min(layer.size), y.min(layer.size));
                let (w, h) = (w.min(layer.size - x), h.min(layer.size - y));
                // An empty region leaves the layer as cleared: every texel empty.
                if w > 0 && h > 0 {
                    pass.set_scissor_rect(x, y, w, h);
                    pass.set_pipeline(&self.pipeline);
                    pass.set_bind_group(0, &layer.bind_group, &[]);
                    pass.draw(0..3, 0..1);
                }
            }
            timer.end(profiler, encoder);
        }
    }
}

/// Layer `index`'s uniform: the inverse of its matrix unprojects the caller's depths.
fn entry_uniform(index: usize, l: &EntryLayer) -> EntryViewUniform {
    EntryViewUniform {
        inverse_view_proj: l.view_proj.inverse().to_cols_array_2d(),
        light_position: l.origin.extend(l.kind).to_array(),
        light_direction: l.direction.extend(0.0).to_array(),
        layer: index as i32,
        size: l.size as i32,
        _pad: [0; 2],
    }
}
