
// Direct fetch: every texel of a tap reads the three input textures and is corrected.

fn centre(p: vec2<f32>) -> Centre {
    return input_centre(vec2<i32>(p));
}

fn extent() -> vec2<i32> {
    return vec2<i32>(textureDimensions(color_tex));
}

// One texel's colour as a tap sees it: a texel that is not skin, belongs to another profile
// (another material), or (with follow-surface) lies on another surface, is pulled back to the
// centre colour, so neither background nor a different material bleeds in (no halo at
// silhouettes; the depth correction of Jimenez et al. 2009 with the threshold in millimetres
// on the skin rather than a unitless constant).
fn corrected(texel: vec2<i32>, c: Centre) -> vec3<f32> {
    let color = textureLoad(color_tex, texel, 0).rgb;
    let depth = textureLoad(depth_tex, texel, 0).r;
    let sss = textureLoad(sss_tex, texel, 0);
    var s = 0.0;
    if (sss.r <= 0.0 || profile_of(sss) != c.profile) {
        s = 1.0;
    } else if (u.follow_surface != 0u) {
        s = min(abs(c.depth - depth) / (u.edge_mm * c.world_per_mm), 1.0);
    }
    return mix(color, c.color, s);
}

// The narrowest Gaussian is the unblurred input times its weights: starts the accumulation.
@fragment
fn fs_copy(in: FullscreenOut) -> @location(0) vec4<f32> {
    let texel = vec2<i32>(in.clip.xy);
    let base = profile_of(textureLoad(sss_tex, texel, 0)) * u.stride;
    return vec4<f32>(textureLoad(color_tex, texel, 0).rgb * table[base + u.gaussians].rgb, 1.0);
}

// Writes the accumulated result back into the diffuse target, on skin pixels only, so every
// other pixel stays bit-identical.
@fragment
fn fs_resolve(in: FullscreenOut) -> @location(0) vec4<f32> {
    let texel = vec2<i32>(in.clip.xy);
    if (textureLoad(sss_tex, texel, 0).r <= 0.0) {
        discard;
    }
    return vec4<f32>(textureLoad(accum_tex, texel, 0).rgb, 1.0);
}
