//! The scene on the GPU: vertex/index buffers, material textures and per-object bind groups,
//! plus the camera and light data derived from the scene description.

use glam::{Mat4, Vec3};
use wgpu::util::DeviceExt;

use crate::error::RenderError;
use crate::gpu::GpuContext;
use std::collections::HashMap;

use crate::gpu::layout;
use crate::material::{MaterialCache, MaterialOptics};
use crate::mesh::Vertex;
use crate::passes::transmittance::lut_texture;
use crate::scene::{LightDesc, LightKind, Object, Scene};
use crate::settings::{LateralPass, RenderSettings};
use crate::uniforms::{CameraUniform, LightUniform, LightsUniform, MAX_LIGHTS, ObjectUniform, mat};

pub const VERTEX_LAYOUT: wgpu::VertexBufferLayout<'static> = wgpu::VertexBufferLayout {
    array_stride: std::mem::size_of::<Vertex>() as u64,
    step_mode: wgpu::VertexStepMode::Vertex,
    attributes: &wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Float32x2, 3 => Float32x4],
};

/// Bind group layout of group 1 (`Object` + material maps), shared by shadow and lighting.
pub fn object_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    // Compute too: the lateral map's evaluation (lateral.wgsl, `cs_transmitted`) reads the
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

pub struct GpuObject {
    pub vertices: wgpu::Buffer,
    pub indices: wgpu::Buffer,
    pub index_count: u32,
    pub uniform: wgpu::Buffer,
    pub bind_group: wgpu::BindGroup,
}

