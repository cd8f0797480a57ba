//! The scene on the GPU: vertex/index buffers, material textures and per-object bind groups,
//! plus the camera and light data derived from the scene description.

use std::collections::HashMap;

use glam::{Mat4, Vec3};
use wgpu::util::DeviceExt;

use crate::error::RenderError;
use crate::gpu::GpuContext;
use crate::material::{MaterialCache, MaterialOptics};
use crate::passes::transmittance::lut_texture;
use crate::passes::util::bind_group;
use crate::scene::{Object, Scene};
use crate::uniforms::{CameraUniform, ObjectUniform, mat};

pub use crate::gpu::object::{GpuObject, VERTEX_LAYOUT, object_layout};
pub use crate::lights::{LightSetup, ShadowLayer, light_setup};

/// Scene units per profile millimetre of a loaded object.
pub fn world_per_mm(object: &Object) -> f32 {
    crate::scene::units::world_per_mm(
        object.transform,
        object.mm_per_unit,
        object.material.sss_width,
    )
}

/// `optics` gives the material's Beer-Lambert extinction; `lut_range_mm` the T(s) LUT width;
/// `profile_row` the object's row in the screen-space profile table.
pub fn object_uniform(
    object: &Object,
    optics: &MaterialOptics,
    lut_range_mm: f32,
    profile_row: u32,
) -> ObjectUniform {
    let m = &object.material;
    ObjectUniform {
        model: mat(object.transform),
        normal_matrix: mat(object.transform.inverse().transpose()),
        albedo: std::array::from_fn(|c| object.albedo[c] * optics.diffuse_albedo[c]),
        has_albedo_map: object.albedo_texture.is_some() as u32,
        has_normal_map: object.normal_texture.is_some() as u32,
        has_specular_map: object.specular_texture.is_some() as u32,
        ..medium_uniform(m, optics, world_per_mm(object), lut_range_mm, profile_row)
    }
}

/// An [`ObjectUniform`] from plain values, for an engine that has no [`Scene`]: the
/// material's boundary and scattering parameters (`roughness`, `specular`, `sss_strength`,
/// `translucency`; its medium only through `optics`), the scene units per profile millimetre
/// of its pixels, the T(s) LUT width and its profile row. The transform is the identity, the
/// albedo `optics`' own and no texture maps are bound: the transmitted light pass
/// ([`crate::passes::transmitted_light`]) reads none of them.
pub fn medium_uniform(
    material: &crate::scene::MaterialDesc,
    optics: &MaterialOptics,
    world_per_mm: f32,
    lut_range_mm: f32,
    profile_row: u32,
) -> ObjectUniform {
    let m = material;
    let diffusion: [_; 3] = std::array::from_fn(|c| optics.dipole.channel(c));
    ObjectUniform {
        model: mat(Mat4::IDENTITY),
        normal_matrix: mat(Mat4::IDENTITY),
        albedo: std::array::from_fn(|c| optics.diffuse_albedo[c]),
        roughness: m.roughness,
        specular: m.specular,
        sss_strength: m.sss_strength,
        world_per_mm,
        translucency: m.translucency,
        has_albedo_map: 0,
        has_normal_map: 0,
        has_specular_map: 0,
        profile: profile_row,
        extinction: optics.sigma_t,
        lut_range_mm,
        eta: optics.dipole.eta as f32,
        // 0 (no lateral taps) for a medium whose table holds no decay, one that passes nothing.
        lateral_decay: Some(optics.transport.lateral_decay_per_mm())
            .filter(|d| d.is_finite())
            .map_or(0.0, |d| d as f32),
        // The caller's: the object's place in its draw list (`upload_objects`).
        index: 0,
        _pad: 0.0,
        reduced_scattering: optics.dipole.sigma_s_prime.map(|x| x as f32),
        _pad2: 0.0,
        boundary_fit: boundary_fit(m.roughness, optics.dipole.eta),
        transport_decay: diffusion.map(|d| d.sigma_tr as f32),
        _pad3: 0.0,
        extrapolation_mm: diffusion.map(|d| d.z_b as f32),
        _pad4: 0.0,
    }
}

/// `ObjectUniform::boundary_fit`: the polynomial's coefficients 0..4 and 4..8.
type BoundaryFit = [[f32; 4]; 2];

