//! The outline pass (outline.wgsl): where the lighting pass reads `diffusion` from the
//! transmitted map, each light's chord at the pixels the map misses (outlines, depth edges),
//! drawn over the skin after the lighting pass and added into its diffuse and specular targets
//! ([`LightingVariant::outline_pass`]). It keeps that code out of the lighting pass's shader:
//! on a CPU rasteriser, which runs both sides of every branch, the chords there cost as much
//! at every skin pixel as at an outline (docs/lab/performance.md, sessions 27 and 29). The
//! lighting pass marks the pixels the map misses; a full-screen draw copies the mark into the
//! z-buffer's stencil, and the skin drawn again shades the marked pixels alone.

use super::{LightingPass, LightingTargets, RADIANCE_FORMAT, variant_constants, zbuffer_format};
use crate::frame_plan::{FramePlan, LightingVariant};
use crate::gpu::object::GpuObject;
use crate::passes::{fullscreen, util};
use crate::timing::TimedPass;

/// The stencil bit that marks a pixel the outline pass shades.
const MARK: u32 = 1;

/// The stencil test on both faces: `compare` against [`MARK`], `pass` where it holds.
fn stencil(compare: wgpu::CompareFunction, pass_op: wgpu::StencilOperation) -> wgpu::StencilState {
    let face = wgpu::StencilFaceState {
        compare,
        fail_op: wgpu::StencilOperation::Keep,
        depth_fail_op: wgpu::StencilOperation::Keep,
        pass_op,
    };
    wgpu::StencilState {
        front: face,
        back: face,
        read_mask: MARK,
        write_mask: MARK,
    }
}

/// Group 0 of the outline pass's mark: the lighting pass's SSS target (`sss_target` in
/// outline_mark.wgsl).
pub(super) fn mark_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("outline mark"),
        entries: &[util::float_texture_entry(
            0,
            wgpu::ShaderStages::FRAGMENT,
            false,
            wgpu::TextureViewDimension::D2,
        )],
    })
}

/// The outline pass's full-screen mark: sets [`MARK`] where the lighting pass left the chords
/// (its SSS target's `a`). One for every lighting variant.
fn mark_pipeline(device: &wgpu::Device) -> wgpu::RenderPipeline {
    use wgpu::{CompareFunction, StencilOperation};
    let module = util::wgsl_module(device, "outline_mark.wgsl", super::OUTLINE_MARK_SHADER);
    let layout = util::pipeline_layout(device, "outline mark", &[&mark_layout(device)]);
    let targets = [RADIANCE_FORMAT, RADIANCE_FORMAT].map(|format| {
        Some(wgpu::ColorTargetState {
            format,
            blend: Some(fullscreen::ADD),
            write_mask: wgpu::ColorWrites::ALL,
        })
    });
    fullscreen::pipeline_with(
        device,
        &module,
        Some(&layout),
        "fs_outline_mark",
        &targets,
        &[],
        Some(wgpu::DepthStencilState {
            format: zbuffer_format(device),
            depth_write_enabled: Some(false),
            depth_compare: Some(CompareFunction::Always),
            stencil: stencil(CompareFunction::Always, StencilOperation::Replace),
            bias: Default::default(),
        }),
    )
}

/// `fs_outline` for the lighting pipeline `variant`: adds the chords at the pixels the mark
/// set into the diffuse and specular targets, on the lighting pass's z-buffer.
fn shade_pipeline(
    device: &wgpu::Device,
    layout: &wgpu::PipelineLayout,
    module: &wgpu::ShaderModule,
    variant: LightingVariant,
) -> wgpu::RenderPipeline {
    use wgpu::{CompareFunction, StencilOperation};
    util::MeshPipeline {
        label: "outline",
        layout,
        module,
        vertex: "vs_main",
        fragment: "fs_outline",
        targets: &[RADIANCE_FORMAT, RADIANCE_FORMAT],
        cull_mode: None,
        depth: util::DepthTest::Prepassed,
        stencil: Some((
            zbuffer_format(device),
            stencil(CompareFunction::Equal, StencilOperation::Keep),
        )),
        constants: &variant_constants(variant),
        blend: Some(fullscreen::ADD),
    }
    .create(device)
}

