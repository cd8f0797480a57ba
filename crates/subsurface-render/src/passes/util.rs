//! Small constructors for the wgpu descriptors the passes repeat: bind group layout entries,
//! 2-D textures and their views, mesh pipelines and render pass attachments. Only the values
//! that differ between passes are parameters; everything else is what every pass used.

use wgpu::util::DeviceExt;

pub use crate::gpu::layout::{
    depth_array_entry, float_texture_entry, sampler_entry, storage_entry, storage_texture_entry,
    uniform_entry,
};
use crate::gpu::object::{GpuObject, VERTEX_LAYOUT};
pub use crate::gpu::supports_compute_storage;
use crate::lights::ShadowLayer;
use crate::timing::TimedPass;

/// Draws every object with `pipeline`, group 0 `frame` and each object's group 2 (`maps[i]`
/// for `objects[i]`, `default_maps` past them): the mesh passes on the lighting shader bind
/// the same groups.
pub fn draw_objects(
    pass: &mut wgpu::RenderPass<'_>,
    pipeline: &wgpu::RenderPipeline,
    frame: &wgpu::BindGroup,
    objects: &[GpuObject],
    maps: &[wgpu::BindGroup],
    default_maps: &wgpu::BindGroup,
) {
    pass.set_pipeline(pipeline);
    pass.set_bind_group(0, frame, &[]);
    for (i, o) in objects.iter().enumerate() {
        pass.set_bind_group(2, maps.get(i).unwrap_or(default_maps), &[]);
        o.draw(pass);
    }
}

/// The z-buffer of every depth-tested mesh pass without a stencil; [`depth_buffer`] and
/// [`MeshPipeline`] share it so that a pipeline always matches the buffer it is drawn with.
pub const ZBUFFER_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

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

/// The layouts of an image pass's one bind group, both named `label`: a uniform at `uniform`
/// then 2-D float textures at `textures` (unfilterable: read without a sampler), all read by
/// the fragment stage; and the pipeline layout of that group alone.
pub fn image_pass_layouts(
    device: &wgpu::Device,
    label: &str,
    uniform: u32,
    textures: &[u32],
) -> (wgpu::BindGroupLayout, wgpu::PipelineLayout) {
    let fragment = wgpu::ShaderStages::FRAGMENT;
    let entries: Vec<_> = std::iter::once(uniform_entry(uniform, fragment))
        .chain(textures.iter().map(|&binding| {
            float_texture_entry(binding, fragment, false, wgpu::TextureViewDimension::D2)
        }))
        .collect();
    let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some(label),
        entries: &entries,
    });
    let pipeline_layout = pipeline_layout(device, label, &[&layout]);
    (layout, pipeline_layout)
}

/// A bind group of `layout` with each `(binding, resource)` of `entries`.
pub fn bind_group<'a>(
    device: &wgpu::Device,
    label: &str,
    layout: &wgpu::BindGroupLayout,
    entries: impl IntoIterator<Item = (u32, wgpu::BindingResource<'a>)>,
) -> wgpu::BindGroup {
    let entries: Vec<_> = entries
        .into_iter()
        .map(|(binding, resource)| wgpu::BindGroupEntry { binding, resource })
        .collect();
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some(label),
        layout,
        entries: &entries,
    })
}

