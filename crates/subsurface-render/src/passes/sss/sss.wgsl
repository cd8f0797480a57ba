// Screen-space subsurface scattering (Jimenez et al. 2009, GPU Pro 2010; Separable SSS 2015;
// Hable et al. 2009's 13 taps). All passes share one rule for fetching a tap, written to match
// subsurface_profile::oracle::screen exactly: bilinear filtering of texels that were each
// corrected first (non-skin texels, texels of another profile and texels across a depth edge
// are pulled back to the centre colour). Each pixel reads its kernel from the profile table
// row its material wrote into the SSS target, so every material keeps its own profile.
//
// This file is followed by one of two ways to fetch a texel, which define `centre`,
// `corrected` and `extent`: sss_direct.wgsl reads the three input textures per texel,
// sss_packed.wgsl one texel of a packed copy that holds all a tap needs.

struct SssUniform {
    direction: vec2<f32>, // pixel direction of a 1-D pass
    focal_px: f32,        // 0.5 * height / tan(fov_y / 2)
    edge_mm: f32,         // depth difference on the skin that fully stops a tap
    follow_surface: u32,
    min_sigma_px: f32,    // six Gaussians: narrower ones are skipped
    taps: u32,            // separable taps per profile
    stride: u32,          // table rows per profile
    hable: u32,           // first row of Hable's taps (two rows each: rgb weight, xy mm)
    gaussians: u32,       // first row of the six Gaussians (rgb weight, variance mm^2)
    gaussian: u32,        // six Gaussians: the Gaussian this pass blurs up to
    previous: u32,        // and the one it starts from
    profiles: u32,        // rows of the table
    seed: u32,            // jittered separable: 0 = horizontal pass, 1 = vertical
    widths: u32,          // first row of the separable taps' jitter half-widths (mm, in x)
    _pad0: u32,
    // The pixels [x0, y0, x1, y1) the separable passes run on: every skin pixel and every tap
    // it reads lies inside (SssPass::set_region); the pixels outside are left as they are.
    region: vec4<u32>,
};

@group(0) @binding(0) var<uniform> u: SssUniform;
@group(0) @binding(1) var color_tex: texture_2d<f32>;
@group(0) @binding(2) var depth_tex: texture_2d<f32>;
// r = strength (0 = not skin), g = scene units per profile mm, b = profile row.
@group(0) @binding(3) var sss_tex: texture_2d<f32>;
@group(0) @binding(4) var<storage, read> table: array<vec4<f32>>;
@group(0) @binding(5) var accum_tex: texture_2d<f32>;
fn profile_of(s: vec4<f32>) -> u32 {
    return min(u32(max(s.b, 0.0) + 0.5), u.profiles - 1u);
}

struct Centre {
    color: vec3<f32>,
    depth: f32,
    strength: f32,
    world_per_mm: f32,
    px_per_mm: f32,
    profile: u32,
    base: u32,            // the profile's first table row
};

// The centre as the input textures give it.
fn input_centre(texel: vec2<i32>) -> Centre {
    var c: Centre;
    c.color = textureLoad(color_tex, texel, 0).rgb;
    c.depth = textureLoad(depth_tex, texel, 0).r;
    let s = textureLoad(sss_tex, texel, 0);
    c.strength = s.r;
    c.world_per_mm = s.g;
    c.profile = profile_of(s);
    return with_footprint(c);
}

fn with_footprint(centre: Centre) -> Centre {
    var c = centre;
    c.base = c.profile * u.stride;
    // Perspective-correct footprint: a millimetre on the skin covers focal / depth pixels per
    // scene unit, so the blur keeps its physical size at any distance and resolution. The
    // per-pixel strength scales it, as the alpha channel does in Jimenez's shaders.
    c.px_per_mm = c.world_per_mm * u.focal_px / max(c.depth, 1e-6) * c.strength;
    return c;
}

// Bilinear filtering done by hand over corrected texels: a hardware-filtered fetch would mix a
// background texel into a skin tap before any correction could see it. Texels with zero
// weight are not loaded, so a 1-D pass reads two texels per tap.
fn tap(p: vec2<f32>, c: Centre) -> vec3<f32> {
    let last = extent() - vec2<i32>(1);
    let t = p - vec2<f32>(0.5);
    let i0 = floor(t);
    let f = t - i0;
    let a = clamp(vec2<i32>(i0), vec2<i32>(0), last);
    let b = clamp(vec2<i32>(i0) + vec2<i32>(1), vec2<i32>(0), last);
    var top = corrected(a, c);
    if (f.x > 0.0) {
        top = mix(top, corrected(vec2<i32>(b.x, a.y), c), f.x);
    }
    if (f.y > 0.0) {
        var bottom = corrected(vec2<i32>(a.x, b.y), c);
        if (f.x > 0.0) {
            bottom = mix(bottom, corrected(b, c), f.x);
        }
        top = mix(top, bottom, f.y);
    }
    return top;
}

// Separable SSS (2015): one 1-D pass of the kernel; run horizontally, then vertically.
fn separable(p: vec2<f32>, c: Centre) -> vec3<f32> {
    if (c.strength <= 0.0) {
        return c.color;
    }
    var sum = table[c.base].rgb * c.color;
    for (var i = 1u; i < u.taps; i++) {
        let k = table[c.base + i];
        sum += k.rgb * tap(p + u.direction * (k.w * c.px_per_mm), c);
    }
    return sum;
}

@fragment
fn fs_separable(in: FullscreenOut) -> @location(0) vec4<f32> {
    return vec4<f32>(separable(in.clip.xy, centre(in.clip.xy)), 1.0);
}

