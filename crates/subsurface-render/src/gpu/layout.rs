//! Bind group layout entries, the lowest layer every GPU module builds on (it imports none).

/// The entry at `binding` of one (not an array of) `ty`.
fn entry(
    binding: u32,
    visibility: wgpu::ShaderStages,
    ty: wgpu::BindingType,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty,
        count: None,
    }
}

/// A buffer of `ty` bound whole (no dynamic offset, size checked by the shader).
fn whole_buffer(ty: wgpu::BufferBindingType) -> wgpu::BindingType {
    wgpu::BindingType::Buffer {
        ty,
        has_dynamic_offset: false,
        min_binding_size: None,
    }
}

/// A single-sampled texture of `sample_type`.
fn texture(
    sample_type: wgpu::TextureSampleType,
    view_dimension: wgpu::TextureViewDimension,
) -> wgpu::BindingType {
    wgpu::BindingType::Texture {
        sample_type,
        view_dimension,
        multisampled: false,
    }
}

/// A uniform buffer at `binding`, bound whole (no dynamic offset, size checked by the shader).
pub fn uniform_entry(binding: u32, visibility: wgpu::ShaderStages) -> wgpu::BindGroupLayoutEntry {
    let ty = whole_buffer(wgpu::BufferBindingType::Uniform);
    entry(binding, visibility, ty)
}

/// A single-sampled float texture at `binding`. `filterable: false` admits 32-bit float
/// formats, which are not filterable without an optional feature; those are read with
/// `textureLoad` or a non-filtering sampler.
pub fn float_texture_entry(
    binding: u32,
    visibility: wgpu::ShaderStages,
    filterable: bool,
    view_dimension: wgpu::TextureViewDimension,
) -> wgpu::BindGroupLayoutEntry {
    let sample_type = wgpu::TextureSampleType::Float { filterable };
    entry(binding, visibility, texture(sample_type, view_dimension))
}

/// A depth texture array at `binding` (`texture_depth_2d_array`): shadow maps' z-buffers, read
/// with `textureLoad` or through a comparison sampler.
pub fn depth_array_entry(
    binding: u32,
    visibility: wgpu::ShaderStages,
) -> wgpu::BindGroupLayoutEntry {
    let (depth, array) = (
        wgpu::TextureSampleType::Depth,
        wgpu::TextureViewDimension::D2Array,
    );
    entry(binding, visibility, texture(depth, array))
}

/// A sampler at `binding`.
pub fn sampler_entry(
    binding: u32,
    visibility: wgpu::ShaderStages,
    ty: wgpu::SamplerBindingType,
) -> wgpu::BindGroupLayoutEntry {
    entry(binding, visibility, wgpu::BindingType::Sampler(ty))
}

/// A read-only storage buffer at `binding` (tables indexed per pixel, e.g. SSS profiles).
pub fn storage_entry(binding: u32, visibility: wgpu::ShaderStages) -> wgpu::BindGroupLayoutEntry {
    let ty = whole_buffer(wgpu::BufferBindingType::Storage { read_only: true });
    entry(binding, visibility, ty)
}

/// A write-only storage texture of `format` at `binding` (compute passes' outputs).
pub fn storage_texture_entry(
    binding: u32,
    visibility: wgpu::ShaderStages,
    format: wgpu::TextureFormat,
    view_dimension: wgpu::TextureViewDimension,
) -> wgpu::BindGroupLayoutEntry {
    let ty = wgpu::BindingType::StorageTexture {
        access: wgpu::StorageTextureAccess::WriteOnly,
        format,
        view_dimension,
    };
    entry(binding, visibility, ty)
}
