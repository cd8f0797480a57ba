//! The workgroup fetch's compute passes of Separable SSS (`sss_workgroup.wgsl`): a workgroup
//! of [`LINE_TILE`] invocations per stretch of a row (horizontal pass) or column (vertical
//! pass), which loads the stretch and an apron once into workgroup memory on a GPU
//! ([`LineFetch`]).

use crate::passes::util;

/// Pixels per workgroup along the line (`LINE_TILE` in sss_workgroup.wgsl).
pub const LINE_TILE: u32 = 128;
/// Texels a workgroup loads: its pixels and a 64-texel apron each side (`LINE_SPAN`).
pub const LINE_SPAN: u32 = 256;

/// Whether the workgroup fetch's first pass should pack its texels as it loads them into
/// workgroup memory on this device, rather than after a pack step. On a GPU it should: the
/// pack step is a full-screen fragment pass, and on the H200 it cost five times the two compute
/// passes (0.26 of 0.31 ms at 1920x1080, docs/lab/performance.md, session 28). On a CPU
/// rasteriser (lavapipe) it should not: llvmpipe runs both sides of a branch, so the fetch of
/// a tap past the workgroup's apron, which then reads three textures instead of one packed
/// texel, runs for every tap, and the blur took twice as long (13.2 against 6.3 ms at 640x360).
/// Without packing on load the passes read the packed texels straight from the texture
/// ([`LineFetch::Texture`]).
pub fn pack_on_load_suits(device: &wgpu::Device) -> bool {
    device.adapter_info().device_type != wgpu::DeviceType::Cpu
}

/// Where a compute pass's taps find their texels; the same texels, so the same image.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LineFetch {
    /// In workgroup memory, which the workgroup fills from the three inputs, packing each
    /// texel as it loads it (the first pass on a GPU).
    PackOnLoad,
    /// In workgroup memory, which the workgroup fills from the packed texels (the second pass
    /// on a GPU).
    Shared,
    /// In the packed texture, one load per tap, with no workgroup memory (both passes after a
    /// pack step, on a CPU adapter): llvmpipe gathers a vector's workgroup-memory words lane by
    /// lane, and reading the taps from the texture instead took the two passes from 15-20 to
    /// 8-10.5 ms at 640x360 (docs/lab/performance.md, session 38).
    Texture,
}

impl LineFetch {
    /// The pipeline-overridable constants of sss_workgroup.wgsl that select it.
    fn constants(self) -> [(&'static str, f64); 2] {
        let flag = |on: bool| f64::from(u8::from(on));
        [
            ("FROM_INPUTS", flag(self == LineFetch::PackOnLoad)),
            ("LINE_SHARED", flag(self != LineFetch::Texture)),
        ]
    }
}

#[derive(Clone, Copy)]
pub struct Dispatch {
    /// Along rows (the first pass) or columns (reading the first pass's output).
    pub horizontal: bool,
    /// Where its taps find their texels.
    pub fetch: LineFetch,
}

/// Group 0 of the compute passes: the uniform, the three inputs (colour, depth, SSS data: the
/// horizontal pass packs them as it loads), the profile table, the packed input (the vertical
/// pass's) and the two outputs (packed for the vertical pass, colour for the result).
pub fn layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    let compute = wgpu::ShaderStages::COMPUTE;
    let storage = |binding, format| {
        util::storage_texture_entry(binding, compute, format, wgpu::TextureViewDimension::D2)
    };
    let float = |binding| {
        util::float_texture_entry(binding, compute, false, wgpu::TextureViewDimension::D2)
    };
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("sss workgroup"),
        entries: &[
            util::uniform_entry(0, compute),
            float(1),
            float(2),
            float(3),
            util::storage_entry(4, compute),
            wgpu::BindGroupLayoutEntry {
                binding: 6,
                visibility: compute,
                ty: wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Uint,
                    view_dimension: wgpu::TextureViewDimension::D2,
                    multisampled: false,
                },
                count: None,
            },
            storage(7, super::PACKED_FORMAT),
            storage(8, super::FORMAT),
        ],
    })
}

/// 1x1 stand-ins for the output a pass does not write and the inputs it does not read (the
/// layout binds them all).
pub struct Dummies {
    pub packed: wgpu::TextureView,
    pub color: wgpu::TextureView,
    pub packed_in: wgpu::TextureView,
    pub float_in: wgpu::TextureView,
}

impl Dummies {
    pub fn new(device: &wgpu::Device) -> Self {
        let storage = wgpu::TextureUsages::STORAGE_BINDING;
        let sampled = wgpu::TextureUsages::TEXTURE_BINDING;
        let make = |format, usage| util::dummy_view(device, "sss workgroup dummy", format, usage);
        Self {
            packed: make(super::PACKED_FORMAT, storage),
            color: make(super::FORMAT, storage),
            packed_in: make(super::PACKED_FORMAT, sampled),
            float_in: make(super::FORMAT, sampled),
        }
    }
}

/// What a pass reads: the three inputs, packed as loaded (the horizontal pass), or the previous
/// pass's packed texels.
pub enum LineInput<'a> {
    Inputs {
        color: &'a wgpu::TextureView,
        depth: &'a wgpu::TextureView,
        sss: &'a wgpu::TextureView,
    },
    Packed(&'a wgpu::TextureView),
}

pub struct BindGroupDesc<'a> {
    pub uniform: &'a wgpu::Buffer,
    pub table: &'a wgpu::Buffer,
    pub input: LineInput<'a>,
    pub dummies: &'a Dummies,
    pub out_packed: &'a wgpu::TextureView,
    pub out_color: &'a wgpu::TextureView,
}

pub fn bind_group(
    device: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    d: &BindGroupDesc<'_>,
) -> wgpu::BindGroup {
    let entry = |binding, resource| wgpu::BindGroupEntry { binding, resource };
    let tex = wgpu::BindingResource::TextureView;
    let f = &d.dummies.float_in;
    let ([color, depth, sss], packed) = match d.input {
        LineInput::Inputs { color, depth, sss } => ([color, depth, sss], &d.dummies.packed_in),
        LineInput::Packed(packed) => ([f, f, f], packed),
    };
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("sss workgroup"),
        layout,
        entries: &[
            entry(0, d.uniform.as_entire_binding()),
            entry(1, tex(color)),
            entry(2, tex(depth)),
            entry(3, tex(sss)),
            entry(4, d.table.as_entire_binding()),
            entry(6, tex(packed)),
            entry(7, tex(d.out_packed)),
            entry(8, tex(d.out_color)),
        ],
    })
}

pub fn pipeline(
    device: &wgpu::Device,
    module: &wgpu::ShaderModule,
    layout: &wgpu::PipelineLayout,
    entry: &str,
    fetch: LineFetch,
) -> wgpu::ComputePipeline {
    device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(entry),
        layout: Some(layout),
        module,
        entry_point: Some(entry),
        compilation_options: wgpu::PipelineCompilationOptions {
            constants: &fetch.constants(),
            // Every invocation writes its texels of the line before the barrier.
            zero_initialize_workgroup_memory: false,
        },
        cache: None,
    })
}

/// Workgroups of a pass over `width` x `height` lines along x (`horizontal`) or y.
pub fn dispatch(width: u32, height: u32, horizontal: bool) -> [u32; 2] {
    let (along, across) = if horizontal {
        (width, height)
    } else {
        (height, width)
    };
    [along.div_ceil(LINE_TILE), across]
}