/// A bind group of [`image_pass_layouts`]' layout: the whole of `uniform.1` at binding
/// `uniform.0`, then each `(binding, view)` of `textures`.
pub fn image_pass_bind_group(
    device: &wgpu::Device,
    label: &str,
    layout: &wgpu::BindGroupLayout,
    uniform: (u32, &wgpu::Buffer),
    textures: &[(u32, &wgpu::TextureView)],
) -> wgpu::BindGroup {
    let views = textures
        .iter()
        .map(|&(binding, view)| (binding, wgpu::BindingResource::TextureView(view)));
    bind_group(
        device,
        label,
        layout,
        std::iter::once((uniform.0, uniform.1.as_entire_binding())).chain(views),
    )
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

/// A 1x1 texture's view, to fill a binding a pipeline does not read.
pub fn dummy_view(
    device: &wgpu::Device,
    label: &str,
    format: wgpu::TextureFormat,
    usage: wgpu::TextureUsages,
) -> wgpu::TextureView {
    texture_2d(device, label, 1, 1, 1, format, usage).create_view(&Default::default())
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
    render_target_with(
        device,
        label,
        width,
        height,
        format,
        wgpu::TextureUsages::empty(),
    )
}

/// A [`render_target`] with `extra` usages.
pub fn render_target_with(
    device: &wgpu::Device,
    label: &str,
    width: u32,
    height: u32,
    format: wgpu::TextureFormat,
    extra: wgpu::TextureUsages,
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
            | wgpu::TextureUsages::COPY_DST
            | extra,
    )
}

/// The z-buffer of a [`MeshPipeline`] with a [`DepthTest`]; only render passes use it, so it
/// is attachment-only.
pub fn depth_buffer(
    device: &wgpu::Device,
    label: &str,
    width: u32,
    height: u32,
    format: wgpu::TextureFormat,
) -> wgpu::TextureView {
    texture_2d(
        device,
        label,
        width,
        height,
        1,
        format,
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
/// vertex and fragment entry points into targets of `targets`' formats.
pub struct MeshPipeline<'a> {
    /// Names the pipeline in validation errors and captures.
    pub label: &'a str,
    /// The pipeline's bind group layouts.
    pub layout: &'a wgpu::PipelineLayout,
    /// The module holding both entry points.
    pub module: &'a wgpu::ShaderModule,
    /// Vertex entry point.
    pub vertex: &'a str,
    /// Fragment entry point.
    pub fragment: &'a str,
    /// One colour target per format, in location order.
    pub targets: &'a [wgpu::TextureFormat],
    /// Faces to cull; `None` draws both sides.
    pub cull_mode: Option<wgpu::Face>,
    /// How the pipeline uses its z-buffer.
    pub depth: DepthTest,
    /// The z-buffer's format with a stencil and the pipeline's stencil test; `None`:
    /// [`ZBUFFER_FORMAT`], no stencil.
    pub stencil: Option<(wgpu::TextureFormat, wgpu::StencilState)>,
    /// Values of the fragment stage's pipeline-overridable constants (WGSL `override`).
    pub constants: &'a [(&'a str, f64)],
    /// How every target blends what the fragment stage writes; `None` replaces it.
    pub blend: Option<wgpu::BlendState>,
}

/// How a [`MeshPipeline`] uses its [`depth_buffer`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DepthTest {
    /// No z-buffer: the last triangle drawn wins.
    Off,
    /// Keep the nearest surface (less, with depth writes).
    Nearest,
    /// After a depth pre-pass of the same vertex stage: shade only the fragment whose depth
    /// the pre-pass kept (equal, no writes), so each pixel is shaded once whatever the
    /// triangle order.
    Prepassed,
}

impl MeshPipeline<'_> {
    /// Builds the render pipeline.
    pub fn create(&self, device: &wgpu::Device) -> wgpu::RenderPipeline {
        let targets: Vec<_> = self
            .targets
            .iter()
            .map(|&format| {
                Some(wgpu::ColorTargetState {
                    format,
                    blend: self.blend,
                    write_mask: wgpu::ColorWrites::ALL,
                })
            })
            .collect();
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
            depth_stencil: depth_state(self.depth, self.stencil.clone()),
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: self.module,
                entry_point: Some(self.fragment),
                compilation_options: wgpu::PipelineCompilationOptions {
                    constants: self.constants,
                    ..Default::default()
                },
                targets: &targets,
            }),
            multiview_mask: None,
            cache: None,
        })
    }
}

