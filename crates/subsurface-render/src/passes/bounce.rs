//! The light one lit part of the skin sends another across the air: a finger's lit side toward
//! its neighbour, a cheek toward the nose. A renderer without global illumination leaves it
//! out; against the path tracer it is most of what the backlit hand's fingers miss
//! (docs/lab/fidelity.md, findings 9 and 11).
//!
//! Every shadow-map texel is a lit point whose position (its distance along the texel's ray)
//! and normal (the map's second channel) are known, and so is the flux the light delivers to
//! it: the reflective shadow map of Dachsbacher and Stamminger 2005, with the flux derived
//! rather than stored. [`FluxPyramid`] sums the texels into cells ([`base_texels`], then 2 x 2
//! cells a level: flux, flux-weighted position and normal sums), a compute pass after the
//! shadow maps. `bounce.wgsl` (part of the lighting shader, `lighting::SHADER`) reads each level from
//! `ring` to `2 ring` of its cells away from the shaded point, a few hundred reads in all, on
//! the transmitted map's reduced grid (`transmitted_map::TransmittedMapTargets`, layer `bounce_layer`) where
//! there is one, per pixel elsewhere. The shaded point takes the bounce as irradiance, which
//! joins the direct light before the subsurface blur.
//!
//! What it leaves out: visibility between the cells and the point (a shadow map cannot test
//! it), the senders' own colour (each sends with the receiving object's albedo and boundary),
//! the reflection of the bounce at the receiver, point lights (their six faces), and the light
//! that crosses a part and leaves its unlit side toward another.

use glam::{Vec3, Vec4};
use wgpu::util::DeviceExt;

use crate::gpu::GpuContext;
use crate::lights::ShadowLayer;
use crate::passes::util;
use crate::timing::TimedPass;
use crate::uniforms::{LightsUniform, mat};

/// The pyramid's build (compute): `base` and `downsample`.
pub const SHADER: &str = concat!(
    include_str!("common.wgsl"),
    include_str!("bounce_build.wgsl")
);
/// Shadow-map texels per side of the pyramid's finest cell for an atlas of `atlas_size`: 4, or
/// 8 (read every other one) from 1024 up (bounce_build.wgsl, `base`).
pub fn base_texels(atlas_size: u32) -> u32 {
    if atlas_size >= 1024 { 8 } else { 4 }
}
/// The layers `FluxLayers` of bounce_build.wgsl holds: six per light.
const MAX_LAYERS: usize = 48;
/// Texel format of the pyramid's position and normal textures.
pub const FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;
/// The spread's one channel.
pub const SPREAD_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Float;

/// `FluxLayer` of bounce_build.wgsl.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct FluxLayer {
    inv_view_proj: [[f32; 4]; 4],
    origin: [f32; 4],
    direction: [f32; 4],
    cone: [f32; 4],
}

/// Per-layer build parameters: the texel's ray and the flux per unit of the light's colour
/// it receives (spot and directional lights; point lights' layers get none).
fn flux_layers(layers: &[ShadowLayer], lights: &LightsUniform, base: u32) -> Vec<FluxLayer> {
    let mut out = vec![bytemuck::Zeroable::zeroed(); MAX_LAYERS];
    for (slot, l) in out.iter_mut().zip(layers) {
        let light = &lights.lights[l.light];
        let inv = l.view_proj.inverse();
        let unproject = |x: f32| {
            let p = inv * Vec4::new(x, 0.0, 0.5, 1.0);
            p.truncate() / p.w
        };
        let (centre, edge) = (unproject(0.0), unproject(1.0));
        let size = l.size.max(1) as f32;
        let kind = light.kind;
        // The texel's side: at unit distance for a perspective light (the image plane's half
        // width is tan of half the field of view), across the beam for a directional one.
        let half = if kind == 2.0 {
            (edge - centre).length()
        } else {
            let (a, b) = (
                (centre - l.origin).normalize(),
                (edge - l.origin).normalize(),
            );
            a.cross(b).length() / a.dot(b).max(1e-6)
        };
        let texel_scale = if kind == 0.0 || !half.is_finite() {
            0.0
        } else {
            (2.0 * half / size).powi(2)
        };
        let axis = Vec3::from(light.direction);
        *slot = FluxLayer {
            inv_view_proj: mat(inv),
            origin: l.origin.extend(kind).to_array(),
            direction: axis.extend(texel_scale).to_array(),
            cone: [light.cos_outer, light.cos_inner, size, base as f32],
        };
    }
    out
}

