// Texture-space diffusion (d'Eon et al.), steps 2 and 3: the separable Gaussian blurs of the
// irradiance map and the padding of the UV islands. Appended to fullscreen.wgsl
// (`vs_fullscreen`); group 0, bindings 10-13. The CPU mirror is
// `subsurface_profile::oracle::texture`.

// ---- Separable Gaussian blurs --------------------------------------------------------------

struct BlurUniform {
    dir: vec4<f32>,     // xy = texel axis of this 1-D pass, z = sigma in profile mm
    weight: vec4<f32>,  // rgb weight of the Gaussian being accumulated (copy: the narrowest)
    params: vec4<f32>,  // x = padding radius in texels (dilation), y = largest sigma in texels
};

@group(0) @binding(10) var<uniform> blur: BlurUniform;
@group(0) @binding(11) var blur_src: texture_2d<f32>;
@group(0) @binding(12) var blur_stretch: texture_2d<f32>;
@group(0) @binding(13) var blur_extra: texture_2d<f32>;

// 7 taps one standard deviation apart (d'Eon's and the screen-space six-Gaussian weights).
const TS_G7 = array<f32, 7>(0.006, 0.061, 0.242, 0.382, 0.242, 0.061, 0.006);

// A texel as a tap sees it: texels outside every UV island (alpha 0) are replaced by the
// centre colour, so the blur never pulls black in at seams and island borders.
fn ts_texel(texel: vec2<i32>, centre: vec3<f32>) -> vec3<f32> {
    let c = textureLoad(blur_src, texel, 0);
    return select(centre, c.rgb, c.a > 0.5);
}

// Linear interpolation by hand over corrected texels (the same rule as the CPU mirror
// `cpu_blur`); a 1-D pass at texel centres reads two texels per tap.
fn ts_tap(p: vec2<f32>, centre: vec3<f32>) -> vec3<f32> {
    let last = vec2<i32>(textureDimensions(blur_src)) - vec2<i32>(1);
    let t = p - vec2<f32>(0.5);
    let i0 = floor(t);
    let f = t - i0;
    let a = clamp(vec2<i32>(i0), vec2<i32>(0), last);
    let b = clamp(vec2<i32>(i0) + vec2<i32>(1), vec2<i32>(0), last);
    var top = ts_texel(a, centre);
    if (f.x > 0.0) {
        top = mix(top, ts_texel(vec2<i32>(b.x, a.y), centre), f.x);
    }
    if (f.y > 0.0) {
        var bottom = ts_texel(vec2<i32>(a.x, b.y), centre);
        if (f.x > 0.0) {
            bottom = mix(bottom, ts_texel(b, centre), f.x);
        }
        top = mix(top, bottom, f.y);
    }
    return top;
}

fn ts_blur(p: vec2<f32>) -> vec4<f32> {
    let texel = vec2<i32>(p);
    let c = textureLoad(blur_src, texel, 0);
    if (c.a <= 0.5) {
        return c;
    }
    // Stretch correction: sigma in millimetres becomes texels along this axis.
    let s = textureLoad(blur_stretch, texel, 0).xy;
    let mm_per_texel = abs(blur.dir.x) * s.x + abs(blur.dir.y) * s.y;
    let sigma = min(blur.dir.z / max(mm_per_texel, 1e-12), blur.params.y);
    var sum = TS_G7[3] * c.rgb;
    for (var j = 0; j < 7; j++) {
        if (j == 3) {
            continue;
        }
        sum += TS_G7[j] * ts_tap(p + blur.dir.xy * (f32(j - 3) * sigma), c.rgb);
    }
    return vec4<f32>(sum, c.a);
}

// Horizontal pass of one Gaussian's variance increment.
@fragment
fn fs_ts_blur(in: FullscreenOut) -> @location(0) vec4<f32> {
    return ts_blur(in.clip.xy);
}

struct TsAccumOut {
    @location(0) blurred: vec4<f32>,
    // Weighted here and added by additive blending (alpha replaced: coverage).
    @location(1) accum: vec4<f32>,
};

// Vertical pass: completes the Gaussian (kept for the next, wider one) and accumulates it.
@fragment
fn fs_ts_blur_accumulate(in: FullscreenOut) -> TsAccumOut {
    let b = ts_blur(in.clip.xy);
    var out: TsAccumOut;
    out.blurred = b;
    out.accum = vec4<f32>(b.rgb * blur.weight.rgb, b.a);
    return out;
}

// The narrowest Gaussian is the irradiance itself times its weights.
@fragment
fn fs_ts_copy(in: FullscreenOut) -> @location(0) vec4<f32> {
    let c = textureLoad(blur_src, vec2<i32>(in.clip.xy), 0);
    return vec4<f32>(c.rgb * blur.weight.rgb, c.a);
}

// ---- Padding of the UV islands -------------------------------------------------------------

struct TsDilateOut {
    @location(0) result: vec4<f32>,
    @location(1) widest: vec4<f32>,
};

// Empty texels within `padding` texels of an island take the mean of the island texels on
// the nearest square ring around them (alpha 0.5 marks padding), so bilinear lookups at the
// islands' borders never mix in black.
@fragment
fn fs_ts_dilate(in: FullscreenOut) -> TsDilateOut {
    let texel = vec2<i32>(in.clip.xy);
    var out: TsDilateOut;
    out.result = textureLoad(blur_src, texel, 0);
    out.widest = textureLoad(blur_extra, texel, 0);
    if (out.result.a > 0.5) {
        return out;
    }
    let last = vec2<i32>(textureDimensions(blur_src)) - vec2<i32>(1);
    let radius = i32(blur.params.x);
    for (var r = 1; r <= radius; r++) {
        var sum_a = vec3<f32>(0.0);
        var sum_b = vec3<f32>(0.0);
        var n = 0.0;
        for (var dy = -r; dy <= r; dy++) {
            for (var dx = -r; dx <= r; dx++) {
                if (max(abs(dx), abs(dy)) != r) {
                    continue;
                }
                let q = texel + vec2<i32>(dx, dy);
                if (any(q < vec2<i32>(0)) || any(q > last)) {
                    continue;
                }
                let a = textureLoad(blur_src, q, 0);
                if (a.a > 0.5) {
                    sum_a += a.rgb;
                    sum_b += textureLoad(blur_extra, q, 0).rgb;
                    n += 1.0;
                }
            }
        }
        if (n > 0.0) {
            out.result = vec4<f32>(sum_a / n, 0.5);
            out.widest = vec4<f32>(sum_b / n, 0.5);
            return out;
        }
    }
    return out;
}