/// A depth-only pipeline (no fragment stage, no culling) with `module`'s `vertex` entry point
/// writing the nearest surface, for a [`DepthTest::Prepassed`] pipeline of the same vertex
/// stage to test against.
pub fn depth_prepass_pipeline(
    device: &wgpu::Device,
    layout: &wgpu::PipelineLayout,
    module: &wgpu::ShaderModule,
    vertex: &str,
    format: wgpu::TextureFormat,
) -> wgpu::RenderPipeline {
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some("depth prepass"),
        layout: Some(layout),
        vertex: wgpu::VertexState {
            module,
            entry_point: Some(vertex),
            compilation_options: Default::default(),
            buffers: &[Some(VERTEX_LAYOUT)],
        },
        primitive: Default::default(),
        depth_stencil: depth_state(DepthTest::Nearest, Some((format, Default::default()))),
        multisample: Default::default(),
        fragment: None,
        multiview_mask: None,
        cache: None,
    })
}

/// The depth state of `depth` (None for [`DepthTest::Off`]) on a z-buffer of
/// [`ZBUFFER_FORMAT`], or of `stencil`'s format with its stencil test.
pub fn depth_state(
    depth: DepthTest,
    stencil: Option<(wgpu::TextureFormat, wgpu::StencilState)>,
) -> Option<wgpu::DepthStencilState> {
    let (write, compare) = match depth {
        DepthTest::Off => return None,
        DepthTest::Nearest => (true, wgpu::CompareFunction::Less),
        DepthTest::Prepassed => (false, wgpu::CompareFunction::Equal),
    };
    let (format, stencil) = stencil.unwrap_or((ZBUFFER_FORMAT, Default::default()));
    Some(wgpu::DepthStencilState {
        format,
        depth_write_enabled: Some(write),
        depth_compare: Some(compare),
        stencil,
        bias: Default::default(),
    })
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

/// A [`depth_buffer`] attachment: `load` (cleared to the far plane, or kept from an earlier
/// pass) and `store` (kept for a later pass, or discarded).
pub fn depth_attachment(
    view: &wgpu::TextureView,
    load: wgpu::LoadOp<f32>,
    store: wgpu::StoreOp,
) -> Option<wgpu::RenderPassDepthStencilAttachment<'_>> {
    Some(wgpu::RenderPassDepthStencilAttachment {
        view,
        depth_ops: Some(wgpu::Operations { load, store }),
        stencil_ops: None,
    })
}

/// A render pass `label` drawing into `colors` only (no depth), timed by `timestamp_writes`:
/// the image passes.
pub fn color_pass<'e>(
    encoder: &'e mut wgpu::CommandEncoder,
    label: &str,
    colors: &[Option<wgpu::RenderPassColorAttachment<'_>>],
    timestamp_writes: Option<wgpu::RenderPassTimestampWrites<'_>>,
) -> wgpu::RenderPass<'e> {
    render_pass(encoder, label, colors, None, timestamp_writes)
}

/// A render pass `label` into `colors` and `depth` ([`depth_attachment`]), timed by
/// `timestamp_writes`: what every pass of the renderer begins with.
pub fn render_pass<'e>(
    encoder: &'e mut wgpu::CommandEncoder,
    label: &str,
    colors: &[Option<wgpu::RenderPassColorAttachment<'_>>],
    depth: Option<wgpu::RenderPassDepthStencilAttachment<'_>>,
    timestamp_writes: Option<wgpu::RenderPassTimestampWrites<'_>>,
) -> wgpu::RenderPass<'e> {
    encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some(label),
        color_attachments: colors,
        depth_stencil_attachment: depth,
        timestamp_writes,
        occlusion_query_set: None,
        multiview_mask: None,
    })
}

