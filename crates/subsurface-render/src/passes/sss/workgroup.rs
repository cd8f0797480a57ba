//! The workgroup fetch's compute passes of Separable SSS (`sss_workgroup.wgsl`): a workgroup
//! of [`LINE_TILE`] invocations per stretch of a row (horizontal pass) or column (vertical
//! pass), which loads the stretch and an apron once into workgroup memory.

use crate::passes::util;

/// Pixels per workgroup along the line (`LINE_TILE` in sss_workgroup.wgsl).
pub const LINE_TILE: u32 = 128;
/// Texels a workgroup loads: its pixels and a 64-texel apron each side (`LINE_SPAN`).
pub const LINE_SPAN: u32 = 256;

/// Group 0 of the compute passes: the uniform, the profile table, the packed input and the
/// two outputs (packed for the vertical pass, colour for the result).
pub fn layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    let compute = wgpu::ShaderStages::COMPUTE;
    let storage = |binding, format| {
        util::storage_texture_entry(binding, compute, format, wgpu::TextureViewDimension::D2)
    };
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("sss workgroup"),
        entries: &[
            util::uniform_entry(0, compute),
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

/// 1x1 stand-ins for the output a pass does not write (the layout binds both).
pub struct Dummies {
    pub packed: wgpu::TextureView,
    pub color: wgpu::TextureView,
}

impl Dummies {
    pub fn new(device: &wgpu::Device) -> Self {
        let storage = wgpu::TextureUsages::STORAGE_BINDING;
        let make = |format| util::dummy_view(device, "sss workgroup dummy", format, storage);
        Self {
            packed: make(super::PACKED_FORMAT),
            color: make(super::FORMAT),
        }
    }
}

pub struct BindGroupDesc<'a> {
    pub uniform: &'a wgpu::Buffer,
    pub table: &'a wgpu::Buffer,
    pub input: &'a wgpu::TextureView,
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
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("sss workgroup"),
        layout,
        entries: &[
            entry(0, d.uniform.as_entire_binding()),
            entry(4, d.table.as_entire_binding()),
            entry(6, tex(d.input)),
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
) -> wgpu::ComputePipeline {
    device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(entry),
        layout: Some(layout),
        module,
        entry_point: Some(entry),
        compilation_options: Default::default(),
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
