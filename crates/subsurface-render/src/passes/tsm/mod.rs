//! Translucent shadow maps: each shadow layer is rendered a second time storing the (u, v) of
//! the surface nearest the light (`Rg32Float`, beside the `R32Float` distance: the three
//! floats per texel the papers count). With `TransmittanceMethod::Tsm` the lighting pass adds
//! `T(s) x E_widest(u_in, v_in)` per light: the thickness `s` and `T(s)` as in the 2010 method
//! (same LUT, same filtered distance), but the back-side irradiance read from the widest
//! blurred Gaussian of texture-space diffusion at the entry point instead of estimated from the
//! vertex normal.

use crate::gpu::GpuContext;
use crate::lights::ShadowLayer;
use crate::passes::util;
use crate::uniforms::{TsmViewUniform, mat};

pub use crate::passes::maps::{TSM_FORMAT, dummy_tsm_view};

/// common.wgsl, bindings/object.wgsl (`object`, `VertexIn`) and tsm.wgsl.
pub const SHADER: &str = concat!(
    include_str!("../common.wgsl"),
    include_str!("../bindings/object.wgsl"),
    include_str!("tsm.wgsl")
);

/// The (u, v) of the surface nearest each light, one layer per shadow layer, at the shadow
/// atlas's size: rendered as a second pass over the same layers ("tsm").
pub struct TsmPass(util::LayeredPass);

impl std::ops::Deref for TsmPass {
    type Target = util::LayeredPass;
    fn deref(&self) -> &util::LayeredPass {
        &self.0
    }
}

impl TsmPass {
    /// One translucent-shadow-map layer per shadow layer, `atlas_size` texels square.
    pub fn new(
        ctx: &GpuContext,
        object_layout: &wgpu::BindGroupLayout,
        layers: &[ShadowLayer],
        atlas_size: u32,
    ) -> Self {
        let desc = util::LayeredPassDesc {
            label: "tsm",
            atlas_label: "translucent shadow maps",
            shader: SHADER,
            vertex: "vs_tsm",
            fragment: "fs_tsm",
            format: TSM_FORMAT,
            view_binding: 14,
            view_visibility: wgpu::ShaderStages::VERTEX,
            // Texels where nothing is drawn hold (-1, -1).
            clear: wgpu::Color {
                r: -1.0,
                g: -1.0,
                b: 0.0,
                a: 0.0,
            },
            sampled_depth: false,
        };
        Self(util::LayeredPass::new(
            &ctx.device,
            &desc,
            object_layout,
            layers,
            atlas_size,
            view_uniform,
        ))
    }

    /// Moves the light cameras (same layers and sizes as at creation).
    pub fn prepare(&mut self, queue: &wgpu::Queue, layers: &[ShadowLayer]) {
        self.0.move_cameras(queue, layers, view_uniform);
    }

    /// [`Self::prepare`], under the name the renderer calls.
    pub fn update_layers(&mut self, queue: &wgpu::Queue, layers: &[ShadowLayer]) {
        self.prepare(queue, layers);
    }
}

fn view_uniform(layer: &ShadowLayer) -> TsmViewUniform {
    TsmViewUniform {
        view_proj: mat(layer.view_proj),
    }
}
