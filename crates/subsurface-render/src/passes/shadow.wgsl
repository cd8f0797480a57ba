// Shadow pass: renders one shadow-map layer per spot/directional light and six per point
// light, storing linear light distance (not projected z) so transmittance can use it, and the
// normal of the surface the light sees (encode_normal), where transmitted light enters.

struct ShadowView {
    view_proj: mat4x4<f32>,
    light_position: vec4<f32>, // xyz, w = kind
    light_direction: vec4<f32>,
};

@group(0) @binding(0) var<uniform> shadow_view: ShadowView;

struct ShadowOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
};

@vertex
fn vs_main(v: VertexIn) -> ShadowOut {
    var out: ShadowOut;
    let world = world_position(v);
    out.world = world.xyz;
    out.normal = world_normal(v);
    out.clip = shadow_view.view_proj * world;
    return out;
}

@fragment
fn fs_main(in: ShadowOut) -> @location(0) vec2<f32> {
    let kind = shadow_view.light_position.w;
    let d = light_distance(kind, shadow_view.light_position.xyz, shadow_view.light_direction.xyz, in.world);
    // The entry surface's normal, turned toward the light: meshes drawn from both sides (and
    // mirrored transforms) may give either orientation.
    let l = light_direction(kind, shadow_view.light_position.xyz, shadow_view.light_direction.xyz, in.world);
    var n = normalize(in.normal);
    if (dot(n, l) < 0.0) {
        n = -n;
    }
    return vec2<f32>(d, encode_normal(n));
}
