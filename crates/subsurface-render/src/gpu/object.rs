//! A drawable object on the GPU: its vertex layout, the bind-group layout of its uniform and
//! material maps (group 1 of every mesh pass), and its buffers.

use crate::gpu::layout;
use crate::mesh::Vertex;

/// Vertex buffer layout of [`Vertex`]: position, normal, uv, tangent at locations 0..=3.
pub const VERTEX_LAYOUT: wgpu::VertexBufferLayout<'static> = wgpu::VertexBufferLayout {
    array_stride: std::mem::size_of::<Vertex>() as u64,
    step_mode: wgpu::VertexStepMode::Vertex,
    attributes: &wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Float32x2, 3 => Float32x4],
};

/// Bind group layout of group 1 (`Object` + material maps), shared by shadow and lighting.
pub fn object_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    // Compute too: the transmitted map's evaluation (transmitted_map.wgsl, `cs_transmitted`) reads the
    // object's uniform and LUT.
    let fragment = wgpu::ShaderStages::FRAGMENT | wgpu::ShaderStages::COMPUTE;
    let tex = |binding| {
        layout::float_texture_entry(binding, fragment, true, wgpu::TextureViewDimension::D2)
    };
    let sampler =
        |binding| layout::sampler_entry(binding, fragment, wgpu::SamplerBindingType::Filtering);
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("object"),
        entries: &[
            layout::uniform_entry(
                0,
                wgpu::ShaderStages::VERTEX_FRAGMENT | wgpu::ShaderStages::COMPUTE,
            ),
            tex(1),
            tex(2),
            tex(3),
            sampler(4),
            tex(5),
            sampler(6),
        ],
    })
}

/// An object's mesh and material on the GPU, drawn by every mesh pass.
pub struct GpuObject {
    /// [`Vertex`] buffer, object space.
    pub vertices: wgpu::Buffer,
    /// Triangle list indices, `u32`.
    pub indices: wgpu::Buffer,
    /// Indices drawn: three per triangle.
    pub index_count: u32,
    /// The object's [`crate::uniforms::ObjectUniform`].
    pub uniform: wgpu::Buffer,
    /// Group 1 of the mesh passes: the uniform and the material maps ([`object_layout`]).
    pub bind_group: wgpu::BindGroup,
}

impl GpuObject {
    /// Binds group 1 and the buffers, and draws the mesh once.
    pub fn draw(&self, pass: &mut wgpu::RenderPass<'_>) {
        pass.set_bind_group(1, &self.bind_group, &[]);
        pass.set_vertex_buffer(0, self.vertices.slice(..));
        pass.set_index_buffer(self.indices.slice(..), wgpu::IndexFormat::Uint32);
        pass.draw_indexed(0..self.index_count, 0, 0..1);
    }
}
