//! CPU mirrors of the uniform blocks declared in `passes/common.wgsl`.

use bytemuck::{Pod, Zeroable};
use glam::{Mat4, Vec3};

pub const MAX_LIGHTS: usize = 8;

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub struct CameraUniform {
    pub view_proj: [[f32; 4]; 4],
    pub position: [f32; 4],
    pub forward: [f32; 4],
    /// near, far, focal length in pixels, unused
    pub params: [f32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub struct LightUniform {
    pub position: [f32; 4],
    pub direction: [f32; 4],
    pub color: [f32; 4],
    pub spot: [f32; 4],
    pub view_proj: [[[f32; 4]; 4]; 6],
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub struct LightsUniform {
    pub count: [u32; 4],
    pub ambient: [f32; 4],
    /// method (0 off, 1 paper, 2 Beer, 3 seed report, 4 TSM, 5 diffusion), normal shrink, thickness filter,
    /// 1 = write the thickness instead of diffuse (`DebugView::Thickness`)
    pub transmittance: [f32; 4],
    pub lights: [LightUniform; MAX_LIGHTS],
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub struct ObjectUniform {
    pub model: [[f32; 4]; 4],
    pub normal_matrix: [[f32; 4]; 4],
    /// rgb linear albedo, a = Beckmann roughness m
    pub albedo: [f32; 4],
    /// rho_s, SSS strength, scene units per profile mm, translucency
    pub params: [f32; 4],
    /// has albedo map, has normal map, has specular map
    pub flags: [f32; 4],
    /// Beer-Lambert extinction per mm (rgb), T(s) LUT range in mm
    pub transmit: [f32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub struct ShadowViewUniform {
    pub view_proj: [[f32; 4]; 4],
    pub light_position: [f32; 4],
    pub light_direction: [f32; 4],
    pub _pad: [[f32; 4]; 10],
}

pub fn mat(m: Mat4) -> [[f32; 4]; 4] {
    m.to_cols_array_2d()
}

pub fn v4(v: Vec3, w: f32) -> [f32; 4] {
    [v.x, v.y, v.z, w]
}

/// Group 2 of the lighting pass (`TextureSpace` in lighting.wgsl), one per object.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub struct TextureSpaceUniform {
    /// blurred map is the diffuse (0/1), translucent shadow maps on (0/1), albedo share
    /// applied before the blur, unused
    pub params: [f32; 4],
}

/// One pass of the texture-space blur (`BlurUniform` in texture_space.wgsl).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub struct BlurUniform {
    /// xy = texel axis, z = sigma in profile mm, w unused
    pub dir: [f32; 4],
    /// rgb weight of the Gaussian, a unused
    pub weight: [f32; 4],
    /// padding radius in texels, largest sigma in texels, unused, unused
    pub params: [f32; 4],
}

/// View of one translucent-shadow-map layer (`TsmView` in texture_space.wgsl).
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
pub struct TsmViewUniform {
    pub view_proj: [[f32; 4]; 4],
}
