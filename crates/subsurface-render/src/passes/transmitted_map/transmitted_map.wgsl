// The map pass: `diffusion`'s whole transmitted light, every light together, at each texel
// of the reduced-resolution transmitted map (layer 0 the diffuse part, which joins the irradiance;
// layer 1 the unscattered and singly scattered part, which joins the specular target; layer 0's
// a = the texel's view depth, 0 where nothing was drawn, layer 1's the lights that reach it
// directly, `lit_code` in map_read.wgsl). What crosses skin changes over the medium's
// decay length, not from pixel to pixel (the diffuse part is blurred by the profile after this
// anyway), so a texel of a few millimetres serves a block of pixels, and the lighting pass
// reads one interpolated value per pixel instead of running each light's thickness, LUT reads,
// taps and single-scattering march (transmittance.wgsl, `transmitted_from_map`). With the
// lateral taps alone in the map, `diffusion` cost +65 % of `paper`'s lighting pass on an H100
// at 1920x1080; with everything, +19 % (docs/lab/performance.md).
//
// Two ways to fill the map, the same numbers (`MapEvaluation` in the settings):
// - `fs_transmitted` evaluates each texel in the raster pass's fragment shader;
// - `fs_surface` only records each texel's surface; `cs_clear` empties the map, then
//   `cs_transmitted`, dispatched once per object with that object's group 1 over the object's
//   box on screen, evaluates the texels it finds its index on, each over several invocations
//   (and `cs_bounce` the bounce, where the map has its layer). On an H200 this took the default
//   scene's map in a third of the fragment shader's time (docs/lab/performance.md).
// Part of the lighting shader (lighting/mod.rs, `SHADER`): it calls lighting.wgsl's and transmittance.wgsl's functions.

struct LateralPair {
    @location(0) first: vec4<f32>,
    @location(1) second: vec4<f32>,
};

// `diffusion`'s transmitted light leaving `world` (vertex normal `n_vertex`, turned toward the
// camera's side), every shadowed light's radiance summed, and the lights that reach it directly
// (`lit_code`, map_read.wgsl).
fn transmitted_light(world: vec3<f32>, n_vertex: vec3<f32>) -> TexelLight {
    var out = TexelLight(Transmitted(vec3<f32>(0.0), vec3<f32>(0.0)), 0u);
    let count = min(lights.count, MAX_LIGHTS);
    for (var i = 0u; i < count; i++) {
        let t = light_transmitted(i, world, n_vertex);
        out.t.diffuse += t.t.diffuse;
        out.t.ballistic += t.t.ballistic;
        out.lit |= t.lit;
    }
    return out;
}

// One light's part of a texel, or every light's: its transmitted light, radiance included, and
// its `lit_code` bits.
struct TexelLight {
    t: Transmitted,
    lit: u32,
};

// Light `i`'s part of `transmitted_light`.
fn light_transmitted(i: u32, world: vec3<f32>, n_vertex: vec3<f32>) -> TexelLight {
    var out = TexelLight(Transmitted(vec3<f32>(0.0), vec3<f32>(0.0)), 0u);
    let light = lights.lights[i];
    let v = normalize(camera.position - world);
    let l = light_direction(light.kind, light.position, light.direction, world);
    let radiance = light_radiance(light, world, l);
    if (all(radiance <= vec3<f32>(0.0))) {
        return out;
    }
    let shadow = shadow_factor(light, world);
    out.lit = lit_code(0u, i, dot(n_vertex, l), shadow);
    // Opaque objects keep only their depth in the map (the lighting pass's read tests it);
    // `light_entry` would find no thickness for any light.
    if (object.translucency <= 0.0 || light.first_layer < 0.0) {
        return out;
    }
    let t = transmittance(light, world, n_vertex, l, v, shadow);
    out.t = Transmitted(radiance * t.diffuse, radiance * t.ballistic);
    return out;
}

@fragment
fn fs_transmitted(in: LitVarying, @builtin(front_facing) front: bool) -> LateralPair {
    let depth = dot(in.world - camera.position, camera.forward);
    let t = transmitted_light(in.world, oriented_normal(in, front));
    return LateralPair(vec4<f32>(t.t.diffuse, depth), vec4<f32>(t.t.ballistic, f32(t.lit)));
}

