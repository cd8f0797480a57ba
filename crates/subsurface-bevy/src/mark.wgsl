// Builds SssPass's inputs from Bevy's frame: linear view depth from the camera's depth buffer
// (reverse-Z) and the SSS texture (strength, scene units per profile mm, profile row) from the
// skin marker the skin material leaves in the main texture's alpha (skin.wesl).
// Preceded by subsurface_render's fullscreen.wgsl (vs_fullscreen, FullscreenOut).

struct Mark {
    // Bevy's view_from_clip (the inverse projection).
    view_from_clip: mat4x4<f32>,
    // The camera's world_from_view: normals go to world space for the transmitted light.
    world_from_view: mat4x4<f32>,
    size: vec2<f32>,
    rows: u32,
    _pad: u32,
    // Scene units per profile millimetre of each profile row, four rows per vec4.
    scale: array<vec4<f32>, 64>,
    // Each row's linear albedo (rgb), the transmitted light's: Bevy's forward pass keeps none
    // per pixel.
    albedo: array<vec4<f32>, 256>,
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

// The view-space point at `texel`; w = 0 where no surface was drawn.
fn view_point(texel: vec2<i32>) -> vec4<f32> {
    let d = textureLoad(depth_tex, texel, 0);
    if (d <= 0.0) {
        return vec4<f32>(0.0);
    }
    let centre = vec2<f32>(texel) + vec2<f32>(0.5);
    let ndc = vec2<f32>(2.0 * centre.x / u.size.x - 1.0, 1.0 - 2.0 * centre.y / u.size.y);
    let v = u.view_from_clip * vec4<f32>(ndc, d, 1.0);
    return vec4<f32>(v.xyz / v.w, 1.0);
}

@fragment
fn fs_mark(in: FullscreenOut) -> MarkOut {
    return mark(in);
}

// fs_mark's body (WGSL entry points cannot call each other).
fn mark(in: FullscreenOut) -> MarkOut {
    let texel = vec2<i32>(in.clip.xy);
    let p = view_point(texel);
    var out: MarkOut;
    out.depth = select(FAR, -p.z, p.w > 0.0);
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

// Of the two neighbours along one axis, the step to the one nearer in depth: across a
// silhouette the other lies on the surface behind, and would tilt the normal toward it.
fn surface_step(p: vec4<f32>, before: vec4<f32>, after: vec4<f32>) -> vec3<f32> {
    let back = select(1e30, abs(before.z - p.z), before.w > 0.0);
    let ahead = select(1e30, abs(after.z - p.z), after.w > 0.0);
    if (back >= 1e30 && ahead >= 1e30) {
        return vec3<f32>(0.0);
    }
    if (ahead <= back) {
        return after.xyz - p.xyz;
    }
    return p.xyz - before.xyz;
}

struct GBufferOut {
    @location(0) depth: f32,
    @location(1) sss: vec4<f32>,
    // World-space normal, turned toward the camera (the transmitted light's n_vertex).
    @location(2) normal: vec4<f32>,
    @location(3) albedo: vec4<f32>,
};

// fs_mark and, for the transmitted light pass, a G-buffer: the normal is rebuilt from the depth
// buffer (Bevy's forward pass writes none without a normal prepass, a camera-wide change the
// plugin does not impose), so it is the geometry's, flat per triangle where the pass would
// take the interpolated vertex normal (both ignore normal maps: thickness follows the
// geometry); the albedo is the row's.
@fragment
fn fs_mark_gbuffer(in: FullscreenOut) -> GBufferOut {
    let m = mark(in);
    var out: GBufferOut;
    out.depth = m.depth;
    out.sss = m.sss;
    out.normal = vec4<f32>(0.0, 0.0, 1.0, 0.0);
    out.albedo = vec4<f32>(0.0);
    if (m.sss.x <= 0.0) {
        return out;
    }
    let texel = vec2<i32>(in.clip.xy);
    let last = vec2<i32>(u.size) - vec2<i32>(1);
    let p = view_point(texel);
    let left = view_point(clamp(texel - vec2<i32>(1, 0), vec2<i32>(0), last));
    let right = view_point(clamp(texel + vec2<i32>(1, 0), vec2<i32>(0), last));
    let up = view_point(clamp(texel - vec2<i32>(0, 1), vec2<i32>(0), last));
    let down = view_point(clamp(texel + vec2<i32>(0, 1), vec2<i32>(0), last));
    // x grows right and y grows down the image: right x down points out of the screen on a
    // surface facing the camera (view space looks down -z).
    var n = cross(surface_step(p, left, right), surface_step(p, up, down));
    if (dot(n, n) < 1e-30) {
        n = vec3<f32>(0.0, 0.0, 1.0);
    }
    n = normalize(n);
    // Toward the camera, which sits at the view-space origin.
    if (dot(n, p.xyz) > 0.0) {
        n = -n;
    }
    out.normal = vec4<f32>(normalize((u.world_from_view * vec4<f32>(n, 0.0)).xyz), 0.0);
    out.albedo = vec4<f32>(u.albedo[u32(m.sss.z)].rgb, 1.0);
    return out;
}