/// A render pass `label` with no colour target, writing depth to `view` after `load`, timed by
/// `timestamp_writes`: a shadow map drawn, or one cleared.
pub fn depth_pass<'e>(
    encoder: &'e mut wgpu::CommandEncoder,
    label: &str,
    view: &wgpu::TextureView,
    load: wgpu::LoadOp<f32>,
    timestamp_writes: Option<wgpu::RenderPassTimestampWrites<'_>>,
) -> wgpu::RenderPass<'e> {
    render_pass(
        encoder,
        label,
        &[],
        depth_attachment(view, load, wgpu::StoreOp::Store),
        timestamp_writes,
    )
}

/// What differs between the passes that draw the objects once per shadow layer into that
/// layer of an array atlas (the shadow maps and the translucent shadow maps).
pub struct LayeredPassDesc<'a> {
    /// Names the pipeline, the render and timed passes; "{label} view" the per-layer light
    /// camera uniform, "{label} depth" the z-buffer and "{label}.wgsl" the shader.
    pub label: &'static str,
    /// Names the atlas texture.
    pub atlas_label: &'a str,
    /// WGSL source of the pass.
    pub shader: &'a str,
    /// Vertex entry point.
    pub vertex: &'a str,
    /// Fragment entry point.
    pub fragment: &'a str,
    /// The atlas's texel format.
    pub format: wgpu::TextureFormat,
    /// Binding (in group 0) and stages of the light camera uniform; the objects are group 1.
    pub view_binding: u32,
    /// Shader stages that read the light camera uniform.
    pub view_visibility: wgpu::ShaderStages,
    /// What texels where nothing is drawn hold.
    pub clear: wgpu::Color,
    /// Keep each layer's z-buffer (Depth32Float, one array layer per shadow layer) for later
    /// passes to sample with a comparison sampler (hardware PCF), instead of one discarded
    /// z-buffer for all layers.
    pub sampled_depth: bool,
}

/// One shadow layer of a [`LayeredPass`]: its size in texels, its light camera and the atlas
/// layer it renders to.
struct AtlasLayer {
    size: u32,
    view_buffer: wgpu::Buffer,
    bind_group: wgpu::BindGroup,
    target: wgpu::TextureView,
    /// Its own layer of the kept z-buffer, or the shared discarded one.
    depth: wgpu::TextureView,
}

/// The objects drawn without culling and depth-tested into one atlas layer per shadow layer,
/// each through its own light camera.
pub struct LayeredPass {
    label: &'static str,
    clear: wgpu::Color,
    pipeline: wgpu::RenderPipeline,
    layers: Vec<AtlasLayer>,
    /// `atlas_size` texels square, one layer per shadow layer (at least one).
    pub atlas: wgpu::Texture,
    /// All of `atlas` as a `texture_2d_array`.
    pub atlas_view: wgpu::TextureView,
    /// With `sampled_depth`: the kept z-buffer as a `texture_depth_2d_array` (the projected
    /// depth of the surface nearest the light, same layers as `atlas`).
    pub depth_view: Option<wgpu::TextureView>,
}

