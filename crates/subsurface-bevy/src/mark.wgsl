// Builds SssPass's inputs from Bevy's frame: linear view depth from the camera's depth buffer
// (reverse-Z) and the SSS texture (strength, scene units per profile mm, profile row) from the
// skin marker the skin material leaves in the main texture's alpha (skin.wesl).
// Preceded by subsurface_render's fullscreen.wgsl (vs_fullscreen, FullscreenOut).

struct Mark {
    // Bevy's view_from_clip (the inverse projection).
    view_from_clip: mat4x4<f32>,
    size: vec2<f32>,
    rows: u32,
    _pad: u32,
    // Scene units per profile millimetre of each profile row, four rows per vec4.
    scale: array<vec4<f32>, 64>,
};

@group(0) @binding(0) var<uniform> u: Mark;
@group(0) @binding(1) var color_tex: texture_2d<f32>;
@group(0) @binding(2) var depth_tex: texture_depth_2d;

// Depth of pixels that hold no surface (Bevy's infinite far plane is depth 0): far enough
// that the blur's depth test gives their taps no weight.
const FAR: f32 = 1e9;

struct MarkOut {
    @location(0) depth: f32,
    @location(1) sss: vec4<f32>,
};

@fragment
fn fs_mark(in: FullscreenOut) -> MarkOut {
    let texel = vec2<i32>(in.clip.xy);
    let d = textureLoad(depth_tex, texel, 0);
    var out: MarkOut;
    out.depth = FAR;
    if (d > 0.0) {
        let ndc = vec2<f32>(2.0 * in.clip.x / u.size.x - 1.0, 1.0 - 2.0 * in.clip.y / u.size.y);
        let v = u.view_from_clip * vec4<f32>(ndc, d, 1.0);
        out.depth = -v.z / v.w;
    }
    out.sss = vec4<f32>(0.0);
    let a = textureLoad(color_tex, texel, 0).a;
    if (a < 0.0) {
        let row = u32(round(-a - 1.0));
        if (row < u.rows) {
            out.sss = vec4<f32>(1.0, u.scale[row / 4u][row % 4u], f32(row), 0.0);
        }
    }
    return out;
}