/// The rough boundary's transmittance polynomial for roughness `alpha` and index `eta`,
/// computed once per pair in the process: [`object_uniform`] runs on every update (each drag
/// in the viewer), and the fit integrates the facets at 65 cosines (about 40 ms).
fn boundary_fit(alpha: f32, eta: f64) -> BoundaryFit {
    static FITS: std::sync::Mutex<Vec<((u32, u64), BoundaryFit)>> =
        std::sync::Mutex::new(Vec::new());
    let key = (alpha.to_bits(), eta.to_bits());
    let mut fits = FITS.lock().unwrap_or_else(|e| e.into_inner());
    if let Some((_, fit)) = fits.iter().find(|(k, _)| *k == key) {
        return *fit;
    }
    let c = subsurface_profile::specular::rough_transmittance_fit(f64::from(alpha), eta);
    let fit = [0, 1].map(|h| std::array::from_fn(|k| c[4 * h + k] as f32));
    // Bounded: a roughness slider dragged in the viewer asks for a new pair at every step.
    if fits.len() >= 64 {
        fits.remove(0);
    }
    fits.push((key, fit));
    fit
}

fn upload_texture(
    ctx: &GpuContext,
    image: Option<&image::RgbaImage>,
    format: wgpu::TextureFormat,
    label: &str,
    source: &str,
) -> Result<wgpu::TextureView, RenderError> {
    let white = image::RgbaImage::from_pixel(1, 1, image::Rgba([255; 4]));
    let base = image.unwrap_or(&white);
    let max = ctx.max_texture_size();
    if base.width() > max || base.height() > max {
        return Err(RenderError::invalid(
            label,
            format!(
                "{source} is {}x{}, larger than this device's limit {max}",
                base.width(),
                base.height()
            ),
        ));
    }
    // Mip maps on the CPU: the head's 2k maps are minified on screen and would alias.
    let levels = 32 - base.width().max(base.height()).leading_zeros();
    let texture = ctx.device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d {
            width: base.width(),
            height: base.height(),
            depth_or_array_layers: 1,
        },
        mip_level_count: levels,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    });
    let mut level_image = base.clone();
    for level in 0..levels {
        if level > 0 {
            let w = (level_image.width() / 2).max(1);
            let h = (level_image.height() / 2).max(1);
            level_image =
                image::imageops::resize(&level_image, w, h, image::imageops::FilterType::Triangle);
        }
        ctx.queue.write_texture(
            wgpu::TexelCopyTextureInfo {
                texture: &texture,
                mip_level: level,
                origin: wgpu::Origin3d::ZERO,
                aspect: wgpu::TextureAspect::All,
            },
            &level_image,
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(4 * level_image.width()),
                rows_per_image: None,
            },
            wgpu::Extent3d {
                width: level_image.width(),
                height: level_image.height(),
                depth_or_array_layers: 1,
            },
        );
    }
    Ok(texture.create_view(&Default::default()))
}

/// What an object's T(s) LUT depends on: its medium (the boundary's roughness is in the
/// object's uniform). Objects with equal keys share one LUT.
pub fn lut_key(material: &crate::scene::MaterialDesc) -> String {
    material.medium.to_string()
}

/// [`lut_key`] of every object, in order.
pub fn lut_keys(scene: &Scene) -> Vec<String> {
    scene.objects.iter().map(|o| lut_key(&o.material)).collect()
}

