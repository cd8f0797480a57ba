//! Small constructors for the wgpu descriptors the passes repeat: bind group layout entries,
//! 2-D textures and their views, mesh pipelines and render pass attachments. Only the values
//! that differ between passes are parameters; everything else is what every pass used.

pub use crate::gpu::layout::{float_texture_entry, sampler_entry, storage_entry, uniform_entry};
use crate::gpu_scene::VERTEX_LAYOUT;

/// The z-buffer of every depth-tested mesh pass; [`depth_buffer`] and [`MeshPipeline`] share it
/// so that a pipeline always matches the buffer it is drawn with.
const ZBUFFER_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// A WGSL shader module; `label` names it in validation errors.
pub fn wgsl_module(device: &wgpu::Device, label: &str, source: &str) -> wgpu::ShaderModule {
    device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(label),
        source: wgpu::ShaderSource::Wgsl(source.into()),
    })
}

/// A pipeline layout of `groups` in order (group 0 first), without immediates.
pub fn pipeline_layout(
    device: &wgpu::Device,
    label: &str,
    groups: &[&wgpu::BindGroupLayout],
) -> wgpu::PipelineLayout {
    let groups: Vec<_> = groups.iter().copied().map(Some).collect();
    device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(label),
        bind_group_layouts: &groups,
        immediate_size: 0,
    })
}

/// A 2-D texture with one mip level and one sample; `layers` > 1 makes an array.
pub fn texture_2d(
    device: &wgpu::Device,
    label: &str,
    width: u32,
    height: u32,
    layers: u32,
    format: wgpu::TextureFormat,
    usage: wgpu::TextureUsages,
) -> wgpu::Texture {
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: layers,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage,
        view_formats: &[],
    })
}

/// A render target that later passes sample; the copy usages let it be read back and stand as
/// either end of a texture copy.
pub fn render_target(
    device: &wgpu::Device,
    label: &str,
    width: u32,
    height: u32,
    format: wgpu::TextureFormat,
) -> wgpu::Texture {
    texture_2d(
        device,
        label,
        width,
        height,
        1,
        format,
        wgpu::TextureUsages::RENDER_ATTACHMENT
            | wgpu::TextureUsages::TEXTURE_BINDING
            | wgpu::TextureUsages::COPY_SRC
            | wgpu::TextureUsages::COPY_DST,
    )
}

/// The z-buffer of a [`MeshPipeline`] with `depth_test`; only the render pass uses it, so it
/// is attachment-only and its contents are discarded (see [`depth_attachment`]).
pub fn depth_buffer(
    device: &wgpu::Device,
    label: &str,
    width: u32,
    height: u32,
) -> wgpu::TextureView {
    texture_2d(
        device,
        label,
        width,
        height,
        1,
        ZBUFFER_FORMAT,
        wgpu::TextureUsages::RENDER_ATTACHMENT,
    )
    .create_view(&Default::default())
}

/// All layers of `texture` as one `texture_2d_array` view, also when there is only one layer
/// (a default view of a one-layer texture would be a plain 2-D view).
pub fn array_view(texture: &wgpu::Texture) -> wgpu::TextureView {
    texture.create_view(&wgpu::TextureViewDescriptor {
        dimension: Some(wgpu::TextureViewDimension::D2Array),
        ..Default::default()
    })
}

/// Layer `layer` of an array texture as a 2-D view, to render into that layer alone.
pub fn layer_view(texture: &wgpu::Texture, layer: u32) -> wgpu::TextureView {
    texture.create_view(&wgpu::TextureViewDescriptor {
        dimension: Some(wgpu::TextureViewDimension::D2),
        base_array_layer: layer,
        array_layer_count: Some(1),
        ..Default::default()
    })
}

/// A target that sums what is drawn into it (one + one) in colour and keeps the alpha written
/// last: the Gaussian passes accumulate their weighted blurs this way.
pub fn additive_target(format: wgpu::TextureFormat) -> wgpu::ColorTargetState {
    wgpu::ColorTargetState {
        format,
        blend: Some(wgpu::BlendState {
            color: wgpu::BlendComponent {
                src_factor: wgpu::BlendFactor::One,
                dst_factor: wgpu::BlendFactor::One,
                operation: wgpu::BlendOperation::Add,
            },
            alpha: wgpu::BlendComponent::REPLACE,
        }),
        write_mask: wgpu::ColorWrites::ALL,
    }
}

/// A pipeline that draws `GpuObject` meshes (vertex buffer [`VERTEX_LAYOUT`]) with one module's
/// vertex and fragment entry points into unblended targets of `targets`' formats.
pub struct MeshPipeline<'a> {
    pub label: &'a str,
    pub layout: &'a wgpu::PipelineLayout,
    pub module: &'a wgpu::ShaderModule,
    pub vertex: &'a str,
    pub fragment: &'a str,
    pub targets: &'a [wgpu::TextureFormat],
    pub cull_mode: Option<wgpu::Face>,
    /// Keep the nearest surface (less, with depth writes) in a [`depth_buffer`]; without it
    /// the last triangle drawn wins.
    pub depth_test: bool,
}

impl MeshPipeline<'_> {
    pub fn create(&self, device: &wgpu::Device) -> wgpu::RenderPipeline {
        let targets: Vec<_> = self.targets.iter().map(|&f| Some(f.into())).collect();
        device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some(self.label),
            layout: Some(self.layout),
            vertex: wgpu::VertexState {
                module: self.module,
                entry_point: Some(self.vertex),
                compilation_options: Default::default(),
                buffers: &[Some(VERTEX_LAYOUT)],
            },
            primitive: wgpu::PrimitiveState {
                cull_mode: self.cull_mode,
                ..Default::default()
            },
            depth_stencil: self.depth_test.then(|| wgpu::DepthStencilState {
                format: ZBUFFER_FORMAT,
                depth_write_enabled: Some(true),
                depth_compare: Some(wgpu::CompareFunction::Less),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: self.module,
                entry_point: Some(self.fragment),
                compilation_options: Default::default(),
                targets: &targets,
            }),
            multiview_mask: None,
            cache: None,
        })
    }
}

/// A single-sampled colour attachment whose result is stored for the passes after it.
pub fn color_attachment(
    view: &wgpu::TextureView,
    load: wgpu::LoadOp<wgpu::Color>,
) -> Option<wgpu::RenderPassColorAttachment<'_>> {
    Some(wgpu::RenderPassColorAttachment {
        view,
        depth_slice: None,
        resolve_target: None,
        ops: wgpu::Operations {
            load,
            store: wgpu::StoreOp::Store,
        },
    })
}

/// A [`depth_buffer`] cleared to the far plane; its contents are discarded after the pass,
/// since no later pass reads them.
pub fn depth_attachment(
    view: &wgpu::TextureView,
) -> Option<wgpu::RenderPassDepthStencilAttachment<'_>> {
    Some(wgpu::RenderPassDepthStencilAttachment {
        view,
        depth_ops: Some(wgpu::Operations {
            load: wgpu::LoadOp::Clear(1.0),
            store: wgpu::StoreOp::Discard,
        }),
        stencil_ops: None,
    })
}
