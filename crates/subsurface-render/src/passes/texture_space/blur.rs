//! Steps 2 and 3 of texture-space diffusion on the GPU: the profile's Gaussians applied to an
//! irradiance map as separable 7-tap blurs, each Gaussian made from the previous one by its
//! variance increment, converted from millimetres to texels through the stretch map, and
//! summed with the profile's per-channel weights; then the UV islands padded by a few texels.
//! The CPU mirror is [`subsurface_profile::oracle::texture`] (`cpu_blur`, `cpu_dilate`).
//!
//! Per blur, in order: copy (the narrowest Gaussian, the irradiance times its weight, into
//! the accumulated map), then per later Gaussian a horizontal pass into `tmp` and a vertical
//! pass into `ping`/`pong` (alternately) that also adds the weighted Gaussian to the
//! accumulated map, and last the padding of the sum and of the widest Gaussian.

use subsurface_profile::oracle::texture::{BlurKernel, MAX_SIGMA_TEXELS};
use wgpu::util::DeviceExt;

use crate::passes::fullscreen;
use crate::passes::maps::{MAP_FORMAT, map_texture};
use crate::passes::util;
use crate::timing::TimedPass;
use crate::uniforms::BlurUniform;

/// fullscreen.wgsl (`vs_fullscreen`) and blur.wgsl.
pub const SHADER: &str = concat!(
    include_str!("../fullscreen.wgsl"),
    include_str!("blur.wgsl")
);

/// The blur and padding pipelines; shared by every object.
pub struct TextureBlur {
    layout: wgpu::BindGroupLayout,
    /// By [`Stage`]: `fs_ts_copy`, the narrowest Gaussian into the accumulated map;
    /// `fs_ts_blur`, horizontal pass of one variance increment; `fs_ts_blur_accumulate`,
    /// vertical pass, also added to the accumulated map; `fs_ts_dilate`, padding of the sum
    /// and of the widest Gaussian.
    pipelines: [wgpu::RenderPipeline; 4],
}

/// Which of [`TextureBlur`]'s pipelines a step runs (their index).
#[derive(Clone, Copy, Debug)]
enum Stage {
    Copy,
    Blur,
    Accumulate,
    Dilate,
}

/// One full-screen draw of a blur.
struct BlurStepPass {
    stage: Stage,
    bind_group: wgpu::BindGroup,
    /// Colour attachments, loaded (not cleared).
    targets: Vec<wgpu::TextureView>,
}

/// The maps of one blur, created by [`TextureBlur::bind`]: `result` holds the padded sum of
/// Gaussians and `widest` the padded widest Gaussian (both `Rgba16Float`, alpha 1 on the
/// islands, 0.5 in the padding, 0 elsewhere).
pub struct BlurTargets {
    /// The padded sum of the profile's Gaussians: the blurred irradiance.
    pub result: wgpu::Texture,
    /// The padded widest Gaussian alone, which translucent shadow maps read.
    pub widest: wgpu::Texture,
    /// The accumulated sum before padding.
    pub accum: wgpu::Texture,
    result_view: wgpu::TextureView,
    widest_view: wgpu::TextureView,
    /// `tmp`, `ping` and `pong`: the horizontal pass and the last two Gaussians.
    _scratch: [wgpu::Texture; 3],
    _uniforms: Vec<wgpu::Buffer>,
    steps: Vec<BlurStepPass>,
}

impl BlurTargets {
    /// A view of `result`.
    pub fn result_view(&self) -> &wgpu::TextureView {
        &self.result_view
    }
    /// A view of `widest`.
    pub fn widest_view(&self) -> &wgpu::TextureView {
        &self.widest_view
    }
}

impl TextureBlur {
    /// Builds the pipelines.
    pub fn new(device: &wgpu::Device) -> Self {
        let module = util::wgsl_module(device, "texture_space/blur.wgsl", SHADER);
        // The stretch map is Rg32Float; the blur reads texels without a sampler anyway.
        let (layout, pipeline_layout) =
            util::image_pass_layouts(device, "texture-space blur", 10, &[11, 12, 13]);
        let replace = Some(wgpu::ColorTargetState::from(MAP_FORMAT));
        let additive = Some(util::additive_target(MAP_FORMAT));
        let make = |entry: &str, targets: &[Option<wgpu::ColorTargetState>]| {
            fullscreen::pipeline(device, &module, Some(&pipeline_layout), entry, targets)
        };
        Self {
            pipelines: [
                make("fs_ts_copy", std::slice::from_ref(&replace)),
                make("fs_ts_blur", std::slice::from_ref(&replace)),
                make("fs_ts_blur_accumulate", &[replace.clone(), additive]),
                make("fs_ts_dilate", &[replace.clone(), replace]),
            ],
            layout,
        }
    }

