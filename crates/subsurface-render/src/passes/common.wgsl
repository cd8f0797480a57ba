// Shared declarations, prepended to every scene pass (shadow, lighting): the lights, the uniform
// blocks' structs (mirrored in uniforms.rs), light distances and the entry normal's encoding.

const MAX_LIGHTS: u32 = 8u;
const KIND_POINT: f32 = 0.0;
const KIND_SPOT: f32 = 1.0;
const KIND_DIRECTIONAL: f32 = 2.0;

struct Camera {
    view_proj: mat4x4<f32>,
    position: vec3<f32>,
    near: f32,
    forward: vec3<f32>,    // unit view direction; linear depth is measured along it
    far: f32,
    focal_px: f32,         // 0.5 * height / tan(fov_y / 2)
    viewport_x: f32,       // the frame's size in pixels (scalars: a vec2 here would move to
    viewport_y: f32,       // offset 104, where CameraUniform has it at 100)
};

struct Light {
    position: vec3<f32>,   // the shadow camera's origin for directional lights
    kind: f32,             // KIND_POINT, KIND_SPOT or KIND_DIRECTIONAL
    direction: vec3<f32>,  // unit, light -> target
    first_layer: f32,      // first shadow-map layer, -1 = no shadow map
    color: vec3<f32>,      // colour x intensity
    shadow_bias: f32,      // scene units
    cos_outer: f32,        // spot cone: cosines of the outer and inner half-angles
    cos_inner: f32,
    shadow_uv_scale: f32,  // this light's share of the atlas layer, in uv
    atlas_texel: f32,      // one atlas texel, in uv
    view_proj: array<mat4x4<f32>, 6>, // one per shadow layer (six cube faces for point lights)
};

struct Lights {
    count: u32,
    // 0 off, 1 Jimenez 2010, 2 Beer-Lambert, 3 the ad-hoc term of 001_*, 4 TSM, 5 diffusion
    transmittance: u32,
    thickness_filter: u32, // texels per axis averaged for thickness
    _pad1: u32,
    ambient: vec3<f32>,
    normal_shrink: f32,    // scene units the shaded point moves inward before the lookup
    sss_runs: u32,         // 1: subsurface scattering runs (source_shadow in shadow_lookup.wgsl)
    lateral_taps: u32,     // diffusion: shadow-map taps of the lit surface around the chord
    map_downsample: u32, // > 1: the taps are read from the transmitted map at 1/N resolution
    bounce_layer: u32,     // the transmitted map's layer holding the bounce (bounce.wgsl)
    bounce_ring: u32,      // cells of each pyramid level between a point and the next; 0 = off
    bounce_cell_mm: f32,   // the finest cells read, profile mm
    _pad2: u32,
    _pad3: u32,
    lights: array<Light, MAX_LIGHTS>,
};

struct Object {
    model: mat4x4<f32>,
    normal_matrix: mat4x4<f32>,
    albedo: vec3<f32>,     // linear
    roughness: f32,        // Beckmann m
    specular: f32,         // rho_s on the boundary's reflection
    sss_strength: f32,     // 0 = not skin
    world_per_mm: f32,     // scene units per profile millimetre
    translucency: f32,     // thickness scale of transmittance
    has_albedo_map: u32,
    has_normal_map: u32,
    has_specular_map: u32,
    profile: u32,          // row of the screen-space SSS profile table
    extinction: vec3<f32>, // Beer-Lambert sigma_t, 1/mm
    lut_range_mm: f32,     // thickness range of the T(s) LUT
    eta: f32,              // relative index of refraction of the boundary
    lateral_decay: f32,    // the medium's slowest decay rate, 1/mm (spreads the lateral taps)
    index: u32,            // in the frame's draw list (transmitted_map.wgsl's surface targets)
    reduced_scattering: vec3<f32>, // sigma_s', 1/mm (isotropic phase)
    // The rough boundary's transmittance against the cosine: coefficients 0-3 and 4-7 of a
    // degree-7 polynomial (transmittance.wgsl, boundary_transmittance).
    boundary_fit: array<vec4<f32>, 2>,
    // The diffusion approximation's per-channel constants of the medium (dipole.rs, computed
    // once on the CPU): sigma_tr, 1/mm, and the extrapolated boundary's height z_b, mm.
    transport_decay: vec3<f32>,
    extrapolation_mm: vec3<f32>,
};

// The distance stored in shadow maps: Euclidean distance to point and spot lights, distance
// along the light direction for directional lights. Linear, in scene units, so thickness
// (Jimenez et al. 2010, Figure 7) is a plain difference of two such distances.
fn light_distance(kind: f32, origin: vec3<f32>, light_dir: vec3<f32>, p: vec3<f32>) -> f32 {
    if (kind == KIND_DIRECTIONAL) {
        return dot(p - origin, light_dir);
    }
    return length(p - origin);
}

// Unit vector from p towards the light (the light's own direction reversed for directional
// lights, which are infinitely far).
fn light_direction(kind: f32, origin: vec3<f32>, light_dir: vec3<f32>, p: vec3<f32>) -> vec3<f32> {
    if (kind == KIND_DIRECTIONAL) {
        return -light_dir;
    }
    return normalize(origin - p);
}

// The shadow map's second channel: the normal of the surface the light sees, octahedral with
// 12 bits a component, stored as an integer-valued f32 (exact below 2^24, so no bit pattern
// can be a NaN or a denormal that a float render target might flush).
fn encode_normal(n: vec3<f32>) -> f32 {
    var p = n.xy / max(abs(n.x) + abs(n.y) + abs(n.z), 1e-20);
    if (n.z < 0.0) {
        p = (vec2<f32>(1.0) - abs(p.yx)) * select(vec2<f32>(-1.0), vec2<f32>(1.0), p >= vec2<f32>(0.0));
    }
    let q = round(clamp(p * 0.5 + vec2<f32>(0.5), vec2<f32>(0.0), vec2<f32>(1.0)) * 4095.0);
    return q.x * 4096.0 + q.y;
}

fn decode_normal(f: f32) -> vec3<f32> {
    let x = floor(f / 4096.0);
    let p = vec2<f32>(x, f - x * 4096.0) / 4095.0 * 2.0 - vec2<f32>(1.0);
    var n = vec3<f32>(p, 1.0 - abs(p.x) - abs(p.y));
    if (n.z < 0.0) {
        n = vec3<f32>((vec2<f32>(1.0) - abs(n.yx)) * select(vec2<f32>(-1.0), vec2<f32>(1.0), n.xy >= vec2<f32>(0.0)), n.z);
    }
    return normalize(n);
}
