//! The full-screen-triangle pipeline that the image passes (SSS, tone map, copy) share: their
//! WGSL is `fullscreen.wgsl` (which declares `vs_fullscreen`) followed by their own, and only
//! the fragment entry point and targets differ.

/// The WGSL of the vertex stage, `vs_fullscreen`: put it before a fragment shader of your own
/// to draw with [`pipeline`].
pub const VERTEX_WGSL: &str = include_str!("fullscreen.wgsl");

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
    pipeline_with_constants(device, module, layout, fragment, targets, &[])
}

/// As [`pipeline`], with the fragment stage's WGSL overrides set to `constants`.
pub fn pipeline_with_constants(
    device: &wgpu::Device,
    module: &wgpu::ShaderModule,
    layout: Option<&wgpu::PipelineLayout>,
    fragment: &str,
    targets: &[Option<wgpu::ColorTargetState>],
    constants: &[(&str, f64)],
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
        depth_stencil: None,
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
