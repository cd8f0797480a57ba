// Group 1 of every pass that draws meshes (gpu/object.rs, `object_layout`): the object's
// uniform, material maps and T(s) tables, and how its vertices are placed in the world.

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

// Object space to world: every pass that draws meshes places them the same way.
fn world_position(v: VertexIn) -> vec4<f32> {
    return object.model * vec4<f32>(v.position, 1.0);
}

// The shading frame in world space (normal and tangent; w keeps the bitangent sign).
fn world_normal(v: VertexIn) -> vec3<f32> {
    return (object.normal_matrix * vec4<f32>(v.normal, 0.0)).xyz;
}

fn world_tangent(v: VertexIn) -> vec4<f32> {
    return vec4<f32>((object.model * vec4<f32>(v.tangent.xyz, 0.0)).xyz, v.tangent.w);
}