/// The outline pass's pipelines, each kept once built (the viewer switches settings back and
/// forth), and the plan's use of them.
#[derive(Default)]
pub(super) struct Outline {
    mark: Option<wgpu::RenderPipeline>,
    /// `fs_outline` per lighting variant.
    shades: Vec<(LightingVariant, wgpu::RenderPipeline)>,
    /// The index in `shades` of the plan's variant; `None`: the plan has no outline pass.
    current: Option<usize>,
    /// For each object: the pass draws it (the plan's `outline_objects`).
    objects: Vec<bool>,
    /// The pixels `[x0, y0, x1, y1)` of those objects' boxes on screen: the full-screen mark
    /// and the draws are scissored to them.
    rect: Option<[u32; 4]>,
}

impl LightingPass {
    /// Takes `plan`'s outline pass, building its pipelines the first time they are asked for.
    pub(super) fn set_outline(&mut self, device: &wgpu::Device, plan: &FramePlan) {
        let key = plan.lighting;
        let outline = &mut self.outline;
        outline.objects = plan.outline_objects.clone();
        outline.rect = plan
            .object_rects
            .iter()
            .zip(&plan.outline_objects)
            .filter_map(|(rect, drawn)| rect.filter(|_| *drawn))
            .reduce(|a, b| {
                [
                    a[0].min(b[0]),
                    a[1].min(b[1]),
                    a[2].max(b[2]),
                    a[3].max(b[3]),
                ]
            });
        outline.current = None;
        if !key.outline_pass {
            return;
        }
        outline.mark.get_or_insert_with(|| mark_pipeline(device));
        let index = match outline.shades.iter().position(|(k, _)| *k == key) {
            Some(i) => i,
            None => {
                let shade = shade_pipeline(device, &self.layout, &self.module, key);
                outline.shades.push((key, shade));
                outline.shades.len() - 1
            }
        };
        outline.current = Some(index);
    }

    /// Whether the frame runs the outline pass.
    pub fn runs_outline(&self) -> bool {
        self.outline.current.is_some() && self.outline.rect.is_some()
    }

    /// The outline pass into the lighting pass's `diffuse` and `specular` views, timed as
    /// `outline`, where the plan has one.
    pub(super) fn encode_outline(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        targets: &LightingTargets,
        [diffuse, specular]: [&wgpu::TextureView; 2],
        objects: &[GpuObject],
        maps: &[wgpu::BindGroup],
        profiler: Option<&wgpu_profiler::GpuProfiler>,
    ) {
        let outline = &self.outline;
        let (Some(mark), Some(current), Some([x0, y0, x1, y1])) =
            (&outline.mark, outline.current, outline.rect)
        else {
            return;
        };
        let shade = &outline.shades[current].1;
        let timer = TimedPass::begin(profiler, "outline", encoder);
        {
            let load = |v| util::color_attachment(v, wgpu::LoadOp::Load);
            let mut pass = util::render_pass(
                encoder,
                "outline",
                &[load(diffuse), load(specular)],
                Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &targets.zbuffer,
                    depth_ops: None,
                    stencil_ops: Some(wgpu::Operations {
                        load: wgpu::LoadOp::Clear(0),
                        store: wgpu::StoreOp::Discard,
                    }),
                }),
                timer.writes(),
            );
            pass.set_scissor_rect(x0, y0, x1 - x0, y1 - y0);
            pass.set_stencil_reference(MARK);
            pass.set_pipeline(mark);
            pass.set_bind_group(0, &targets.outline_mark, &[]);
            pass.draw(0..3, 0..1);
            pass.set_pipeline(shade);
            pass.set_bind_group(0, &self.frame_bind_group, &[]);
            pass.set_bind_group(3, &targets.screen, &[]);
            for (i, o) in objects.iter().enumerate() {
                if outline.objects.get(i) == Some(&true) {
                    pass.set_bind_group(2, maps.get(i).unwrap_or(&self.default_maps), &[]);
                    o.draw(&mut pass);
                }
            }
        }
        timer.end(profiler, encoder);
    }
}
