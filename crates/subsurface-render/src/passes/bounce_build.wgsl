// Builds the flux pyramid that bounce.wgsl gathers from (after common.wgsl: decode_normal,
// the light kinds): every shadow-map texel is a lit point
// of the surface (its distance and normal are in the map), and what the light delivers there
// is known from the light alone. `base` sums 4 x 4 texels a cell (8 x 8, every other one, for
// large maps), `downsample` 2 x 2 cells a level. Sums, not means, so that every level holds the same total flux.

struct FluxLayer {
    // Inverse of the layer's view-projection: a texel's ray.
    inv_view_proj: mat4x4<f32>,
    origin: vec4<f32>,     // xyz: where light distances are measured from; w: KIND_*
    direction: vec4<f32>,  // xyz: the light's unit direction; w: texel_scale (see flux_weight)
    cone: vec4<f32>,       // spot cos_outer, cos_inner; z: the light's map size in texels;
                           // w: texels per side of a finest cell (bounce.rs, base_texels)
};

struct FluxLayers {
    layers: array<FluxLayer, 48>,
};

@group(0) @binding(0) var shadow_atlas: texture_2d_array<f32>;
@group(0) @binding(1) var<uniform> flux_layers: FluxLayers;
@group(0) @binding(2) var out_position: texture_storage_2d_array<rgba32float, write>;
@group(0) @binding(3) var out_normal: texture_storage_2d_array<rgba32float, write>;
@group(0) @binding(4) var out_spread: texture_storage_2d_array<r32float, write>;

// The level below, for `downsample`.
@group(1) @binding(0) var in_position: texture_2d_array<f32>;
@group(1) @binding(1) var in_normal: texture_2d_array<f32>;
@group(1) @binding(2) var in_spread: texture_2d_array<f32>;

// Texels read per side of a finest cell, every `base / READS` texel.
const READS: i32 = 4;

@compute @workgroup_size(8, 8, 1)
fn base(@builtin(global_invocation_id) id: vec3<u32>) {
    let dim = textureDimensions(out_position);
    if (id.x >= dim.x || id.y >= dim.y) {
        return;
    }
    let layer = i32(id.z);
    let info = flux_layers.layers[id.z];
    let size = i32(info.cone.z);
    // Maps of 1024 texels or more have cells of 8 x 8 texels read every other texel in each
    // direction, each read standing for four: the finest cell the gather reads (2 mm) spans
    // tens of their texels, and reading every one, 16 to a thread, was most of the bounce's
    // cost on lavapipe (137 of 240 ms at 640 x 360).
    let base = i32(info.cone.w);
    let stride = max(base / READS, 1);
    let step_weight = f32(stride * stride);
    var pos = vec4<f32>(0.0);
    var nrm = vec4<f32>(0.0);
    var spread = 0.0;
    for (var j = 0; j < base; j += stride) {
        for (var i = 0; i < base; i += stride) {
            let t = vec2<i32>(id.xy) * base + vec2<i32>(i, j);
            if (any(t >= vec2<i32>(size))) {
                continue;
            }
            let texel = textureLoad(shadow_atlas, t, layer, 0).rg;
            if (texel.x > 1e30 || texel.y < 0.0) {
                continue;
            }
            let uv = (vec2<f32>(t) + 0.5) / f32(size);
            let ndc = vec4<f32>(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0, 0.5, 1.0);
            let q = info.inv_view_proj * ndc;
            let on_ray = q.xyz / q.w;
            let axis = info.direction.xyz;
            var x: vec3<f32>;
            var to_light: vec3<f32>;
            var weight: f32;
            if (info.origin.w == KIND_DIRECTIONAL) {
                // The map holds the distance along the beam from the shadow camera's origin.
                x = on_ray + axis * (texel.x - dot(on_ray - info.origin.xyz, axis));
                to_light = -axis;
                // The texel's area across the beam.
                weight = info.direction.w;
            } else {
                let ray = normalize(on_ray - info.origin.xyz);
                x = info.origin.xyz + ray * texel.x;
                to_light = -ray;
                // The texel's solid angle: (its side in the image plane at unit distance)^2
                // x cos^3 of its angle off the axis; times the spot's falloff.
                let c = dot(ray, axis);
                weight = info.direction.w * c * c * c;
                if (info.origin.w == KIND_SPOT) {
                    weight *= smoothstep(info.cone.x, info.cone.y, c);
                }
            }
            let n = decode_normal(texel.y);
            let cos_i = dot(n, to_light);
            if (cos_i <= 1e-3 || weight <= 0.0) {
                continue;
            }
            weight *= step_weight;
            // Flux `weight` enters per unit of the light's colour, whatever the slope: the
            // texel's area grows as 1 / cos_i as its irradiance falls as cos_i.
            pos += vec4<f32>(x * weight, weight);
            nrm += vec4<f32>(n * weight, weight / cos_i);
            // Squared distances from the light's origin: with the mean position they give the
            // cell's spread, large where it averages surfaces far apart (bounce.wgsl).
            let rel = x - info.origin.xyz;
            spread += weight * dot(rel, rel);
        }
    }
    textureStore(out_position, id.xy, layer, pos);
    textureStore(out_normal, id.xy, layer, nrm);
    textureStore(out_spread, id.xy, layer, vec4<f32>(spread, 0.0, 0.0, 0.0));
}

@compute @workgroup_size(8, 8, 1)
fn downsample(@builtin(global_invocation_id) id: vec3<u32>) {
    let dim = textureDimensions(out_position);
    if (id.x >= dim.x || id.y >= dim.y) {
        return;
    }
    let src = vec2<i32>(textureDimensions(in_position));
    let layer = i32(id.z);
    var pos = vec4<f32>(0.0);
    var nrm = vec4<f32>(0.0);
    var spread = 0.0;
    // An odd side's last row and column go to the last cell.
    let extra = vec2<i32>(select(vec2<u32>(0u), vec2<u32>(1u), (id.xy == dim - 1u) & (vec2<u32>(src) % 2u == vec2<u32>(1u))));
    for (var j = 0; j < 2 + extra.y; j++) {
        for (var i = 0; i < 2 + extra.x; i++) {
            let t = vec2<i32>(id.xy) * 2 + vec2<i32>(i, j);
            pos += textureLoad(in_position, t, layer, 0);
            nrm += textureLoad(in_normal, t, layer, 0);
            spread += textureLoad(in_spread, t, layer, 0).r;
        }
    }
    textureStore(out_position, id.xy, layer, pos);
    textureStore(out_normal, id.xy, layer, nrm);
    textureStore(out_spread, id.xy, layer, vec4<f32>(spread, 0.0, 0.0, 0.0));
}