// PCG's output hash (Jarzynski and Olano 2020): integers only, so the CPU oracle
// (oracle::screen::jitter_value) draws exactly these numbers.
fn pcg(v: u32) -> u32 {
    let state = v * 747796405u + 2891336453u;
    let word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

// The pixel's hash in this pass, drawn once (oracle::screen::jitter_seed).
fn jitter_seed(texel: vec2<u32>) -> u32 {
    return pcg(texel.x + pcg(texel.y + pcg(u.seed)));
}

// In [0, 1): the top 24 bits, exact in f32. Every pixel, pass and tap draws its own number.
fn jitter_value(seed: u32, tap: u32) -> f32 {
    return f32(pcg(seed + tap) >> 8u) * (1.0 / 16777216.0);
}

// Separable SSS's few-sample mode (2015: seven samples with jittering): each tap moves, per
// pixel and pass, within the interval its weight stands for, so the few taps' ghost copies of
// features turn into fine noise (oracle::screen::separable_jittered). The weights are
// untouched: a flat surface keeps its energy.
// Tap i's offset in mm, moved within its interval (the row of half-widths after the taps).
fn jittered_offset(seed: u32, i: u32, offset: f32, c: Centre) -> f32 {
    let width = table[c.base + u.widths + i].x;
    // Rows i and taps - i are the taps at -o and +o: one number moves both outward or inward
    // (a random scale of the pair), so their errors cancel on a linear gradient.
    let xi = jitter_value(seed, min(i, u.taps - i));
    let outward = select(-1.0, 1.0, offset >= 0.0);
    return offset + outward * (2.0 * xi - 1.0) * width;
}

fn separable_jitter(p: vec2<f32>, c: Centre) -> vec3<f32> {
    if (c.strength <= 0.0) {
        return c.color;
    }
    let seed = jitter_seed(vec2<u32>(p));
    var sum = table[c.base].rgb * c.color;
    for (var i = 1u; i < u.taps; i++) {
        let k = table[c.base + i];
        let o = jittered_offset(seed, i, k.w, c);
        sum += k.rgb * tap(p + u.direction * (o * c.px_per_mm), c);
    }
    return sum;
}

@fragment
fn fs_separable_jitter(in: FullscreenOut) -> @location(0) vec4<f32> {
    return vec4<f32>(separable_jitter(in.clip.xy, centre(in.clip.xy)), 1.0);
}

const G7_W = array<f32, 7>(0.006, 0.061, 0.242, 0.382, 0.242, 0.061, 0.006);

// The increment from the previous Gaussian to this pass's one, in the centre's own profile:
// each Gaussian is the previous one blurred by the difference of variances (d'Eon).
fn gaussian7(p: vec2<f32>, c: Centre) -> vec3<f32> {
    if (c.strength <= 0.0) {
        return c.color;
    }
    let v_start = table[c.base + u.gaussians + u.previous].w;
    let v_end = table[c.base + u.gaussians + u.gaussian].w;
    let sigma_px = sqrt(max(v_end - v_start, 0.0)) * c.px_per_mm;
    // GPU Pro's distance-based removal: a sub-pixel Gaussian changes nothing visible.
    if (sigma_px < u.min_sigma_px) {
        return c.color;
    }
    var sum = G7_W[3] * c.color;
    for (var j = 0; j < 7; j++) {
        if (j == 3) {
            continue;
        }
        sum += G7_W[j] * tap(p + u.direction * (f32(j - 3) * sigma_px), c);
    }
    return sum;
}

// Six-Gaussian (2009 / GPU Pro): horizontal 7-tap pass of one Gaussian's variance increment.
@fragment
fn fs_gaussian(in: FullscreenOut) -> @location(0) vec4<f32> {
    return vec4<f32>(gaussian7(in.clip.xy, centre(in.clip.xy)), 1.0);
}

struct GaussianAccumOut {
    @location(0) blurred: vec4<f32>,
    // Weighted by the Gaussian's RGB weights and added to the accumulation target by
    // additive blending, so no buffer per Gaussian is kept (GPU Pro's blending pipeline; the
    // weights are applied here rather than as a blend constant, whose precision is not
    // guaranteed).
    @location(1) accum: vec4<f32>,
};

@fragment
fn fs_gaussian_accumulate(in: FullscreenOut) -> GaussianAccumOut {
    let c = centre(in.clip.xy);
    let b = vec4<f32>(gaussian7(in.clip.xy, c), 1.0);
    var out: GaussianAccumOut;
    out.blurred = b;
    out.accum = vec4<f32>(b.rgb * table[c.base + u.gaussians + u.gaussian].rgb, 1.0);
    return out;
}

// Hable et al. 2009: one 2-D pass with 13 jittered taps; row 2i = rgb weight, row 2i + 1 =
// offset in mm, from the profile's first Hable row.
@fragment
fn fs_hable13(in: FullscreenOut) -> @location(0) vec4<f32> {
    let c = centre(in.clip.xy);
    if (c.strength <= 0.0) {
        return vec4<f32>(c.color, 1.0);
    }
    let first = c.base + u.hable;
    var sum = table[first].rgb * c.color;
    for (var i = 1u; i < 13u; i++) {
        let w = table[first + 2u * i].rgb;
        let o = table[first + 2u * i + 1u].xy;
        sum += w * tap(in.clip.xy + o * c.px_per_mm, c);
    }
    return vec4<f32>(sum, 1.0);
}