// The surface at each texel, for `cs_transmitted` (transmitted_map/targets.rs, `TransmittedMapTargets`): the world
// position and view depth (0: nothing), and the vertex normal turned toward the camera's side
// with the object's index in the draw list. 32-bit floats: the evaluation sees the point
// `fs_transmitted` would, to the bit.
@fragment
fn fs_surface(in: LitVarying, @builtin(front_facing) front: bool) -> LateralPair {
    let depth = dot(in.world - camera.position, camera.forward);
    return LateralPair(vec4<f32>(in.world, depth), vec4<f32>(oriented_normal(in, front), f32(object.index)));
}

// Group 2 of the compute evaluation (transmitted_map/targets.rs, `map_compute_layout`); the lighting
// pass's group 2 (texture-space maps) uses bindings 0 to 3.
@group(2) @binding(8) var surface_position: texture_2d<f32>;
@group(2) @binding(9) var surface_normal: texture_2d<f32>;
@group(2) @binding(10) var map_out: texture_storage_2d_array<rgba32float, write>;
// The first texel of this dispatch (xy): each object's dispatch covers only its box on screen
// (transmitted_map/targets.rs, `ObjectRects`), one entry per object at a dynamic offset.
// Binding 1: the lighting pass's group 3 has the transmitted map at 0.
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
// before the dispatches (transmitted_map/mod.rs, `TransmittedMapPass::encode`), and each texel is its object's alone.
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

// `cs_transmitted` spreads each texel over TEXEL_LANES invocations (at least MAX_LIGHTS), a
// workgroup over a BLOCK_WIDTH x BLOCK_HEIGHT block of texels. The map has a few thousand
// texels, too few to keep a GPU's units busy one invocation each, and each texel's light is a
// chain of dependent loads (per light: its thickness's N x N shadow-map texels, 12 lateral
// taps of a shadow-map texel and a LUT row each, the rest of `transmittance`) that one
// invocation waits out load after load: on an H200 the default scene's 160 x 90 texels took
// 0.10 ms, whatever the map's size. Spread, one lane per light first finds the light's entry,
// then the lanes of each light take a stride of its lateral taps, then one lane per light
// evaluates the rest with the entry and the taps' sum given (LATERAL_SOURCE 3), and the first
// lane adds the lights.
override TEXEL_LANES: u32 = 8u;
override BLOCK_WIDTH: u32 = 4u;
override BLOCK_HEIGHT: u32 = 2u;
var<workgroup> lane_entry: array<vec4<f32>, BLOCK_WIDTH * BLOCK_HEIGHT * TEXEL_LANES>;
var<workgroup> lane_taps: array<vec3<f32>, BLOCK_WIDTH * BLOCK_HEIGHT * TEXEL_LANES>;
var<workgroup> lane_mass: array<vec2<f32>, BLOCK_WIDTH * BLOCK_HEIGHT * TEXEL_LANES>;
var<workgroup> lane_diffuse: array<vec3<f32>, BLOCK_WIDTH * BLOCK_HEIGHT * TEXEL_LANES>;
var<workgroup> lane_ballistic: array<vec3<f32>, BLOCK_WIDTH * BLOCK_HEIGHT * TEXEL_LANES>;
var<workgroup> lane_lit: array<u32, BLOCK_WIDTH * BLOCK_HEIGHT * TEXEL_LANES>;

// The texel (relative to the dispatch's origin) of workgroup `group`'s `slot`.
fn block_texel(group: vec3<u32>, slot: u32) -> vec3<u32> {
    let block = vec2<u32>(BLOCK_WIDTH, BLOCK_HEIGHT);
    return vec3<u32>(group.xy * block + vec2<u32>(slot % BLOCK_WIDTH, slot / BLOCK_WIDTH), 0u);
}

