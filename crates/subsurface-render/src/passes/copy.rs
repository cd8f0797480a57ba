//! Full-screen copy pass, the baseline cost that `subsurface bench` divides SSS times by.

use crate::passes::util;
use crate::timing::TimedPass;

/// The copy pass's WGSL: the full-screen triangle and a fragment stage that returns its texel.
pub const SHADER: &str = concat!(include_str!("fullscreen.wgsl"), include_str!("copy.wgsl"));

/// A full-screen copy of one texture: the cheapest image pass, which SSS times are compared with.
pub struct CopyPass {
    pipeline: wgpu::RenderPipeline,
    bind_group: wgpu::BindGroup,
    target: wgpu::TextureView,
}

impl CopyPass {
    /// Copies `source` into a new texture of the same size and format on every `encode`.
    pub fn new(device: &wgpu::Device, source: &wgpu::Texture) -> Self {
        let module = util::wgsl_module(device, "copy.wgsl", SHADER);
        let pipeline = super::fullscreen::pipeline(
            device,
            &module,
            None,
            "fs_main",
            &[Some(source.format().into())],
        );
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("copy"),
            layout: &pipeline.get_bind_group_layout(0),
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::TextureView(
                    &source.create_view(&Default::default()),
                ),
            }],
        });
        let target = util::texture_2d(
            device,
            "copy target",
            source.width(),
            source.height(),
            source.depth_or_array_layers(),
            source.format(),
            wgpu::TextureUsages::RENDER_ATTACHMENT,
        )
        .create_view(&Default::default());
        Self {
            pipeline,
            bind_group,
            target,
        }
    }

    /// Records the copy, timed as "copy".
    pub fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        profiler: Option<&wgpu_profiler::GpuProfiler>,
    ) {
        let timer = TimedPass::begin(profiler, "copy", encoder);
        {
            let mut pass = util::color_pass(
                encoder,
                "copy",
                &[util::color_attachment(&self.target, wgpu::LoadOp::Load)],
                timer.writes(),
            );
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, &self.bind_group, &[]);
            pass.draw(0..3, 0..1);
        }
        timer.end(profiler, encoder);
    }
}
