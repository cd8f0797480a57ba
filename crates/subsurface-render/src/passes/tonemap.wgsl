// Composite and tone map: diffuse (after subsurface scattering) plus specular, exposure,
// Hable's filmic curve, written to an sRGB target (the hardware applies the sRGB encode).

struct ToneParams {
    // x = 2^EV, y = view (0 final, 1 mask, 2 depth, 3 diffuse, 4 specular, 5 thickness),
    // z = far, w = 1: diffuse_tex is a UV-space map shown letterboxed
    exposure: vec4<f32>,
};

// Must match tonemap.rs THICKNESS_RANGE_MM.
const THICKNESS_RANGE_MM: f32 = 8.0;

@group(0) @binding(0) var<uniform> params: ToneParams;
@group(0) @binding(1) var diffuse_tex: texture_2d<f32>;
@group(0) @binding(2) var specular_tex: texture_2d<f32>;
@group(0) @binding(3) var depth_tex: texture_2d<f32>;
@group(0) @binding(4) var sss_tex: texture_2d<f32>;


// John Hable's filmic curve (Uncharted 2), normalised so that the white point maps to 1.
fn hable(x: vec3<f32>) -> vec3<f32> {
    let a = 0.15;
    let b = 0.50;
    let c = 0.10;
    let d = 0.20;
    let e = 0.02;
    let f = 0.30;
    return ((x * (a * x + c * b) + d * e) / (x * (a * x + b) + d * f)) - e / f;
}

fn filmic(x: vec3<f32>) -> vec3<f32> {
    let white = 11.2;
    // The factor 2 is Hable's exposure bias, so that mid grey lands mid screen.
    return hable(2.0 * x) / hable(vec3<f32>(white));
}

// Thin is bright: white at 0 mm, yellow, red, black at the range, so that the parts that
// transmit (ears, nostrils, finger edges) stand out the way the light through them does.
fn thickness_ramp(mm: f32) -> vec3<f32> {
    let t = clamp(mm / THICKNESS_RANGE_MM, 0.0, 1.0);
    let white = vec3<f32>(1.0, 1.0, 1.0);
    let yellow = vec3<f32>(1.0, 0.85, 0.1);
    let red = vec3<f32>(0.8, 0.05, 0.02);
    let black = vec3<f32>(0.0);
    if (t < 0.1) {
        return mix(white, yellow, t / 0.1);
    }
    if (t < 0.4) {
        return mix(yellow, red, (t - 0.1) / 0.3);
    }
    return mix(red, black, (t - 0.4) / 0.6);
}

// The texel of a (square) UV-space map shown as the largest centred square of the output;
// x < 0 outside it.
fn letterbox(p: vec2<i32>) -> vec2<i32> {
    let out_size = vec2<i32>(textureDimensions(specular_tex));
    let map_size = vec2<i32>(textureDimensions(diffuse_tex));
    let side = min(out_size.x, out_size.y);
    let local = p - (out_size - vec2<i32>(side)) / 2;
    if (any(local < vec2<i32>(0)) || any(local >= vec2<i32>(side))) {
        return vec2<i32>(-1);
    }
    // The map's v = 0 is its first row, shown at the top like the image's first row.
    return min(local * map_size / side, map_size - vec2<i32>(1));
}

@fragment
fn fs_main(in: FullscreenOut) -> @location(0) vec4<f32> {
    let p = vec2<i32>(in.clip.xy);
    if (params.exposure.w > 0.5) {
        let t = letterbox(p);
        if (t.x < 0) {
            return vec4<f32>(0.0, 0.0, 0.0, 1.0);
        }
        let e = textureLoad(diffuse_tex, t, 0).rgb;
        let m = filmic(max(e, vec3<f32>(0.0)) * params.exposure.x);
        return vec4<f32>(clamp(m, vec3<f32>(0.0), vec3<f32>(1.0)), 1.0);
    }
    let diffuse = textureLoad(diffuse_tex, p, 0).rgb;
    let specular = textureLoad(specular_tex, p, 0).rgb;
    let view = u32(params.exposure.y);
    var c: vec3<f32>;
    switch view {
        case 1u: {
            let s = textureLoad(sss_tex, p, 0).r;
            return vec4<f32>(vec3<f32>(s), 1.0);
        }
        case 2u: {
            let d = textureLoad(depth_tex, p, 0).r / params.exposure.z;
            return vec4<f32>(vec3<f32>(clamp(d, 0.0, 1.0)), 1.0);
        }
        case 3u: {
            c = diffuse;
        }
        case 4u: {
            c = specular;
        }
        case 5u: {
            // The lighting pass wrote the thickness (mm) into diffuse.r, < 0 where unknown.
            if (textureLoad(sss_tex, p, 0).r <= 0.0) {
                return vec4<f32>(0.0, 0.0, 0.0, 1.0);
            }
            if (diffuse.r < 0.0) {
                return vec4<f32>(0.25, 0.25, 0.25, 1.0);
            }
            return vec4<f32>(thickness_ramp(diffuse.r), 1.0);
        }
        default: {
            c = diffuse + specular;
        }
    }
    let mapped = filmic(max(c, vec3<f32>(0.0)) * params.exposure.x);
    return vec4<f32>(clamp(mapped, vec3<f32>(0.0), vec3<f32>(1.0)), 1.0);
}
