// Shared declarations, prepended to every scene pass (shadow, lighting).

const MAX_LIGHTS: u32 = 8u;
const KIND_POINT: f32 = 0.0;
const KIND_SPOT: f32 = 1.0;
const KIND_DIRECTIONAL: f32 = 2.0;

struct Camera {
    view_proj: mat4x4<f32>,
    position: vec4<f32>,   // xyz, w unused
    forward: vec4<f32>,    // xyz unit view direction; linear depth is measured along it
    params: vec4<f32>,     // near, far, focal length in pixels, unused
};

struct Light {
    position: vec4<f32>,   // xyz, w = kind
    direction: vec4<f32>,  // xyz unit (light -> target), w = first shadow layer or -1
    color: vec4<f32>,      // rgb = colour * intensity, w = shadow bias (scene units)
    spot: vec4<f32>,       // cos(outer), cos(inner), shadow uv scale, atlas texel size (uv)
    view_proj: array<mat4x4<f32>, 6>, // one per shadow layer (six cube faces for point lights)
};

struct Lights {
    count: vec4<u32>,      // x = number of lights
    ambient: vec4<f32>,
    // x = method (0 off, 1 Jimenez 2010, 2 Beer-Lambert, 3 the ad-hoc term of 001_*, 4 TSM),
    // y = normal shrink (scene units), z = thickness filter width (texels per axis)
    transmittance: vec4<f32>,
    lights: array<Light, MAX_LIGHTS>,
};

struct Object {
    model: mat4x4<f32>,
    normal_matrix: mat4x4<f32>,
    albedo: vec4<f32>,     // rgb linear, a = roughness (Beckmann m)
    params: vec4<f32>,     // rho_s, sss strength, scene units per profile mm, translucency
    flags: vec4<f32>,      // has albedo map, has normal map, has specular map, SSS profile index
    transmit: vec4<f32>,   // rgb = Beer-Lambert extinction (1/mm), a = T(s) LUT range in mm
};

@group(1) @binding(0) var<uniform> object: Object;
@group(1) @binding(1) var albedo_map: texture_2d<f32>;
@group(1) @binding(2) var normal_map: texture_2d<f32>;
@group(1) @binding(3) var specular_map: texture_2d<f32>;
@group(1) @binding(4) var material_sampler: sampler;
// T(s) of the object's material profile (000_*, equation 9), s in mm over the LUT range.
@group(1) @binding(5) var transmittance_lut: texture_2d<f32>;
@group(1) @binding(6) var lut_sampler: sampler;

struct VertexIn {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) uv: vec2<f32>,
    @location(3) tangent: vec4<f32>,
};

// The distance stored in shadow maps: Euclidean distance to point and spot lights, distance
// along the light direction for directional lights. Linear, in scene units, so thickness
// (Jimenez et al. 2010, Figure 7) is a plain difference of two such distances.
fn light_distance(light_pos: vec4<f32>, light_dir: vec3<f32>, p: vec3<f32>) -> f32 {
    if (light_pos.w == KIND_DIRECTIONAL) {
        return dot(p - light_pos.xyz, light_dir);
    }
    return length(p - light_pos.xyz);
}

// Unit vector from p towards the light (the light's own direction reversed for directional
// lights, which are infinitely far).
fn light_direction(light_pos: vec4<f32>, light_dir: vec3<f32>, p: vec3<f32>) -> vec3<f32> {
    if (light_pos.w == KIND_DIRECTIONAL) {
        return -light_dir;
    }
    return normalize(light_pos.xyz - p);
}
