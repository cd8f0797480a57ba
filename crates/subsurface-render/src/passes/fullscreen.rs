//! The full-screen-triangle pipeline that the image passes (SSS, tone map, copy) share: their
//! WGSL is `fullscreen.wgsl` (which declares `vs_fullscreen`) followed by their own, and only
//! the fragment entry point and targets differ.

/// The WGSL of the vertex stage, `vs_fullscreen`: put it before a fragment shader of your own
/// to draw with [`pipeline`].
pub const VERTEX_WGSL: &str = include_str!("fullscreen.wgsl");

/// Blending that adds the colour a pass writes to what the target holds and keeps the target's
/// alpha: a term drawn on top of another pass's result (the outline pass's chords, the
/// unscattered light a renderer adds after its blur).
pub const ADD: wgpu::BlendState = wgpu::BlendState {
    color: wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::One,
        dst_factor: wgpu::BlendFactor::One,
        operation: wgpu::BlendOperation::Add,
    },
    alpha: wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::Zero,
        dst_factor: wgpu::BlendFactor::One,
        operation: wgpu::BlendOperation::Add,
    },
};

/// A pipeline drawing one full-screen triangle (3 vertices, no vertex buffer) with
/// `module`'s `vs_fullscreen` and the fragment entry point `fragment`. `layout: None` lets
/// wgpu derive the bind group layouts from the shader.
pub fn pipeline(
    device: &wgpu::Device,
    module: &wgpu::ShaderModule,
    layout: Option<&wgpu::PipelineLayout>,
    fragment: &str,
    targets: &[Option<wgpu::ColorTargetState>],
) -> wgpu::RenderPipeline {
    pipeline_with(device, module, layout, fragment, targets, &[], None)
}

/// As [`pipeline`], with the fragment stage's WGSL overrides set to `constants` and, where
/// given, a z-buffer of `depth_stencil`'s state (its stencil, say).
pub fn pipeline_with(
    device: &wgpu::Device,
    module: &wgpu::ShaderModule,
    layout: Option<&wgpu::PipelineLayout>,
    fragment: &str,
    targets: &[Option<wgpu::ColorTargetState>],
    constants: &[(&str, f64)],
    depth_stencil: Option<wgpu::DepthStencilState>,
) -> wgpu::RenderPipeline {
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(fragment),
        layout,
        vertex: wgpu::VertexState {
            module,
            entry_point: Some("vs_fullscreen"),
            compilation_options: Default::default(),
            buffers: &[],
        },
        primitive: Default::default(),
        depth_stencil,
        multisample: Default::default(),
        fragment: Some(wgpu::FragmentState {
            module,
            entry_point: Some(fragment),
            compilation_options: wgpu::PipelineCompilationOptions {
                constants,
                ..Default::default()
            },
            targets,
        }),
        multiview_mask: None,
        cache: None,
    })
}
