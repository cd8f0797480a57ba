//! Step 1 of texture-space diffusion: each skin object's lights, shadows, ambient and
//! transmittance evaluated with the mesh laid out by its texture coordinates, into an
//! irradiance map ([`MAP_FORMAT`], alpha = covered) and a stretch map ([`STRETCH_FORMAT`]:
//! profile millimetres per texel along u and v, from the derivatives of the world position).
//!
//! The shader is the lighting pass's (common.wgsl, lighting.wgsl, shadow_lookup.wgsl,
//! transmittance.wgsl, bounce.wgsl) with irradiance.wgsl appended, and the pipeline takes the lighting
//! pass's bind groups: its frame bind group (group 0), the object's (group 1), the object's
//! maps (group 2) and, in group 3, no transmitted map (texels of a UV map are no pixels of it:
//! the lateral taps run per texel).

use crate::gpu_scene::{self, GpuObject};
use crate::passes::lighting::{self, LightingPass};
use crate::passes::maps::{MAP_FORMAT, STRETCH_FORMAT};
use crate::passes::util;
use crate::timing::TimedPass;

/// The irradiance pass's WGSL: the lighting shader with irradiance.wgsl's UV-space entry
/// points.
pub const SHADER: &str = lighting_shader!(include_str!("irradiance.wgsl"));

/// The UV-space irradiance pipeline; shared by every object.
pub struct IrradiancePass {
    pipeline: wgpu::RenderPipeline,
}

impl IrradiancePass {
    /// `maps_layout` is group 2 of the lighting pass ([`crate::passes::maps::maps_layout`]);
    /// groups 0 and 1 are the lighting pass's frame layout and the objects' layout.
    pub fn new(device: &wgpu::Device, maps_layout: &wgpu::BindGroupLayout) -> Self {
        let frame_layout = lighting::frame_layout(device);
        let object_layout = gpu_scene::object_layout(device);
        let layout = util::pipeline_layout(
            device,
            "texture-space irradiance",
            &[
                &frame_layout,
                &object_layout,
                maps_layout,
                &lighting::screen_layout(device),
            ],
        );
        let module = util::wgsl_module(device, "texture_space/irradiance.wgsl", SHADER);
        let pipeline = util::MeshPipeline {
            label: "texture-space irradiance",
            layout: &layout,
            module: &module,
            vertex: "vs_irradiance",
            fragment: "fs_irradiance",
            targets: &[MAP_FORMAT, STRETCH_FORMAT],
            // UV islands may be laid out with either winding; no depth (one surface per texel).
            cull_mode: None,
            depth: util::DepthTest::Off,
            // Follows `lights.transmittance` (TRANSMITTANCE_METHOD's default): the pass is
            // built once per texture-space setup, not per method.
            stencil: None,
            constants: &[],
            blend: None,
        }
        .create(device);
        Self { pipeline }
    }

    /// Records one object's irradiance and stretch maps (`targets`, cleared first) with the
    /// lighting pass's frame bindings (camera, lights, shadow maps) and the object's group 2
    /// `maps`. Timed "texture".
    pub fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        lighting: &LightingPass,
        object: &GpuObject,
        maps: &wgpu::BindGroup,
        targets: &[wgpu::TextureView; 2],
        profiler: Option<&wgpu_profiler::GpuProfiler>,
    ) {
        let timer = TimedPass::begin(profiler, "texture", encoder);
        {
            let attach =
                |v| util::color_attachment(v, wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT));
            let mut pass = util::color_pass(
                encoder,
                "texture-space irradiance",
                &[attach(&targets[0]), attach(&targets[1])],
                timer.writes(),
            );
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, lighting.frame_bind_group(), &[]);
            pass.set_bind_group(2, maps, &[]);
            pass.set_bind_group(3, lighting.no_transmitted_map(), &[]);
            object.draw(&mut pass);
        }
        timer.end(profiler, encoder);
    }
}
