//! The example program's own renderer data (skin_in_your_renderer.rs): its uniform blocks, as
//! its WGSL (skin_in_your_renderer.wgsl) declares them, its meshes with their materials, and its
//! lights. Nothing here is the library's: an engine has its own.

use glam::{Mat4, Vec3, Vec4};
use wgpu::util::DeviceExt;

use subsurface_render::gpu_scene::{object_uniform, world_per_mm};
use subsurface_render::lights::LightSetup;
use subsurface_render::material::{MaterialCache, ProfileTable};
use subsurface_render::passes::transmitted_light::SkinMedium;
use subsurface_render::passes::util;
use subsurface_render::uniforms::LightsUniform;
use subsurface_render::{GpuContext, RenderError, Scene};

/// The camera, as the WGSL's `View`.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ViewUniform {
    pub view_proj: [[f32; 4]; 4],
    pub position: Vec4,
    pub forward: Vec4,
}

/// One light, as the WGSL's `Light`.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct LightData {
    pub position: Vec4,
    pub direction: Vec4,
    pub color: Vec4,
    pub cone: Vec4,
    pub view_proj: [[f32; 4]; 4],
}

/// Every light, as the WGSL's `Lights`.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct LightsData {
    pub count: [u32; 4],
    pub ambient: Vec4,
    pub lights: [LightData; 8],
}

/// One object's material, as the WGSL's `Material`.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub struct MaterialData {
    pub model: Mat4,
    pub normal_matrix: Mat4,
    pub albedo: Vec4,
    pub params: Vec4,
    pub sss: Vec4,
}

/// One object on the GPU: its buffers and its material's bind group.
pub struct Mesh {
    vertices: wgpu::Buffer,
    indices: wgpu::Buffer,
    count: u32,
    material: wgpu::BindGroup,
}

/// A buffer `label` holding `bytes`.
pub fn buffer(
    device: &wgpu::Device,
    label: &str,
    bytes: &[u8],
    usage: wgpu::BufferUsages,
) -> wgpu::Buffer {
    device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some(label),
        contents: bytes,
        usage,
    })
}

/// A bind group `label` of `layout` whose binding 0 is a uniform buffer holding `data` (the
/// group keeps the buffer alive).
pub fn uniform_group(
    device: &wgpu::Device,
    label: &str,
    layout: &wgpu::BindGroupLayout,
    data: &[u8],
) -> wgpu::BindGroup {
    let uniform = buffer(device, label, data, wgpu::BufferUsages::UNIFORM);
    util::bind_group(device, label, layout, [(0, uniform.as_entire_binding())])
}

/// Each drawn object's mesh and material, and the skin's media (one per profile row), for the
/// library's skin passes.
pub fn upload_objects(
    ctx: &GpuContext,
    scene: &Scene,
    profiles: &ProfileTable,
    cache: &mut MaterialCache,
    material_layout: &wgpu::BindGroupLayout,
) -> Result<(Vec<Mesh>, Vec<SkinMedium>), RenderError> {
    let device = &ctx.device;
    let mut meshes = Vec::new();
    let mut media: Vec<SkinMedium> = Vec::new();
    let mut media_rows = Vec::new();
    for (i, object) in scene.objects.iter().enumerate() {
        if object.mesh.indices.is_empty() {
            continue;
        }
        let field = format!("objects[{i}].material.medium");
        let optics = cache.get(&object.material.medium, &field)?;
        let row = profiles.object_rows[i];
        let m = &object.material;
        let albedo = Vec3::from(object.albedo) * Vec3::from(optics.diffuse_albedo);
        let data = MaterialData {
            model: object.transform,
            normal_matrix: object.transform.inverse().transpose(),
            albedo: albedo.extend(1.0),
            params: Vec4::new(
                m.roughness,
                m.specular,
                optics.dipole.eta as f32,
                m.sss_strength,
            ),
            sss: Vec4::new(world_per_mm(object), row as f32, 0.0, 0.0),
        };
        let material = uniform_group(
            device,
            "material",
            material_layout,
            bytemuck::bytes_of(&data),
        );
        meshes.push(Mesh {
            vertices: buffer(
                device,
                "vertices",
                bytemuck::cast_slice(&object.mesh.vertices),
                wgpu::BufferUsages::VERTEX,
            ),
            indices: buffer(
                device,
                "indices",
                bytemuck::cast_slice(&object.mesh.indices),
                wgpu::BufferUsages::INDEX,
            ),
            count: object.mesh.indices.len() as u32,
            material,
        });
        // The skin's media: one per profile row.
        if m.sss_strength > 0.0 && !media_rows.contains(&row) {
            media.push(SkinMedium::new(
                ctx,
                &optics,
                object_uniform(object, &optics, 0.0, row),
            )?);
            media_rows.push(row);
        }
    }
    Ok((meshes, media))
}

/// The program's lights as its WGSL reads them, from the library's lights uniform and shadow
/// atlas layout.
pub fn lights_data(
    lights_uniform: &LightsUniform,
    setup: &LightSetup,
    ambient: [f32; 3],
) -> LightsData {
    let atlas = setup.atlas_size;
    let mut lights = LightsData {
        count: [lights_uniform.count, 0, 0, 0],
        ambient: Vec3::from(ambient).extend(0.0),
        lights: bytemuck::Zeroable::zeroed(),
    };
    for (i, l) in lights_uniform
        .lights
        .iter()
        .take(lights_uniform.count as usize)
        .enumerate()
    {
        let size = setup
            .layers
            .iter()
            .find(|s| s.light == i)
            .map_or(1, |s| s.size);
        lights.lights[i] = LightData {
            position: Vec3::from(l.position).extend(l.kind),
            direction: Vec3::from(l.direction).extend(l.first_layer),
            color: Vec3::from(l.color).extend(l.shadow_bias),
            cone: Vec4::new(l.cos_outer, l.cos_inner, size as f32, atlas as f32),
            view_proj: l.view_proj[0],
        };
    }
    lights
}

/// Draws every mesh with its material in group 1.
pub fn draw(pass: &mut wgpu::RenderPass<'_>, meshes: &[Mesh]) {
    for m in meshes {
        pass.set_bind_group(1, &m.material, &[]);
        pass.set_vertex_buffer(0, m.vertices.slice(..));
        pass.set_index_buffer(m.indices.slice(..), wgpu::IndexFormat::Uint32);
        pass.draw_indexed(0..m.count, 0, 0..1);
    }
}