/// `profile_rows`: each scene object's row in the screen-space profile table.
pub fn upload_objects(
    ctx: &GpuContext,
    scene: &Scene,
    layout: &wgpu::BindGroupLayout,
    profile_rows: &[u32],
) -> Result<Vec<GpuObject>, RenderError> {
    let device = &ctx.device;
    let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
        label: Some("material"),
        address_mode_u: wgpu::AddressMode::Repeat,
        address_mode_v: wgpu::AddressMode::Repeat,
        mag_filter: wgpu::FilterMode::Linear,
        min_filter: wgpu::FilterMode::Linear,
        mipmap_filter: wgpu::MipmapFilterMode::Linear,
        anisotropy_clamp: 4,
        ..Default::default()
    });
    let mut out = Vec::new();
    let lut_sampler = device.create_sampler(&wgpu::SamplerDescriptor {
        label: Some("transmittance lut"),
        mag_filter: wgpu::FilterMode::Linear,
        min_filter: wgpu::FilterMode::Linear,
        ..Default::default()
    });
    let mut materials = MaterialCache::default();
    let mut luts: HashMap<String, (wgpu::TextureView, f32)> = HashMap::new();
    for (i, object) in scene.objects.iter().enumerate() {
        if object.mesh.indices.is_empty() {
            continue;
        }
        let label = format!("objects[{i}]");
        let desc_mesh = match scene.desc.objects.get(i).map(|d| &d.mesh) {
            Some(crate::scene::MeshDesc::Gltf { path }) => Some(path.clone()),
            _ => None,
        };
        let vertices = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(&label),
            contents: bytemuck::cast_slice(&object.mesh.vertices),
            usage: wgpu::BufferUsages::VERTEX,
        });
        let indices = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(&label),
            contents: bytemuck::cast_slice(&object.mesh.indices),
            usage: wgpu::BufferUsages::INDEX,
        });
        let optics = materials.get(&object.material.medium, &format!("{label}.material.medium"))?;
        let key = lut_key(&object.material);
        if !luts.contains_key(&key) {
            luts.insert(key.clone(), lut_texture(ctx, &optics)?);
        }
        let (lut, lut_range) = &luts[&key];
        let uniform = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(&label),
            contents: bytemuck::bytes_of(&ObjectUniform {
                index: out.len() as u32,
                ..object_uniform(
                    object,
                    &optics,
                    *lut_range,
                    profile_rows.get(i).copied().unwrap_or(0),
                )
            }),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        });
        let m = &object.material;
        // The file a texture came from, for the message: the material's own path, else the
        // glTF that embeds it.
        let source = |own: &Option<String>, what: &str| match (own, &desc_mesh) {
            (Some(p), _) => format!("texture {p}"),
            (None, Some(g)) => format!("the {what} texture of {g}"),
            (None, None) => "the texture".to_string(),
        };
        use wgpu::TextureFormat::{Rgba8Unorm, Rgba8UnormSrgb};
        let [albedo, normal, specular] = [
            (
                &object.albedo_texture,
                Rgba8UnormSrgb,
                "albedo",
                &m.albedo_texture,
                "base colour",
            ),
            (
                &object.normal_texture,
                Rgba8Unorm,
                "normal",
                &m.normal_texture,
                "normal",
            ),
            (
                &object.specular_texture,
                Rgba8Unorm,
                "specular",
                &m.specular_texture,
                "specular",
            ),
        ]
        .map(|(image, format, key, own, what)| {
            upload_texture(
                ctx,
                image.as_ref(),
                format,
                &format!("{label}.material.{key}_texture"),
                &source(own, what),
            )
        });
        let (albedo, normal, specular) = (albedo?, normal?, specular?);
        let view = wgpu::BindingResource::TextureView;
        let bind_group = bind_group(
            device,
            &label,
            layout,
            [
                (0, uniform.as_entire_binding()),
                (1, view(&albedo)),
                (2, view(&normal)),
                (3, view(&specular)),
                (4, wgpu::BindingResource::Sampler(&sampler)),
                (5, view(lut)),
                (6, wgpu::BindingResource::Sampler(&lut_sampler)),
            ],
        );
        out.push(GpuObject {
            vertices,
            indices,
            index_count: object.mesh.indices.len() as u32,
            uniform,
            bind_group,
        });
    }
    Ok(out)
}

/// The camera of the scene for a target of `width` x `height` pixels.
pub fn camera_uniform(scene: &Scene, width: u32, height: u32) -> CameraUniform {
    let c = &scene.desc.camera;
    let position = Vec3::from(c.position);
    let target = Vec3::from(c.target);
    let fov = c.fov_y_deg.to_radians();
    let view = Mat4::look_at_rh(position, target, Vec3::from(c.up));
    let proj = Mat4::perspective_rh(fov, width as f32 / height as f32, c.near, c.far);
    let focal_px = 0.5 * height as f32 / (0.5 * fov).tan();
    CameraUniform {
        view_proj: mat(proj * view),
        position: position.to_array(),
        near: c.near,
        forward: (target - position).normalize().to_array(),
        far: c.far,
        focal_px,
        viewport: [width as f32, height as f32],
        _pad: 0.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::MaterialCache;
    use crate::scene::MaterialDesc;
    use subsurface_profile::{Coefficients, Medium};

    /// The side walls' image sources (side_walls.wgsl, `side_wall_share`) read the medium's
    /// sigma_tr and z_b from the object uniform, as the dipole derives them. At eta = 4 the
    /// polynomial F_dr fit alone passes 1 (dipole.rs), which made the shader's own copy of it
    /// put the walls' images at a negative height; the uniform holds the dipole's exact values.
    #[test]
    fn the_uniform_carries_the_dipoles_transport_constants() {
        for eta in [1.3, 4.0] {
            let medium = Medium::Coefficients(Coefficients {
                sigma_a: [0.032, 0.17, 0.48],
                sigma_s: [0.74, 0.88, 1.01],
                eta,
            });
            let optics = MaterialCache::default().get(&medium, "m").unwrap();
            let u = medium_uniform(&MaterialDesc::default(), &optics, 1.0, 8.0, 0);
            for c in 0..3 {
                let want = optics.dipole.channel(c);
                assert_eq!(
                    u.transport_decay[c], want.sigma_tr as f32,
                    "eta {eta} sigma_tr"
                );
                assert_eq!(u.extrapolation_mm[c], want.z_b as f32, "eta {eta} z_b");
                assert!(
                    u.extrapolation_mm[c] > 0.0,
                    "eta {eta}: z_b {}",
                    u.extrapolation_mm[c]
                );
            }
        }
    }
}
