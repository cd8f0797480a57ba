// The lateral pass: `diffusion`'s whole transmitted light, every light together, at each texel
// of the reduced-resolution lateral map (layer 0 the diffuse part, which joins the irradiance;
// layer 1 the unscattered and singly scattered part, which joins the specular target; a = the
// texel's view depth, 0 where nothing was drawn). What crosses skin changes over the medium's
// decay length, not from pixel to pixel (the diffuse part is blurred by the profile after this
// anyway), so a texel of a few millimetres serves a block of pixels, and the lighting pass
// reads one interpolated value per pixel instead of running each light's thickness, LUT reads,
// taps and single-scattering march (transmittance.wgsl, `transmitted_from_map`). With the
// lateral taps alone in the map, `diffusion` cost +65 % of `paper`'s lighting pass on an H100
// at 1920x1080; with everything, +19 % (docs/performance.md).
//
// Two ways to fill the map, the same numbers (`LateralPass` in the settings):
// - `fs_transmitted` evaluates each texel in the raster pass's fragment shader;
// - `fs_surface` only records each texel's surface, and `cs_transmitted`, dispatched once per
//   object with that object's group 1 over the object's box on screen, evaluates the texels
//   it finds its index on (and `cs_bounce` the bounce, where the map has its layer). Data-centre
//   GPUs rasterise on a few of their units and ran a fragment shader's arithmetic many times
//   slower than a compute shader's (docs/performance.md), and this evaluation is nearly all
//   arithmetic.
// Part of lighting.rs's module: it calls lighting.wgsl's and transmittance.wgsl's functions.

struct LateralPair {
    @location(0) first: vec4<f32>,
    @location(1) second: vec4<f32>,
};

// `diffusion`'s transmitted light leaving `world` (vertex normal `n_vertex`, turned toward the
// camera's side), every shadowed light's radiance summed.
fn transmitted_light(world: vec3<f32>, n_vertex: vec3<f32>) -> Transmitted {
    var out = Transmitted(vec3<f32>(0.0), vec3<f32>(0.0));
    // Opaque objects keep only their depth in the map (the lighting pass's read tests it);
    // `light_entry` would find no thickness for any light.
    if (object.translucency <= 0.0) {
        return out;
    }
    let v = normalize(camera.position - world);
    let count = min(lights.count, MAX_LIGHTS);
    for (var i = 0u; i < count; i++) {
        let light = lights.lights[i];
        if (light.first_layer < 0.0) {
            continue;
        }
        let l = light_direction(light.kind, light.position, light.direction, world);
        let radiance = light_radiance(light, world, l);
        if (all(radiance <= vec3<f32>(0.0))) {
            continue;
        }
        let t = transmittance(light, world, n_vertex, l, v, shadow_factor(light, world));
        out.diffuse += radiance * t.diffuse;
        out.ballistic += radiance * t.ballistic;
    }
    return out;
}

@fragment
fn fs_transmitted(in: LitVarying, @builtin(front_facing) front: bool) -> LateralPair {
    let depth = dot(in.world - camera.position, camera.forward);
    let t = transmitted_light(in.world, oriented_normal(in, front));
    return LateralPair(vec4<f32>(t.diffuse, depth), vec4<f32>(t.ballistic, depth));
}

// The surface at each texel, for `cs_transmitted` (lighting.rs, `LateralTargets`): the world
// position and view depth (0: nothing), and the vertex normal turned toward the camera's side
// with the object's index in the draw list. 32-bit floats: the evaluation sees the point
// `fs_transmitted` would, to the bit.
@fragment
fn fs_surface(in: LitVarying, @builtin(front_facing) front: bool) -> LateralPair {
    let depth = dot(in.world - camera.position, camera.forward);
    return LateralPair(vec4<f32>(in.world, depth), vec4<f32>(oriented_normal(in, front), f32(object.index)));
}

// Group 2 of the compute evaluation (lighting.rs, `lateral_compute_layout`); the lighting
// pass's group 2 (texture-space maps) uses bindings 0 to 3.
@group(2) @binding(8) var surface_position: texture_2d<f32>;
@group(2) @binding(9) var surface_normal: texture_2d<f32>;
@group(2) @binding(10) var lateral_out: texture_storage_2d_array<rgba32float, write>;
// The first texel of this dispatch (xy): each object's dispatch covers only its box on screen
// (lighting.rs, `LightingPass::set_object_rects`), one entry per object at a dynamic offset.
// Binding 1: the lighting pass's group 3 has the lateral map at 0.
@group(3) @binding(1) var<uniform> dispatch_origin: vec4<u32>;

// A texel's surface as `fs_surface` recorded it, where it is this dispatch's object's.
struct TexelSurface {
    texel: vec2<i32>,
    world: vec3<f32>,
    normal: vec3<f32>,
    depth: f32,
    own: bool,    // in the map, drawn, and of this dispatch's object
};

// Texels of other objects and empty ones are left as they are: the pass cleared the map
// before the dispatches (lighting.rs, `encode_lateral`), and each texel is its object's alone.
fn texel_surface(id: vec3<u32>) -> TexelSurface {
    let at = dispatch_origin.xy + id.xy;
    let texel = vec2<i32>(at);
    var s = TexelSurface(texel, vec3<f32>(0.0), vec3<f32>(0.0), 0.0, false);
    if (any(at >= textureDimensions(surface_position))) {
        return s;
    }
    let surface = textureLoad(surface_position, texel, 0);
    let normal = textureLoad(surface_normal, texel, 0);
    s.world = surface.xyz;
    s.normal = normal.xyz;
    s.depth = surface.w;
    s.own = surface.w > 0.0 && u32(normal.w) == object.index;
    return s;
}

@compute @workgroup_size(8, 8)
fn cs_transmitted(@builtin(global_invocation_id) id: vec3<u32>) {
    let s = texel_surface(id);
    if (!s.own) {
        return;
    }
    let t = transmitted_light(s.world, s.normal);
    textureStore(lateral_out, s.texel, 0, vec4<f32>(t.diffuse, s.depth));
    textureStore(lateral_out, s.texel, 1, vec4<f32>(t.ballistic, s.depth));
}

// `fs_bounce` (lighting.wgsl) on the recorded surfaces, into the map's bounce layer.
@compute @workgroup_size(8, 8)
fn cs_bounce(@builtin(global_invocation_id) id: vec3<u32>) {
    let s = texel_surface(id);
    if (!s.own) {
        return;
    }
    let layer = i32(lights.bounce_layer);
    textureStore(lateral_out, s.texel, layer, vec4<f32>(bounce_irradiance(s.world, s.normal), s.depth));
}