impl GpuObject {
    pub fn draw(&self, pass: &mut wgpu::RenderPass<'_>) {
        pass.set_bind_group(1, &self.bind_group, &[]);
        pass.set_vertex_buffer(0, self.vertices.slice(..));
        pass.set_index_buffer(self.indices.slice(..), wgpu::IndexFormat::Uint32);
        pass.draw_indexed(0..self.index_count, 0, 0..1);
    }
}

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
        roughness: m.roughness,
        specular: m.specular,
        sss_strength: m.sss_strength,
        world_per_mm: world_per_mm(object),
        translucency: m.translucency,
        has_albedo_map: object.albedo_texture.is_some() as u32,
        has_normal_map: object.normal_texture.is_some() as u32,
        has_specular_map: object.specular_texture.is_some() as u32,
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
        scattering: optics.dipole.sigma_s_prime.map(|x| x as f32),
        _pad2: 0.0,
        boundary_fit: boundary_fit(m.roughness, optics.dipole.eta),
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
) -> Result<wgpu::TextureView, RenderError> {
    let white = image::RgbaImage::from_pixel(1, 1, image::Rgba([255; 4]));
    let base = image.unwrap_or(&white);
    let max = ctx.max_texture_size();
    if base.width() > max || base.height() > max {
        return Err(RenderError::invalid(
            label,
            format!(
                "texture is {}x{}, larger than this device's limit {max}",
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
        let albedo = upload_texture(
            ctx,
            object.albedo_texture.as_ref(),
            wgpu::TextureFormat::Rgba8UnormSrgb,
            &format!("{label}.material.albedo_texture"),
        )?;
        let normal = upload_texture(
            ctx,
            object.normal_texture.as_ref(),
            wgpu::TextureFormat::Rgba8Unorm,
            &format!("{label}.material.normal_texture"),
        )?;
        let specular = upload_texture(
            ctx,
            object.specular_texture.as_ref(),
            wgpu::TextureFormat::Rgba8Unorm,
            &format!("{label}.material.specular_texture"),
        )?;
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some(&label),
            layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: uniform.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(&albedo),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::TextureView(&normal),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: wgpu::BindingResource::TextureView(&specular),
                },
                wgpu::BindGroupEntry {
                    binding: 4,
                    resource: wgpu::BindingResource::Sampler(&sampler),
                },
                wgpu::BindGroupEntry {
                    binding: 5,
                    resource: wgpu::BindingResource::TextureView(lut),
                },
                wgpu::BindGroupEntry {
                    binding: 6,
                    resource: wgpu::BindingResource::Sampler(&lut_sampler),
                },
            ],
        });
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

/// The lateral map's reduction for `scene` at `width` x `height` with `settings`
/// ([`crate::settings::lateral_downsample`]): from the pixel's size in profile millimetres on
/// the translucent object in view nearest in those terms (`skin_pixel_mm`), so that the
/// map's texels are the same millimetres at any resolution and zoom (a farther object whose
/// texels come out too coarse gathers its own taps, [`lateral_taps_objects`]). 1 (no
/// map) unless `diffusion` runs lateral taps on the screen (texture-space diffusion takes its
/// transmitted light from its UV-space pass).
pub fn lateral_downsample(
    scene: &Scene,
    settings: &crate::settings::RenderSettings,
    width: u32,
    height: u32,
) -> u32 {
    let t = &settings.transmittance;
    let taps = t.method == crate::settings::TransmittanceMethod::Diffusion && t.lateral_taps > 0;
    // The bounce is gathered on the same map (passes::bounce): it too changes over
    // millimetres.
    if !(taps || settings.bounce.enabled())
        || settings.sss.method == crate::settings::SssMethod::Texture
    {
        return 1;
    }
    let pixel_mm = skin_pixel_mm(scene, width, height)
        .into_iter()
        .flatten()
        .fold(f32::INFINITY, f32::min);
    crate::settings::lateral_downsample(t.lateral_texel_mm, pixel_mm)
}

/// For each object of `scene` seen at `width` x `height`: the size of a pixel in its profile
/// millimetres at the depth of its bounds' centre (at least the near plane), where it is
/// translucent and may lie in view; `None` elsewhere.
fn skin_pixel_mm(scene: &Scene, width: u32, height: u32) -> Vec<Option<f32>> {
    let camera = camera_uniform(scene, width, height);
    let (position, forward) = (Vec3::from(camera.position), Vec3::from(camera.forward));
    let view_proj = Mat4::from_cols_array_2d(&camera.view_proj);
    scene
        .objects
        .iter()
        .map(|o| {
            if !(o.material.translucency > 0.0 && in_view(view_proj, o.world_bounds())) {
                return None;
            }
            let (lo, hi) = o.world_bounds();
            let depth = ((lo + hi) * 0.5 - position).dot(forward).max(camera.near);
            let mm = depth / camera.focal_px / (world_per_mm(o) * o.material.translucency);
            (mm.is_finite() && mm > 0.0).then_some(mm)
        })
        .collect()
}

/// Which of the uploaded objects (those with triangles, in the scene's order, as
/// [`upload_objects`] makes them) gather `diffusion`'s lateral taps at each pixel although the
/// frame has a lateral map of reduction `downsample`: skin so much farther than the nearest
/// that its texels would span more than [`crate::settings::MAX_TEXEL_FACTOR`] times
/// `lateral_texel_mm`. The lighting pass draws them with a pipeline that holds the taps
/// (passes::lighting, `lateral_source`); every other pixel reads the map with one that does not.
pub fn lateral_taps_objects(
    scene: &Scene,
    settings: &crate::settings::RenderSettings,
    width: u32,
    height: u32,
    downsample: u32,
) -> Vec<bool> {
    let t = &settings.transmittance;
    let limit = crate::settings::MAX_TEXEL_FACTOR * t.lateral_texel_mm;
    let coarse = |mm: Option<f32>| mm.is_some_and(|mm| downsample as f32 * mm > limit);
    scene
        .objects
        .iter()
        .zip(skin_pixel_mm(scene, width, height))
        .filter(|(o, _)| !o.mesh.indices.is_empty())
        .map(|(_, mm)| downsample > 1 && coarse(mm))
        .collect()
}

/// Each uploaded object's box on a `width` x `height` frame (those with triangles, in the
/// scene's order, as [`upload_objects`] makes them): the pixels `[x0, y0, x1, y1)` its world
/// bounds project to, the whole frame where the bounds reach behind the camera's eye, `None`
/// where they lie outside the view. The lateral map's compute evaluation dispatches over each
/// object's box alone (passes::lighting, `LightingPass::set_object_rects`).
pub fn screen_rects(scene: &Scene, width: u32, height: u32) -> Vec<Option<[u32; 4]>> {
    let camera = camera_uniform(scene, width, height);
    let view_proj = Mat4::from_cols_array_2d(&camera.view_proj);
    let (w, h) = (width as f32, height as f32);
    scene
        .objects
        .iter()
        .filter(|o| !o.mesh.indices.is_empty())
        .map(|o| {
            let bounds = o.world_bounds();
            if !in_view(view_proj, bounds) {
                return None;
            }
            let (lo, hi) = bounds;
            let mut min = glam::Vec2::splat(f32::INFINITY);
            let mut max = glam::Vec2::splat(f32::NEG_INFINITY);
            for c in crate::scene::box_corners(lo, hi) {
                let clip = view_proj * c.extend(1.0);
                // A corner at or behind the eye projects nowhere useful: the whole frame.
                if !clip.w.is_finite() || clip.w <= 1e-6 {
                    return Some([0, 0, width, height]);
                }
                let px = glam::Vec2::new(
                    (clip.x / clip.w * 0.5 + 0.5) * w,
                    (0.5 - clip.y / clip.w * 0.5) * h,
                );
                (min, max) = (min.min(px), max.max(px));
            }
            let x0 = min.x.floor().clamp(0.0, w) as u32;
            let y0 = min.y.floor().clamp(0.0, h) as u32;
            let x1 = max.x.ceil().clamp(0.0, w) as u32;
            let y1 = max.y.ceil().clamp(0.0, h) as u32;
            (x1 > x0 && y1 > y0).then_some([x0, y0, x1, y1])
        })
        .collect()
}

/// Whether any of the box `(lo, hi)` may lie in the view of `view_proj` (wgpu clip space): no
/// frustum plane has all eight corners outside it.
fn in_view(view_proj: Mat4, (lo, hi): (Vec3, Vec3)) -> bool {
    let corners = crate::scene::box_corners(lo, hi).map(|c| view_proj * c.extend(1.0));
    let outside = |f: &dyn Fn(&glam::Vec4) -> bool| corners.iter().all(f);
    !(outside(&|c| c.x < -c.w)
        || outside(&|c| c.x > c.w)
        || outside(&|c| c.y < -c.w)
        || outside(&|c| c.y > c.w)
        || outside(&|c| c.z < 0.0)
        || outside(&|c| c.z > c.w))
}

/// Where each light's shadow maps live in the shadow atlas (a 2-D array texture).
#[derive(Clone, Debug)]
pub struct ShadowLayer {
    pub light: usize,
    pub size: u32,
    pub view_proj: Mat4,
    /// Origin that `light_distance` measures from (the light, or the directional light's
    /// shadow-camera origin).
    pub origin: Vec3,
}

pub struct LightSetup {
    pub uniform: LightsUniform,
    pub layers: Vec<ShadowLayer>,
    pub atlas_size: u32,
}

fn safe_up(dir: Vec3) -> Vec3 {
    if dir.y.abs() > 0.99 { Vec3::Z } else { Vec3::Y }
}

/// Light-space matrices and uniforms, with the ambient light and transmittance of `settings`.
/// Shadow near/far planes are fitted to the scene's bounding sphere so that depth precision is
/// spent where the geometry is.
pub fn light_setup(scene: &Scene, settings: &RenderSettings) -> Result<LightSetup, RenderError> {
    let transmittance = &settings.transmittance;
    if scene.desc.lights.len() > MAX_LIGHTS {
        return Err(RenderError::invalid(
            "lights",
            format!(
                "at most {MAX_LIGHTS} lights are supported (got {})",
                scene.desc.lights.len()
            ),
        ));
    }
    let (lo, hi) = scene.bounds();
    let centre = (lo + hi) * 0.5;
    let radius = ((hi - lo).length() * 0.5).max(1e-3);
    let atlas_size = scene
        .desc
        .lights
        .iter()
        .map(|l| l.shadow_map_size)
        .max()
        .unwrap_or(0)
        .max(1);
    let mut uniform = LightsUniform::zeroed_default();
    uniform.count = scene.desc.lights.len() as u32;
    uniform.ambient = settings.ambient;
    uniform.transmittance = transmittance.method.code();
    uniform.normal_shrink = transmittance.normal_shrink;
    uniform.thickness_filter = transmittance.thickness_filter;
    uniform.lateral_taps = transmittance.lateral_taps;
    uniform.lateral_compute = u32::from(transmittance.lateral_pass == LateralPass::Compute);
    uniform.lateral_downsample =
        lateral_downsample(scene, settings, settings.width, settings.height);
    uniform.scattering = u32::from(settings.sss.method != crate::settings::SssMethod::None);
    let mut layers = Vec::new();
    for (i, l) in scene.desc.lights.iter().enumerate() {
        let (u, light_layers) = light_uniform(i, l, centre, radius, atlas_size, layers.len());
        uniform.lights[i] = u;
        layers.extend(light_layers);
    }
    // Point lights' six faces are not gathered (bounce.wgsl): only the others count.
    let bounced = scene
        .desc
        .lights
        .iter()
        .any(|l| l.shadow_map_size > 0 && l.kind != LightKind::Point);
    if settings.bounce.enabled()
        && bounced
        && settings.sss.method != crate::settings::SssMethod::Texture
    {
        uniform.bounce_ring = settings.bounce.ring;
        uniform.bounce_cell_mm = settings.bounce.cell_mm;
    }
    uniform.bounce_layer = if crate::passes::lighting::transmitted_map(&uniform) {
        crate::passes::lighting::TRANSMITTED_LAYERS
    } else {
        0
    };
    Ok(LightSetup {
        uniform,
        layers,
        atlas_size,
    })
}

impl LightsUniform {
    fn zeroed_default() -> Self {
        bytemuck::Zeroable::zeroed()
    }
}

fn light_uniform(
    index: usize,
    l: &LightDesc,
    centre: Vec3,
    radius: f32,
    atlas_size: u32,
    first_layer: usize,
) -> (LightUniform, Vec<ShadowLayer>) {
    let pos = Vec3::from(l.position);
    let dir = (Vec3::from(l.target) - pos).normalize_or(Vec3::NEG_Z);
    let colour = Vec3::from(l.color) * l.intensity;
    let kind = match l.kind {
        LightKind::Point => 0.0,
        LightKind::Spot => 1.0,
        LightKind::Directional => 2.0,
    };
    let far = ((pos - centre).length() + radius) * 1.05;
    let near = (far * 1e-3)
        .max(((pos - centre).length() - radius) * 0.5)
        .max(far * 1e-4);
    let mut views: Vec<(Mat4, Vec3)> = Vec::new();
    let mut origin = pos;
    if l.shadow_map_size > 0 {
        match l.kind {
            LightKind::Spot => {
                let fov = (2.0 * l.outer_angle_deg.to_radians() * 1.05).min(179f32.to_radians());
                let v = Mat4::look_at_rh(pos, pos + dir, safe_up(dir));
                views.push((Mat4::perspective_rh(fov, 1.0, near, far) * v, pos));
            }
            LightKind::Point => {
                let faces = [
                    (Vec3::X, Vec3::NEG_Y),
                    (Vec3::NEG_X, Vec3::NEG_Y),
                    (Vec3::Y, Vec3::Z),
                    (Vec3::NEG_Y, Vec3::NEG_Z),
                    (Vec3::Z, Vec3::NEG_Y),
                    (Vec3::NEG_Z, Vec3::NEG_Y),
                ];
                // Slightly wider than 90 degrees so PCF taps at face edges stay inside.
                let proj = Mat4::perspective_rh(92f32.to_radians(), 1.0, near, far);
                for (d, up) in faces {
                    views.push((proj * Mat4::look_at_rh(pos, pos + d, up), pos));
                }
            }
            LightKind::Directional => {
                origin = centre - dir * (2.0 * radius);
                let v = Mat4::look_at_rh(origin, centre, safe_up(dir));
                let p = Mat4::orthographic_rh(
                    -radius,
                    radius,
                    -radius,
                    radius,
                    0.5 * radius,
                    3.5 * radius,
                );
                views.push((p * v, origin));
            }
        }
    }
    let mut vp = [[[0.0; 4]; 4]; 6];
    for (k, (m, _)) in views.iter().enumerate() {
        vp[k] = mat(*m);
    }
    let first = if views.is_empty() {
        -1.0
    } else {
        first_layer as f32
    };
    let cos_outer = l.outer_angle_deg.to_radians().cos();
    let cos_inner = l.inner_angle_deg.to_radians().cos().max(cos_outer + 1e-4);
    let u = LightUniform {
        position: origin.to_array(),
        kind,
        direction: dir.to_array(),
        first_layer: first,
        color: colour.to_array(),
        shadow_bias: l.shadow_bias,
        cos_outer,
        cos_inner,
        shadow_uv_scale: l.shadow_map_size.max(1) as f32 / atlas_size as f32,
        atlas_texel: 1.0 / atlas_size as f32,
        view_proj: vp,
    };
    let layers = views
        .into_iter()
        .map(|(view_proj, origin)| ShadowLayer {
            light: index,
            size: l.shadow_map_size,
            view_proj,
            origin,
        })
        .collect();
    (u, layers)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::settings::{RenderSettings, SssMethod, TransmittanceMethod};

    fn downsample(scene: &Scene, settings: &RenderSettings, w: u32, h: u32) -> u32 {
        lateral_downsample(scene, settings, w, h)
    }

    /// Each object's box on screen holds every vertex of it (the lateral map's compute
    /// dispatch covers only the box), is far smaller than the frame for the default scene's
    /// hand and wedge, and is the whole frame for an object reaching behind the camera.
    #[test]
    fn screen_rects_hold_every_vertex() {
        let mut scene = Scene::default_scene();
        let (w, h) = (256, 192);
        let camera = camera_uniform(&scene, w, h);
        let view_proj = Mat4::from_cols_array_2d(&camera.view_proj);
        let rects = screen_rects(&scene, w, h);
        assert_eq!(rects.len(), scene.objects.len());
        for (o, rect) in scene.objects.iter().zip(&rects) {
            let [x0, y0, x1, y1] = rect.expect("the default scene's objects are in view");
            assert!(
                ((x1 - x0) * (y1 - y0)) < w * h / 2,
                "{:?}: box {x0},{y0}..{x1},{y1} of a {w}x{h} frame",
                o.name
            );
            for v in &o.mesh.vertices {
                let c = view_proj
                    * o.transform
                        .transform_point3(Vec3::from(v.position))
                        .extend(1.0);
                let px = (c.x / c.w * 0.5 + 0.5) * w as f32;
                let py = (0.5 - c.y / c.w * 0.5) * h as f32;
                assert!(
                    px >= x0 as f32 && px <= x1 as f32 && py >= y0 as f32 && py <= y1 as f32,
                    "{:?}: vertex at ({px}, {py}) outside {x0},{y0}..{x1},{y1}",
                    o.name
                );
            }
        }
        // The camera inside the hand's bounds, looking down the fingers to the wrist (the
        // bounds reach past the near plane in front and behind the eye).
        let (lo, hi) = scene.objects[0].world_bounds();
        let centre = (lo + hi) * 0.5;
        scene.desc.camera.position = centre.to_array();
        scene.desc.camera.target = (centre - Vec3::Y).to_array();
        scene.desc.camera.up = [0.0, 0.0, 1.0];
        assert_eq!(screen_rects(&scene, w, h)[0], Some([0, 0, w, h]));
    }

    /// The map's texels stay about `lateral_texel_mm` on the skin: twice the pixels, twice
    /// the reduction (up to 8), 2 for skin small on screen and none where it is smaller still.
    #[test]
    fn lateral_map_reduction_follows_the_skin_on_screen() {
        let scene = Scene::default_scene();
        let s = scene.desc.render.clone();
        let (r256, r512) = (
            downsample(&scene, &s, 256, 256),
            downsample(&scene, &s, 512, 512),
        );
        assert_eq!((r256, r512), (3, 6));
        assert_eq!(downsample(&scene, &s, 1280, 720), 8);
        // Small on screen: two pixels a texel while that stays within MAX_TEXEL_FACTOR.
        assert_eq!(downsample(&scene, &s, 64, 64), 2);
        assert_eq!(downsample(&scene, &s, 32, 32), 1);
        let mut per_pixel = s.clone();
        per_pixel.transmittance.lateral_texel_mm = 0.0;
        assert_eq!(downsample(&scene, &per_pixel, 512, 512), 1);
    }

    /// Skin whose texels would span more than `MAX_TEXEL_FACTOR` times `lateral_texel_mm`
    /// gathers the taps itself: none of the default scene's objects, and every object but the
    /// nearest once moved back to six times its distance along the view (the map stays sized
    /// for the nearest).
    #[test]
    fn skin_too_far_for_the_map_gathers_its_own_taps() {
        let scene = Scene::default_scene();
        let s = scene.desc.render.clone();
        let n = downsample(&scene, &s, 1280, 720);
        let flags = lateral_taps_objects(&scene, &s, 1280, 720, n);
        assert_eq!(flags.len(), scene.objects.len());
        assert!(flags.iter().all(|&t| !t), "{flags:?}");
        let pixel_mm = skin_pixel_mm(&scene, 1280, 720);
        let nearest = (0..pixel_mm.len())
            .filter(|&i| pixel_mm[i].is_some())
            .min_by(|&a, &b| pixel_mm[a].partial_cmp(&pixel_mm[b]).unwrap())
            .unwrap();
        let camera = camera_uniform(&scene, 1280, 720);
        let (eye, forward) = (Vec3::from(camera.position), Vec3::from(camera.forward));
        let mut far = scene.clone();
        for (i, o) in far.objects.iter_mut().enumerate() {
            if i != nearest {
                let (lo, hi) = o.world_bounds();
                let depth = ((lo + hi) * 0.5 - eye).dot(forward);
                o.transform = Mat4::from_translation(forward * 5.0 * depth) * o.transform;
            }
        }
        assert_eq!(downsample(&far, &s, 1280, 720), n);
        let flags = lateral_taps_objects(&far, &s, 1280, 720, n);
        for (i, flag) in flags.iter().enumerate() {
            let skin = pixel_mm[i].is_some();
            assert_eq!(*flag, skin && i != nearest, "object {i}: {flags:?}");
        }
        // Without a map nothing is marked.
        assert!(
            lateral_taps_objects(&far, &s, 1280, 720, 1)
                .iter()
                .all(|&t| !t)
        );
    }

    /// No map where nothing reads it: other transmittance methods without the bounce, no
    /// taps, texture-space diffusion (its transmitted light comes from UV space), no
    /// translucent object in view.
    #[test]
    fn no_lateral_map_where_nothing_reads_it() {
        let scene = Scene::default_scene();
        let mut s = scene.desc.render.clone();
        let mut paper = s.clone();
        paper.transmittance.method = TransmittanceMethod::Paper;
        // The bounce alone is gathered on the map.
        assert_eq!(downsample(&scene, &paper, 512, 512), 6);
        s.bounce = crate::settings::BounceSettings::OFF;
        paper.bounce = crate::settings::BounceSettings::OFF;
        let mut no_taps = s.clone();
        no_taps.transmittance.lateral_taps = 0;
        let mut texture = s.clone();
        texture.sss.method = SssMethod::Texture;
        for settings in [paper, no_taps, texture] {
            assert_eq!(downsample(&scene, &settings, 512, 512), 1);
        }
        let mut away = scene.clone();
        let c = &mut away.desc.camera;
        c.target = [c.position[0], c.position[1], c.position[2] + 1.0];
        assert_eq!(downsample(&away, &s, 512, 512), 1);
    }
}