@compute @workgroup_size(BLOCK_WIDTH * BLOCK_HEIGHT * TEXEL_LANES)
fn cs_transmitted(@builtin(workgroup_id) group: vec3<u32>, @builtin(local_invocation_index) index: u32) {
    let slot = index / TEXEL_LANES;
    let lane = index % TEXEL_LANES;
    let s = texel_surface(block_texel(group, slot));
    let count = min(lights.count, MAX_LIGHTS);
    let first_lane = slot * TEXEL_LANES;
    let translucent = s.own && object.translucency > 0.0;
    // The barriers need every invocation: those without work store zeros instead of leaving.
    // Lane i: light i's entry.
    var entry = vec4<f32>(0.0, 0.0, 0.0, -1.0);
    if (translucent && lane < count && lights.lights[lane].first_layer >= 0.0) {
        let e = light_entry(lights.lights[lane], s.world, s.normal);
        entry = vec4<f32>(e.normal, e.s_mm);
    }
    lane_entry[index] = entry;
    workgroupBarrier();
    // Lane i * per_light + j: light i's taps j, j + per_light, ...
    let per_light = TEXEL_LANES / max(count, 1u);
    let light_index = lane / per_light;
    var taps = vec3<f32>(0.0);
    lateral_mass = vec2<f32>(0.0);
    if (translucent && light_index < count && lights.lateral_taps > 0u && object.lateral_decay > 0.0) {
        let s_mm = lane_entry[first_lane + light_index].w;
        if (s_mm >= 0.0) {
            let light = lights.lights[light_index];
            let l = light_direction(light.kind, light.position, light.direction, s.world);
            taps = lateral_tap_sum(light, s.world, s.normal, l, s_mm, lane % per_light, per_light);
        }
    }
    lane_taps[index] = taps;
    lane_mass[index] = lateral_mass;
    workgroupBarrier();
    // Lane i: the rest of light i's transmittance.
    var t = TexelLight(Transmitted(vec3<f32>(0.0), vec3<f32>(0.0)), 0u);
    if (s.own && lane < count) {
        var sum = vec3<f32>(0.0);
        var mass = vec2<f32>(0.0);
        for (var k = 0u; k < per_light; k++) {
            sum += lane_taps[first_lane + lane * per_light + k];
            mass += lane_mass[first_lane + lane * per_light + k];
        }
        let e = lane_entry[index];
        given_entry = Entry(e.w, e.xyz);
        given_lateral = sum;
        given_mass = mass;
        t = light_transmitted(lane, s.world, s.normal);
    }
    lane_diffuse[index] = t.t.diffuse;
    lane_ballistic[index] = t.t.ballistic;
    lane_lit[index] = t.lit;
    workgroupBarrier();
    if (!s.own || lane != 0u) {
        return;
    }
    var out = TexelLight(Transmitted(vec3<f32>(0.0), vec3<f32>(0.0)), 0u);
    for (var k = 0u; k < count; k++) {
        out.t.diffuse += lane_diffuse[first_lane + k];
        out.t.ballistic += lane_ballistic[first_lane + k];
        out.lit |= lane_lit[first_lane + k];
    }
    textureStore(map_out, s.texel, 0, vec4<f32>(out.t.diffuse, s.depth));
    textureStore(map_out, s.texel, 1, vec4<f32>(out.t.ballistic, f32(out.lit)));
}

// Every layer of the map to nothing (depth 0), before the objects' dispatches write their
// own texels: one dispatch in the compute pass instead of render passes that only clear.
@compute @workgroup_size(8, 8)
fn cs_clear(@builtin(global_invocation_id) id: vec3<u32>) {
    if (any(id.xy >= textureDimensions(map_out))) {
        return;
    }
    for (var layer = 0u; layer < textureNumLayers(map_out); layer++) {
        textureStore(map_out, vec2<i32>(id.xy), i32(layer), vec4<f32>(0.0));
    }
}

// `fs_bounce` (lighting.wgsl) on the recorded surfaces, into the map's bounce layer: spread as
// `cs_transmitted` is, each lane gathering a stride of each pyramid level's rows of cells (a
// texel reads some 40 cells per level and light at ring 2, each a load whose result decides
// the next two), and lane 0 adding the lanes' sums (in `lane_taps`, free in this pipeline).
@compute @workgroup_size(BLOCK_WIDTH * BLOCK_HEIGHT * TEXEL_LANES)
fn cs_bounce(@builtin(workgroup_id) group: vec3<u32>, @builtin(local_invocation_index) index: u32) {
    let slot = index / TEXEL_LANES;
    let lane = index % TEXEL_LANES;
    let s = texel_surface(block_texel(group, slot));
    var e = vec3<f32>(0.0);
    if (s.own) {
        e = bounce_rows(s.world, s.normal, lane, TEXEL_LANES);
    }
    lane_taps[index] = e;
    workgroupBarrier();
    if (!s.own || lane != 0u) {
        return;
    }
    var sum = vec3<f32>(0.0);
    for (var k = 0u; k < TEXEL_LANES; k++) {
        sum += lane_taps[slot * TEXEL_LANES + k];
    }
    textureStore(map_out, s.texel, i32(lights.bounce_layer), vec4<f32>(sum, s.depth));
}
