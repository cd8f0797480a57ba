//! Copying textures back to the CPU (PNG output, tests, debugging).

use crate::error::RenderError;
use crate::gpu::GpuContext;

/// Reads mip 0, layer `layer` of a texture; returns tightly packed rows.
pub fn read_texture_layer(
    ctx: &GpuContext,
    texture: &wgpu::Texture,
    layer: u32,
) -> Result<Vec<u8>, RenderError> {
    read_texture_level(ctx, texture, layer, 0)
}

/// Reads mip `level`, layer `layer` of a texture (`max(size >> level, 1)` texels a side);
/// returns tightly packed rows.
pub fn read_texture_level(
    ctx: &GpuContext,
    texture: &wgpu::Texture,
    layer: u32,
    level: u32,
) -> Result<Vec<u8>, RenderError> {
    let (w, h) = (
        (texture.width() >> level).max(1),
        (texture.height() >> level).max(1),
    );
    let texel = texture.format().block_copy_size(None).ok_or_else(|| {
        RenderError::Readback(format!("format {:?} cannot be copied", texture.format()))
    })?;
    let row = w * texel;
    let padded =
        row.div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT) * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
    let buffer = ctx.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("readback"),
        size: padded as u64 * h as u64,
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    let mut encoder = ctx.device.create_command_encoder(&Default::default());
    encoder.copy_texture_to_buffer(
        wgpu::TexelCopyTextureInfo {
            texture,
            mip_level: level,
            origin: wgpu::Origin3d {
                x: 0,
                y: 0,
                z: layer,
            },
            aspect: wgpu::TextureAspect::All,
        },
        wgpu::TexelCopyBufferInfo {
            buffer: &buffer,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(padded),
                rows_per_image: Some(h),
            },
        },
        wgpu::Extent3d {
            width: w,
            height: h,
            depth_or_array_layers: 1,
        },
    );
    ctx.queue.submit([encoder.finish()]);
    let (tx, rx) = std::sync::mpsc::channel();
    buffer.map_async(wgpu::MapMode::Read, .., move |r| {
        let _ = tx.send(r);
    });
    ctx.check()?;
    rx.recv()
        .map_err(|e| RenderError::Readback(e.to_string()))?
        .map_err(|e| RenderError::Readback(e.to_string()))?;
    let data = buffer
        .get_mapped_range(..)
        .map_err(|e| RenderError::Readback(e.to_string()))?;
    let mut out = Vec::with_capacity((row * h) as usize);
    for y in 0..h as usize {
        let start = y * padded as usize;
        out.extend_from_slice(&data[start..start + row as usize]);
    }
    drop(data);
    buffer.unmap();
    Ok(out)
}

/// Reads mip 0, layer 0 of a texture; returns tightly packed rows.
pub fn read_texture(ctx: &GpuContext, texture: &wgpu::Texture) -> Result<Vec<u8>, RenderError> {
    read_texture_layer(ctx, texture, 0)
}

/// An Rgba8 texture as an image (sRGB or not, as stored).
pub fn read_rgba8(
    ctx: &GpuContext,
    texture: &wgpu::Texture,
) -> Result<image::RgbaImage, RenderError> {
    let bytes = read_texture(ctx, texture)?;
    image::RgbaImage::from_raw(texture.width(), texture.height(), bytes)
        .ok_or_else(|| RenderError::Readback("size mismatch".into()))
}

/// Any float texture (Rgba16Float, R32Float, Rg32Float, Rgba32Float) as f32 texels,
/// `channels` values per texel.
pub fn read_float(
    ctx: &GpuContext,
    texture: &wgpu::Texture,
) -> Result<(Vec<f32>, usize), RenderError> {
    let bytes = read_texture(ctx, texture)?;
    Ok(decode_float(texture.format(), &bytes))
}

/// Bytes read back from a float texture as f32 values, and the channels per texel; half floats are
/// widened, any other format is read as 32-bit floats.
pub fn decode_float(format: wgpu::TextureFormat, bytes: &[u8]) -> (Vec<f32>, usize) {
    use wgpu::TextureFormat as F;
    match format {
        F::Rgba16Float | F::Rg16Float | F::R16Float => {
            let c = match format {
                F::Rgba16Float => 4,
                F::Rg16Float => 2,
                _ => 1,
            };
            let halves: &[half::f16] = bytemuck::cast_slice(bytes);
            (halves.iter().map(|h| h.to_f32()).collect(), c)
        }
        _ => {
            let c = match format {
                F::Rgba32Float => 4,
                F::Rg32Float => 2,
                _ => 1,
            };
            (bytemuck::cast_slice::<u8, f32>(bytes).to_vec(), c)
        }
    }
}