    fn pipeline(&self, stage: Stage) -> &wgpu::RenderPipeline {
        &self.pipelines[stage as usize]
    }

    /// Creates the maps and bind groups that blur `irradiance` (`Rgba16Float`, square, alpha >
    /// 0.5 = covered) with `stretch` (`Rg32Float`, profile mm per texel along u and v), and
    /// writes the blur's uniforms (they do not change from frame to frame).
    pub fn bind(
        &self,
        device: &wgpu::Device,
        irradiance: &wgpu::Texture,
        stretch: &wgpu::Texture,
        kernel: &BlurKernel,
        padding: u32,
    ) -> BlurTargets {
        let size = irradiance.width();
        let view = |t: &wgpu::Texture| t.create_view(&Default::default());
        let map = |label| map_texture(device, label, size, MAP_FORMAT);
        let tmp = map("texture-space tmp");
        let gaussians = [map("texture-space ping"), map("texture-space pong")];
        let accum = map("texture-space accum");
        let result = map("texture-space result");
        let widest = map("texture-space widest");
        let tmp_view = view(&tmp);
        let gaussian_views = gaussians.each_ref().map(view);
        let accum_view = view(&accum);
        let result_view = view(&result);
        let widest_view = view(&widest);
        let irradiance_view = view(irradiance);
        let stretch_view = view(stretch);

        let mut uniforms = Vec::new();
        let mut bind = |u: BlurUniform, src: &wgpu::TextureView, extra: &wgpu::TextureView| {
            let buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("texture-space blur"),
                contents: bytemuck::bytes_of(&u),
                usage: wgpu::BufferUsages::UNIFORM,
            });
            let bg = util::image_pass_bind_group(
                device,
                "texture-space blur",
                &self.layout,
                (10, &buffer),
                &[(11, src), (12, &stretch_view), (13, extra)],
            );
            uniforms.push(buffer);
            bg
        };
        let params = [padding as f32, MAX_SIGMA_TEXELS, 0.0, 0.0];
        let w4 = |w: [f32; 3]| [w[0], w[1], w[2], 0.0];
        let uniform = |dir: [f32; 4], weight: [f32; 4]| BlurUniform {
            dir,
            weight,
            params,
        };

        let mut steps = vec![BlurStepPass {
            stage: Stage::Copy,
            bind_group: bind(
                uniform([0.0; 4], w4(kernel.first_weight)),
                &irradiance_view,
                &irradiance_view,
            ),
            targets: vec![accum_view.clone()],
        }];
        // The previous Gaussian: the irradiance map itself, then ping and pong in turn.
        let mut source = &irradiance_view;
        for (k, s) in kernel.steps.iter().enumerate() {
            steps.push(BlurStepPass {
                stage: Stage::Blur,
                bind_group: bind(
                    uniform([1.0, 0.0, s.sigma_mm, 0.0], w4(s.weight)),
                    source,
                    source,
                ),
                targets: vec![tmp_view.clone()],
            });
            let dst = &gaussian_views[k % 2];
            steps.push(BlurStepPass {
                stage: Stage::Accumulate,
                bind_group: bind(
                    uniform([0.0, 1.0, s.sigma_mm, 0.0], w4(s.weight)),
                    &tmp_view,
                    &tmp_view,
                ),
                targets: vec![dst.clone(), accum_view.clone()],
            });
            source = dst;
        }
        steps.push(BlurStepPass {
            stage: Stage::Dilate,
            bind_group: bind(uniform([0.0; 4], [0.0; 4]), &accum_view, source),
            targets: vec![result_view.clone(), widest_view.clone()],
        });
        let [ping, pong] = gaussians;
        BlurTargets {
            result,
            widest,
            accum,
            result_view,
            widest_view,
            _scratch: [tmp, ping, pong],
            _uniforms: uniforms,
            steps,
        }
    }

    /// Records the copy, blur and padding passes (each timed as "texture").
    pub fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        targets: &BlurTargets,
        profiler: Option<&wgpu_profiler::GpuProfiler>,
    ) {
        for s in &targets.steps {
            let timer = TimedPass::begin(profiler, "texture", encoder);
            {
                let attachments: Vec<_> = s
                    .targets
                    .iter()
                    .map(|v| util::color_attachment(v, wgpu::LoadOp::Load))
                    .collect();
                let mut pass =
                    util::color_pass(encoder, "texture-space blur", &attachments, timer.writes());
                pass.set_pipeline(self.pipeline(s.stage));
                pass.set_bind_group(0, &s.bind_group, &[]);
                pass.draw(0..3, 0..1);
            }
            timer.end(profiler, encoder);
        }
    }
}
