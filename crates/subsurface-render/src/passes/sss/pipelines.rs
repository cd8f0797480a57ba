//! The pipelines of the SSS passes, made on first use: only those a method and fetch need are
//! compiled (each is a shader compile on the driver).

use super::{FORMAT, PACKED_FORMAT, SHADER, SHADER_PACKED, SHADER_WORKGROUP, workgroup};
use crate::passes::util;
use crate::settings::SssFetch;
use workgroup::LineFetch;

/// Which pipeline a step runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stage {
    /// Packed fetch: the inputs into one Rgba32Uint texel per pixel.
    Pack,
    Separable,
    SeparableJitter,
    Gaussian,
    Hable13,
    /// Writes a blurred Gaussian and adds it, weighted, to the accumulation target.
    Accumulate,
    /// The narrowest Gaussian (the input times its weight) starts the accumulation.
    CopyWeighted,
    /// Writes the accumulation back into the diffuse target, on skin pixels only.
    Resolve,
}

/// A step's pipeline: its stage, the fetch its shader module uses, and whether its (first)
/// output is the packed layout that the next step reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PipelineKey {
    pub stage: Stage,
    pub fetch: SssFetch,
    pub packed_out: bool,
}

impl PipelineKey {
    fn entry_point(&self) -> String {
        let base = match self.stage {
            Stage::Pack => "fs_pack",
            Stage::Separable => "fs_separable",
            Stage::SeparableJitter => "fs_separable_jitter",
            Stage::Gaussian => "fs_gaussian",
            Stage::Hable13 => "fs_hable13",
            Stage::Accumulate => "fs_gaussian_accumulate",
            Stage::CopyWeighted => "fs_copy",
            Stage::Resolve => "fs_resolve",
        };
        if self.packed_out && self.stage != Stage::Pack {
            format!("{base}_packed")
        } else {
            base.to_string()
        }
    }
}

pub struct Pipelines {
    /// Group 0 of the fragment steps (both fetches: the direct one leaves binding 6 unused).
    pub layout: wgpu::BindGroupLayout,
    pipeline_layout: wgpu::PipelineLayout,
    /// Shader modules of the direct, the packed and the workgroup fetch.
    modules: [Option<wgpu::ShaderModule>; 3],
    render: Vec<(PipelineKey, wgpu::RenderPipeline)>,
    /// The workgroup fetch's layouts and pipelines, made when first used (never on adapters
    /// without compute shaders and storage textures).
    pub compute: Option<ComputeParts>,
}

pub struct ComputeParts {
    /// Group 0 of the workgroup fetch's compute steps.
    pub layout: wgpu::BindGroupLayout,
    pipeline_layout: wgpu::PipelineLayout,
    /// The compute pipelines, by stage and where their taps find their texels.
    pipelines: Vec<((Stage, LineFetch), wgpu::ComputePipeline)>,
    pub dummies: workgroup::Dummies,
}

impl Pipelines {
    pub fn new(device: &wgpu::Device) -> Self {
        let fragment = wgpu::ShaderStages::FRAGMENT;
        let tex = |binding| {
            util::float_texture_entry(binding, fragment, false, wgpu::TextureViewDimension::D2)
        };
        let packed = wgpu::BindGroupLayoutEntry {
            binding: 6,
            visibility: fragment,
            ty: wgpu::BindingType::Texture {
                sample_type: wgpu::TextureSampleType::Uint,
                view_dimension: wgpu::TextureViewDimension::D2,
                multisampled: false,
            },
            count: None,
        };
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("sss"),
            entries: &[
                util::uniform_entry(0, fragment),
                tex(1),
                tex(2),
                tex(3),
                util::storage_entry(4, fragment),
                tex(5),
                packed,
            ],
        });
        let pipeline_layout = util::pipeline_layout(device, "sss", &[&layout]);
        Self {
            layout,
            pipeline_layout,
            modules: [None, None, None],
            render: Vec::new(),
            compute: None,
        }
    }

    /// Makes the compute steps' layouts (once); call before building their bind groups.
    pub fn prepare_compute(&mut self, device: &wgpu::Device) {
        if self.compute.is_none() {
            let layout = workgroup::layout(device);
            let pipeline_layout = util::pipeline_layout(device, "sss workgroup", &[&layout]);
            self.compute = Some(ComputeParts {
                layout,
                pipeline_layout,
                pipelines: Vec::new(),
                dummies: workgroup::Dummies::new(device),
            });
        }
    }

    /// Makes the pipeline of `key` unless it was made before.
    pub fn ensure_render(&mut self, device: &wgpu::Device, key: PipelineKey) {
        if self.render.iter().any(|(k, _)| *k == key) {
            return;
        }
        let module = self.module(device, key.fetch);
        let first = if key.packed_out {
            PACKED_FORMAT
        } else {
            FORMAT
        };
        let mut targets = vec![Some(wgpu::ColorTargetState::from(first))];
        if key.stage == Stage::Accumulate {
            targets.push(Some(util::additive_target(FORMAT)));
        }
        let pipeline = crate::passes::fullscreen::pipeline(
            device,
            &module,
            Some(&self.pipeline_layout),
            &key.entry_point(),
            &targets,
        );
        self.render.push((key, pipeline));
    }

    fn module(&mut self, device: &wgpu::Device, fetch: SssFetch) -> wgpu::ShaderModule {
        let (index, label, source) = match fetch {
            SssFetch::Direct => (0, "sss.wgsl", SHADER),
            SssFetch::Packed => (1, "sss.wgsl + sss_packed.wgsl", SHADER_PACKED),
            SssFetch::Workgroup => (2, "sss.wgsl + sss_workgroup.wgsl", SHADER_WORKGROUP),
        };
        self.modules[index]
            .get_or_insert_with(|| util::wgsl_module(device, label, source))
            .clone()
    }

    /// Makes the compute pipeline of `stage` (separable, fixed or jittered) that finds its
    /// texels as `fetch` says, unless made before.
    pub fn ensure_compute(&mut self, device: &wgpu::Device, stage: Stage, fetch: LineFetch) {
        self.prepare_compute(device);
        let key = (stage, fetch);
        let made = self.compute.as_ref().map(|c| &c.pipelines);
        if made.is_some_and(|p| p.iter().any(|(k, _)| *k == key)) {
            return;
        }
        let module = self.module(device, SssFetch::Workgroup);
        let entry = match stage {
            Stage::SeparableJitter => "cs_separable_jitter",
            _ => "cs_separable",
        };
        let parts = self.compute.as_mut().expect("prepared above");
        let layout = &parts.pipeline_layout;
        let pipeline = workgroup::pipeline(device, &module, layout, entry, fetch);
        parts.pipelines.push((key, pipeline));
    }

    pub fn render(&self, key: PipelineKey) -> &wgpu::RenderPipeline {
        let found = self.render.iter().find(|(k, _)| *k == key);
        &found.expect("resize makes every step's pipeline").1
    }

    pub fn compute(&self, stage: Stage, fetch: LineFetch) -> &wgpu::ComputePipeline {
        let parts = self.compute.as_ref();
        let key = (stage, fetch);
        let found = parts.and_then(|c| c.pipelines.iter().find(|(k, _)| *k == key));
        &found.expect("resize makes every step's pipeline").1
    }
}