/// The pyramid's levels for an atlas of `atlas_size` texels a side: the finest
/// `ceil(atlas_size / base_texels)` cells a side, halved down to one cell.
pub fn level_count(atlas_size: u32) -> u32 {
    let base = atlas_size.div_ceil(base_texels(atlas_size)).max(1);
    32 - base.leading_zeros()
}

/// The flux pyramid of every shadow-map layer, rebuilt from the shadow atlas each frame.
pub struct FluxPyramid {
    /// rgb = sum of flux x position, a = flux; one layer per shadow layer, all levels.
    pub position: wgpu::Texture,
    /// rgb = sum of flux x normal, a = sum of flux / cos(incidence).
    pub normal: wgpu::Texture,
    /// r = sum of flux x squared distance from the light's origin.
    pub spread: wgpu::Texture,
    /// All levels and layers of `position` as one array view.
    pub position_view: wgpu::TextureView,
    /// All levels and layers of `normal` as one array view.
    pub normal_view: wgpu::TextureView,
    /// All levels and layers of `spread` as one array view.
    pub spread_view: wgpu::TextureView,
    layer_buffer: wgpu::Buffer,
    base: wgpu::ComputePipeline,
    downsample: wgpu::ComputePipeline,
    /// Group 0 per level: the atlas, the layers, and the level's storage views.
    outputs: Vec<wgpu::BindGroup>,
    /// Group 1 per level above the first: the level below, read.
    inputs: Vec<wgpu::BindGroup>,
    sizes: Vec<u32>,
    layers: u32,
    base_texels: u32,
}

impl FluxPyramid {
    /// Whether `device` can build it (compute with storage textures).
    pub fn supported(device: &wgpu::Device) -> bool {
        util::supports_compute_storage(device)
    }

