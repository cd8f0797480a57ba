//! Shadow maps that store linear light distance (scene units) in the first channel of an
//! Rg32Float array texture. Jimenez et al. 2010 read thickness from exactly such standard maps;
//! the second channel holds the normal of the surface the light sees (octahedral, 12 bits a
//! component as an integer-valued float), which the `diffusion` transmittance needs for the
//! back irradiance and the direction of the light crossing thin parts unscattered.

use crate::error::RenderError;
use crate::gpu::GpuContext;
use crate::lights::ShadowLayer;
use crate::passes::util;
use crate::uniforms::{ShadowViewUniform, mat, v4};

/// The shadow pass's WGSL: common declarations, the object's group and shadow.wgsl.
pub const SHADER: &str = concat!(
    include_str!("common.wgsl"),
    include_str!("bindings/object.wgsl"),
    include_str!("shadow.wgsl")
);
/// Texel format of the shadow atlas: r = linear light distance in scene units, g = the entry
/// normal, octahedral-encoded.
pub const FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rg32Float;

/// All shadow maps ([`util::LayeredPass::atlas`]): one layer per spot/directional light, six
/// per point light.
pub struct ShadowPass(util::LayeredPass);

impl std::ops::Deref for ShadowPass {
    type Target = util::LayeredPass;
    fn deref(&self) -> &util::LayeredPass {
        &self.0
    }
}

impl ShadowPass {
    /// One atlas layer per entry of `layers`, `atlas_size` texels square; `light_kinds` holds each
    /// light's kind and direction `[kind, x, y, z]`. Errors when the atlas or its layer count
    /// exceeds the device's limits.
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
        let desc = util::LayeredPassDesc {
            label: "shadow",
            atlas_label: "shadow atlas",
            shader: SHADER,
            vertex: "vs_main",
            fragment: "fs_main",
            format: FORMAT,
            view_binding: 0,
            view_visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
            // Empty texels read as infinitely far: nothing occludes there.
            clear: wgpu::Color {
                r: f32::MAX as f64,
                g: 0.0,
                b: 0.0,
                a: 0.0,
            },
            // The lighting pass filters shadows with a comparison sampler on the z-buffer.
            sampled_depth: true,
        };
        Ok(Self(util::LayeredPass::new(
            device,
            &desc,
            object_layout,
            layers,
            atlas_size,
            |l| view_uniform(l, light_kinds),
        )))
    }

    /// The maps as the lighting pass binds them: the atlas and the z-buffer of every layer
    /// (projected depth of the surface nearest the light, for comparison sampling).
    pub fn maps(&self) -> crate::passes::lighting::ShadowMaps<'_> {
        crate::passes::lighting::ShadowMaps {
            atlas: &self.0.atlas_view,
            depth: self
                .0
                .depth_view
                .as_ref()
                .expect("the shadow pass keeps its z-buffer"),
            flux: None,
        }
    }

    /// Moves the shadow cameras (same layers and sizes as at creation: the viewer moving a
    /// light). Changed sizes or light counts need a new `ShadowPass`.
    pub fn update_layers(
        &mut self,
        queue: &wgpu::Queue,
        layers: &[ShadowLayer],
        light_kinds: &[[f32; 4]],
    ) {
        self.0
            .move_cameras(queue, layers, |l| view_uniform(l, light_kinds));
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
