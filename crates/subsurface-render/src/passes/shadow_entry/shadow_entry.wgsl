// Shadow entry pass: turns a caller's standard shadow map (a z-buffer per layer, drawn with the
// light's view-projection) into the maps the skin's transmittance reads, as shadow.wgsl writes
// them for our own renderer: the linear light distance of the surface nearest the light, and
// that surface's normal (encode_normal), where transmitted light enters.

struct EntryView {
    inverse_view_proj: mat4x4<f32>,
    light_position: vec4<f32>, // xyz: where light_distance measures from, w = kind
    light_direction: vec4<f32>,
    layer: i32,
    size: i32,                 // this layer's map size in texels
    _pad: vec2<i32>,
};

@group(0) @binding(0) var<uniform> entry_view: EntryView;
@group(0) @binding(1) var caller_depth: texture_depth_2d_array;

// The world position the light sees at `texel`; w = 0 where nothing was drawn (the z-buffer
// still holds its clear value, the far plane).
fn texel_world(texel: vec2<i32>) -> vec4<f32> {
    let z = textureLoad(caller_depth, texel, entry_view.layer, 0);
    if (z >= 1.0) {
        return vec4<f32>(0.0);
    }
    let uv = (vec2<f32>(texel) + vec2<f32>(0.5)) / f32(entry_view.size);
    let ndc = vec2<f32>(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0);
    let h = entry_view.inverse_view_proj * vec4<f32>(ndc, z, 1.0);
    return vec4<f32>(h.xyz / h.w, 1.0);
}

fn entry_distance(p: vec3<f32>) -> f32 {
    return light_distance(entry_view.light_position.w, entry_view.light_position.xyz, entry_view.light_direction.xyz, p);
}

// The step to the neighbour along one axis that lies on the same surface: of the two
// neighbours, the one whose light distance differs least. Taking the other at a silhouette
// would tilt the normal toward the surface behind it, and the entry normal sets how much light
// enters (transmittance.wgsl, `entry_in`).
fn surface_step(p: vec4<f32>, before: vec4<f32>, after: vec4<f32>) -> vec3<f32> {
    let d = entry_distance(p.xyz);
    let back = select(1e30, abs(entry_distance(before.xyz) - d), before.w > 0.0);
    let ahead = select(1e30, abs(entry_distance(after.xyz) - d), after.w > 0.0);
    if (back >= 1e30 && ahead >= 1e30) {
        return vec3<f32>(0.0);
    }
    if (ahead <= back) {
        return after.xyz - p.xyz;
    }
    return p.xyz - before.xyz;
}

@fragment
fn fs_entry(@builtin(position) frag: vec4<f32>) -> @location(0) vec2<f32> {
    let texel = vec2<i32>(frag.xy);
    let p = texel_world(texel);
    if (p.w == 0.0) {
        // As shadow.rs clears its maps: infinitely far, nothing occludes there.
        return vec2<f32>(3.4028235e38, 0.0);
    }
    let last = vec2<i32>(entry_view.size - 1);
    let left = texel_world(clamp(texel - vec2<i32>(1, 0), vec2<i32>(0), last));
    let right = texel_world(clamp(texel + vec2<i32>(1, 0), vec2<i32>(0), last));
    let up = texel_world(clamp(texel - vec2<i32>(0, 1), vec2<i32>(0), last));
    let down = texel_world(clamp(texel + vec2<i32>(0, 1), vec2<i32>(0), last));
    let kind = entry_view.light_position.w;
    let l = light_direction(kind, entry_view.light_position.xyz, entry_view.light_direction.xyz, p.xyz);
    var n = cross(surface_step(p, left, right), surface_step(p, up, down));
    // A lone texel has no surface around it: take it as facing the light.
    if (dot(n, n) < 1e-30) {
        n = l;
    }
    n = normalize(n);
    if (dot(n, l) < 0.0) {
        n = -n;
    }
    return vec2<f32>(entry_distance(p.xyz), encode_normal(n));
}