    /// For the shadow atlas `atlas` (`shadow::ShadowPass::atlas_view`) of `layers` and
    /// `atlas_size`, lit by `lights`.
    pub fn new(
        ctx: &GpuContext,
        atlas: &wgpu::TextureView,
        layers: &[ShadowLayer],
        atlas_size: u32,
        lights: &LightsUniform,
    ) -> Self {
        let device = &ctx.device;
        let count = layers.len().clamp(1, MAX_LAYERS) as u32;
        let base_texels = base_texels(atlas_size);
        let base = atlas_size.div_ceil(base_texels).max(1);
        let levels = level_count(atlas_size);
        let texture = |label, format| {
            device.create_texture(&wgpu::TextureDescriptor {
                label: Some(label),
                size: wgpu::Extent3d {
                    width: base,
                    height: base,
                    depth_or_array_layers: count,
                },
                mip_level_count: levels,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format,
                usage: wgpu::TextureUsages::STORAGE_BINDING
                    | wgpu::TextureUsages::TEXTURE_BINDING
                    | wgpu::TextureUsages::COPY_SRC,
                view_formats: &[],
            })
        };
        let (position, normal, spread) = (
            texture("flux position", FORMAT),
            texture("flux normal", FORMAT),
            texture("flux spread", SPREAD_FORMAT),
        );
        let level_view = |t: &wgpu::Texture, level: u32| {
            t.create_view(&wgpu::TextureViewDescriptor {
                label: Some("flux level"),
                dimension: Some(wgpu::TextureViewDimension::D2Array),
                base_mip_level: level,
                mip_level_count: Some(1),
                ..Default::default()
            })
        };
        let layer_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("flux layers"),
            contents: bytemuck::cast_slice(&flux_layers(layers, lights, base_texels)),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        });
        let compute = wgpu::ShaderStages::COMPUTE;
        let array = wgpu::TextureViewDimension::D2Array;
        let storage =
            |binding, format| util::storage_texture_entry(binding, compute, format, array);
        let out_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("flux build"),
            entries: &[
                util::float_texture_entry(0, compute, false, array),
                util::uniform_entry(1, compute),
                storage(2, FORMAT),
                storage(3, FORMAT),
                storage(4, SPREAD_FORMAT),
            ],
        });
        let in_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("flux level below"),
            entries: &[
                util::float_texture_entry(0, compute, false, array),
                util::float_texture_entry(1, compute, false, array),
                util::float_texture_entry(2, compute, false, array),
            ],
        });
        let module = util::wgsl_module(device, "bounce_build.wgsl", SHADER);
        let pipeline = |entry, layout: &wgpu::PipelineLayout| {
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some("flux pyramid"),
                layout: Some(layout),
                module: &module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            })
        };
        let base_pipeline = pipeline(
            "base",
            &util::pipeline_layout(device, "flux base", &[&out_layout]),
        );
        let down_pipeline = pipeline(
            "downsample",
            &util::pipeline_layout(device, "flux downsample", &[&out_layout, &in_layout]),
        );
        let outputs = (0..levels)
            .map(|k| {
                let (p, n, s) = (
                    level_view(&position, k),
                    level_view(&normal, k),
                    level_view(&spread, k),
                );
                util::bind_group(
                    device,
                    "flux build",
                    &out_layout,
                    [
                        (0, wgpu::BindingResource::TextureView(atlas)),
                        (1, layer_buffer.as_entire_binding()),
                        (2, wgpu::BindingResource::TextureView(&p)),
                        (3, wgpu::BindingResource::TextureView(&n)),
                        (4, wgpu::BindingResource::TextureView(&s)),
                    ],
                )
            })
            .collect();
        let inputs = (1..levels)
            .map(|k| {
                let (p, n, s) = (
                    level_view(&position, k - 1),
                    level_view(&normal, k - 1),
                    level_view(&spread, k - 1),
                );
                util::bind_group(
                    device,
                    "flux level below",
                    &in_layout,
                    [
                        (0, wgpu::BindingResource::TextureView(&p)),
                        (1, wgpu::BindingResource::TextureView(&n)),
                        (2, wgpu::BindingResource::TextureView(&s)),
                    ],
                )
            })
            .collect();
        Self {
            position_view: util::array_view(&position),
            normal_view: util::array_view(&normal),
            spread_view: util::array_view(&spread),
            position,
            normal,
            spread,
            layer_buffer,
            base: base_pipeline,
            downsample: down_pipeline,
            outputs,
            inputs,
            sizes: (0..levels).map(|k| (base >> k).max(1)).collect(),
            layers: count,
            base_texels,
        }
    }

    /// The lights moved (same layers and sizes as at creation).
    pub fn update(&self, queue: &wgpu::Queue, layers: &[ShadowLayer], lights: &LightsUniform) {
        queue.write_buffer(
            &self.layer_buffer,
            0,
            bytemuck::cast_slice(&flux_layers(layers, lights, self.base_texels)),
        );
    }

    /// Sums the shadow atlas into every level (timed "bounce build"). After the shadow pass.
    pub fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        profiler: Option<&wgpu_profiler::GpuProfiler>,
    ) {
        let timer = TimedPass::begin(profiler, "bounce build", encoder);
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("flux pyramid"),
                timestamp_writes: timer.compute_writes(),
            });
            for (k, size) in self.sizes.iter().enumerate() {
                let groups = size.div_ceil(8);
                if k == 0 {
                    pass.set_pipeline(&self.base);
                } else {
                    pass.set_pipeline(&self.downsample);
                    pass.set_bind_group(1, &self.inputs[k - 1], &[]);
                }
                pass.set_bind_group(0, &self.outputs[k], &[]);
                pass.dispatch_workgroups(groups, groups, self.layers);
            }
        }
        timer.end(profiler, encoder);
    }
}

/// 1x1 stand-ins for the lighting pass's flux bindings where there is no pyramid.
pub fn dummy_views(device: &wgpu::Device) -> [wgpu::TextureView; 3] {
    let view = |label, format| {
        util::texture_2d(
            device,
            label,
            1,
            1,
            1,
            format,
            wgpu::TextureUsages::TEXTURE_BINDING,
        )
        .create_view(&wgpu::TextureViewDescriptor {
            dimension: Some(wgpu::TextureViewDimension::D2Array),
            ..Default::default()
        })
    };
    [
        view("no flux position", FORMAT),
        view("no flux normal", FORMAT),
        view("no flux spread", SPREAD_FORMAT),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn levels_halve_down_to_one_cell() {
        assert_eq!(level_count(2048), 9); // 256 .. 1
        assert_eq!(level_count(1000), 8); // 250 .. 1
        assert_eq!(level_count(1024), 8); // 128 .. 1
        assert_eq!(level_count(4), 1);
        assert_eq!(level_count(1), 1);
    }
}
