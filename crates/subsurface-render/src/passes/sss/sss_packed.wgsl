
// Packed fetch: a first pass (fs_pack) copies what a tap needs into one Rgba32Uint texel per
// pixel, so each texel of a tap is one load instead of three (colour, depth, SSS data):
//   x = colour rg as two f16, y = colour b as f16 | key << 16 (profile row + 1, 0 = not
//   skin), z = depth as f32 bits, w = strength and scene units per profile mm as two f16.
// The colour and the SSS data are f16 textures already, so nothing is rounded that the direct
// fetch reads exactly; the 1-D passes write this layout too, and the second pass reads it.
@group(0) @binding(6) var packed_tex: texture_2d<u32>;

fn pack(color: vec3<f32>, c: Centre) -> vec4<u32> {
    // `!(s <= 0)` rather than `s > 0`: a NaN strength counts as skin, as the direct fetch
    // (and the oracle) count it.
    let key = select(0u, c.profile + 1u, !(c.strength <= 0.0));
    return vec4<u32>(
        pack2x16float(color.rg),
        (pack2x16float(vec2<f32>(color.b, 0.0)) & 0xffffu) | (key << 16u),
        bitcast<u32>(c.depth),
        pack2x16float(vec2<f32>(c.strength, c.world_per_mm)),
    );
}

fn unpack_color(t: vec4<u32>) -> vec3<f32> {
    return vec3<f32>(unpack2x16float(t.x), unpack2x16float(t.y & 0xffffu).x);
}

@fragment
fn fs_pack(in: FullscreenOut) -> @location(0) vec4<u32> {
    let c = input_centre(vec2<i32>(in.clip.xy));
    return pack(c.color, c);
}

fn centre(p: vec2<f32>) -> Centre {
    return centre_of(textureLoad(packed_tex, vec2<i32>(p), 0));
}

fn centre_of(t: vec4<u32>) -> Centre {
    var c: Centre;
    c.color = unpack_color(t);
    c.depth = bitcast<f32>(t.z);
    let s = unpack2x16float(t.w);
    c.strength = s.x;
    c.world_per_mm = s.y;
    c.profile = max(t.y >> 16u, 1u) - 1u;
    return with_footprint(c);
}

fn extent() -> vec2<i32> {
    return vec2<i32>(textureDimensions(packed_tex));
}

// The direct fetch's `corrected` (sss_direct.wgsl) on one packed texel.
fn corrected(texel: vec2<i32>, c: Centre) -> vec3<f32> {
    return corrected_texel(textureLoad(packed_tex, texel, 0), c);
}

fn corrected_texel(t: vec4<u32>, c: Centre) -> vec3<f32> {
    let color = unpack_color(t);
    var s = 0.0;
    if ((t.y >> 16u) != c.profile + 1u) {
        s = 1.0;
    } else if (u.follow_surface != 0u) {
        s = min(abs(c.depth - bitcast<f32>(t.z)) / (u.edge_mm * c.world_per_mm), 1.0);
    }
    return mix(color, c.color, s);
}

@fragment
fn fs_copy(in: FullscreenOut) -> @location(0) vec4<f32> {
    let c = centre(in.clip.xy);
    return vec4<f32>(c.color * table[c.base + u.gaussians].rgb, 1.0);
}

@fragment
fn fs_resolve(in: FullscreenOut) -> @location(0) vec4<f32> {
    let texel = vec2<i32>(in.clip.xy);
    if ((textureLoad(packed_tex, texel, 0).y >> 16u) == 0u) {
        discard;
    }
    return vec4<f32>(textureLoad(accum_tex, texel, 0).rgb, 1.0);
}

// The first of two 1-D passes: its result, packed with the centre's key, feeds the second.
@fragment
fn fs_separable_packed(in: FullscreenOut) -> @location(0) vec4<u32> {
    let c = centre(in.clip.xy);
    return pack(separable(in.clip.xy, c), c);
}

@fragment
fn fs_separable_jitter_packed(in: FullscreenOut) -> @location(0) vec4<u32> {
    let c = centre(in.clip.xy);
    return pack(separable_jitter(in.clip.xy, c), c);
}

@fragment
fn fs_gaussian_packed(in: FullscreenOut) -> @location(0) vec4<u32> {
    let c = centre(in.clip.xy);
    return pack(gaussian7(in.clip.xy, c), c);
}

struct GaussianAccumPackedOut {
    @location(0) blurred: vec4<u32>,
    @location(1) accum: vec4<f32>,
};

@fragment
fn fs_gaussian_accumulate_packed(in: FullscreenOut) -> GaussianAccumPackedOut {
    let c = centre(in.clip.xy);
    let b = gaussian7(in.clip.xy, c);
    var out: GaussianAccumPackedOut;
    out.blurred = pack(b, c);
    out.accum = vec4<f32>(b * table[c.base + u.gaussians + u.gaussian].rgb, 1.0);
    return out;
}