impl LayeredPass {
    /// `uniform` is each layer's light camera.
    pub fn new<U: bytemuck::Pod>(
        device: &wgpu::Device,
        desc: &LayeredPassDesc,
        object_layout: &wgpu::BindGroupLayout,
        layers: &[ShadowLayer],
        atlas_size: u32,
        uniform: impl Fn(&ShadowLayer) -> U,
    ) -> Self {
        let label = desc.label;
        let view_label = format!("{label} view");
        let module = wgsl_module(device, &format!("{label}.wgsl"), desc.shader);
        let view_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some(&view_label),
            entries: &[uniform_entry(desc.view_binding, desc.view_visibility)],
        });
        let layout = pipeline_layout(device, label, &[&view_layout, object_layout]);
        let pipeline = MeshPipeline {
            label,
            layout: &layout,
            module: &module,
            vertex: desc.vertex,
            fragment: desc.fragment,
            targets: &[desc.format],
            // No culling: thickness needs the surface nearest the light whichever way it faces.
            cull_mode: None,
            depth: DepthTest::Nearest,
            stencil: None,
            constants: &[],
            blend: None,
        }
        .create(device);
        let size = atlas_size.max(1);
        let atlas = texture_2d(
            device,
            desc.atlas_label,
            size,
            size,
            layers.len().max(1) as u32,
            desc.format,
            wgpu::TextureUsages::RENDER_ATTACHMENT
                | wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::COPY_SRC,
        );
        let depth_label = format!("{label} depth");
        let kept_depth = desc.sampled_depth.then(|| {
            texture_2d(
                device,
                &depth_label,
                size,
                size,
                layers.len().max(1) as u32,
                ZBUFFER_FORMAT,
                wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
            )
        });
        // Without a kept z-buffer the layers share one, cleared for each.
        let layer_depths: Vec<wgpu::TextureView> = match &kept_depth {
            Some(kept) => (0..layers.len() as u32)
                .map(|i| layer_view(kept, i))
                .collect(),
            None => {
                let zbuffer = depth_buffer(device, &depth_label, size, size, ZBUFFER_FORMAT);
                vec![zbuffer; layers.len()]
            }
        };
        let layers = layers
            .iter()
            .enumerate()
            .map(|(i, l)| {
                let view_buffer = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some(&view_label),
                    contents: bytemuck::bytes_of(&uniform(l)),
                    usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                });
                let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some(&view_label),
                    layout: &view_layout,
                    entries: &[wgpu::BindGroupEntry {
                        binding: desc.view_binding,
                        resource: view_buffer.as_entire_binding(),
                    }],
                });
                AtlasLayer {
                    size: l.size,
                    view_buffer,
                    bind_group,
                    target: layer_view(&atlas, i as u32),
                    depth: layer_depths[i].clone(),
                }
            })
            .collect();
        Self {
            label,
            clear: desc.clear,
            pipeline,
            layers,
            atlas_view: array_view(&atlas),
            atlas,
            depth_view: kept_depth.as_ref().map(array_view),
        }
    }

    /// Moves the light cameras (same layers and sizes as at creation).
    pub fn move_cameras<U: bytemuck::Pod>(
        &mut self,
        queue: &wgpu::Queue,
        layers: &[ShadowLayer],
        uniform: impl Fn(&ShadowLayer) -> U,
    ) {
        for (layer, new) in self.layers.iter_mut().zip(layers) {
            layer.size = new.size;
            queue.write_buffer(&layer.view_buffer, 0, bytemuck::bytes_of(&uniform(new)));
        }
    }

    /// Number of layers rendered each frame.
    pub fn layer_count(&self) -> usize {
        self.layers.len()
    }

    /// Renders every layer, each in its own timed render pass named after the pass.
    pub fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        objects: &[GpuObject],
        profiler: Option<&wgpu_profiler::GpuProfiler>,
    ) {
        for layer in &self.layers {
            let timer = TimedPass::begin(profiler, self.label, encoder);
            {
                let mut pass = render_pass(
                    encoder,
                    self.label,
                    &[color_attachment(
                        &layer.target,
                        wgpu::LoadOp::Clear(self.clear),
                    )],
                    depth_attachment(
                        &layer.depth,
                        wgpu::LoadOp::Clear(1.0),
                        if self.depth_view.is_some() {
                            wgpu::StoreOp::Store
                        } else {
                            wgpu::StoreOp::Discard
                        },
                    ),
                    timer.writes(),
                );
                let size = layer.size;
                pass.set_viewport(0.0, 0.0, size as f32, size as f32, 0.0, 1.0);
                pass.set_scissor_rect(0, 0, size, size);
                pass.set_pipeline(&self.pipeline);
                pass.set_bind_group(0, &layer.bind_group, &[]);
                for o in objects {
                    o.draw(&mut pass);
                }
            }
            timer.end(profiler, encoder);
        }
    }
}
