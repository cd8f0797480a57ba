// Reading the transmitted map (transmitted_map/) at a pixel of the lighting pass: which of the map's
// texels hold the pixel's surface, and the light they hold. The lighting, outline and bounce
// code (lighting.wgsl, outline.wgsl, bounce.wgsl) share these.

// How far (profile mm, along the view) a transmitted-map texel's surface may lie from the pixel's
// surface extended as a plane, for the pixel to take its light: a quarter of the kernel's own
// decay length (0.9 mm for skin1), so the four texels around a pixel on one smooth surface
// agree, and a sheet in front of another (tests/transmittance.rs: without the test the front
// one's pixels beside the edge took the back one's light), a finger in front of a palm, or a
// curved rim where the plane leaves the surface within a texel takes the texel nearest its
// depth instead (transmitted_from_map).
const LATERAL_DEPTH_TOLERANCE: f32 = 0.25;
// Below this share of the bilinear weight on the pixel's own surface, the pixel takes the
// texel of the 4 x 4 around it nearest its depth rather than blend texels of other surfaces.
const LATERAL_MIN_WEIGHT: f32 = 0.3;
// How far in depth, in depth tolerances, the nearest texel of a silhouette pixel may lie.
const LATERAL_NEAREST_TOLERANCES: f32 = 16.0;
// Where the four texels' light differs by more than EXPONENTIAL_FROM times, it changes across
// them as diffusion decays, exponentially, and the bilinear blend lies above the curve between
// them (halfway between texels 50 times apart it gives 0.51 of the brighter one, the curve
// 0.14): a backlit wedge's light-side outline, 3-10 pixels inside its bright rim, read +141 %
// against the path tracer, evaluated per pixel +15 %, blended in the logarithm +22 %. The
// blend moves to the logarithm's from EXPONENTIAL_FROM to EXPONENTIAL_FULL times; below, the
// linear blend stays, since on a smooth field the logarithm's lies lower by half the square of
// the relative change (1-2 points off the canonical fingers, already at -24 % for `medium`;
// docs/lab/suite.md, session 37).
const EXPONENTIAL_FROM: f32 = 2.0;
const EXPONENTIAL_FULL: f32 = 8.0;
// A texel without light stands for this share of the brightest in the logarithm's blend.
const EXPONENTIAL_FLOOR: f32 = 1e-3;

// Which lights reach a point directly on a surface facing them (bit i for light i): there a
// light's chord gives nothing (`transmittance`: the point is its own entry) and only the lit
// side's light remains (lit_side.wgsl), a step the light's terminator draws across the map's
// smooth field. The map pass stores each texel's code
// in layer 1's `a` (transmitted_map.wgsl), and a pixel takes no texel that a light reaches
// where the pixel is in that light's shadow: the unlit pixels within a texel of a terminator
// blended in the lit texels' zero (a backlit chicken1 ball's light-side outline read -55 %
// against the path tracer, evaluated per pixel -40 %, now -37 %). The other way round a lit
// pixel keeps its unlit texels' light: per pixel it would get only the lit side's, but near a
// terminator the path tracer shows light on both sides of it (docs/lab/suite.md, session 39),
// and without it the canonical hand's fingers lost a point (-24.4 to -25.4 % at `medium`,
// session 37).
fn lit_code(code: u32, i: u32, facing: f32, shadow: f32) -> u32 {
    return select(code, code | (1u << i), facing > 0.0 && shadow >= 0.5);
}

// The pixel the lighting pass shades, for reading `diffusion` and the bounce from the map: its
// centre in pixels, its view depth and that depth's change per pixel across the surface.
struct ScreenSample {
    xy: vec2<f32>,
    depth: f32,
    gradient: vec2<f32>,
    // `lit_code` over the lights at the pixel's surface.
    lit: u32,
};

// The pixel's surface extended as a plane (its depth derivatives), at the centre of the map
// texel `texel` of a map `scale` times the frame's size: the depth a texel on the pixel's own
// surface holds.
fn plane_depth(screen: ScreenSample, texel: vec2<i32>, scale: vec2<f32>) -> f32 {
    let centre = (vec2<f32>(texel) + 0.5) / scale;
    return screen.depth + dot(screen.gradient, centre - screen.xy);
}

// What the lighting pass's pixel reads from the transmitted map: every light's transmitted light,
// and whether it came from texels of the pixel's own surface.
struct MapRead {
    t: Transmitted,
    on_surface: bool,
};

// How far in depth (scene units) a map texel's surface may lie from the pixel's own.
fn map_depth_tolerance() -> f32 {
    let units_per_mm = object.world_per_mm * object.translucency;
    return LATERAL_DEPTH_TOLERANCE / max(object.lateral_decay, 1e-3) * units_per_mm;
}

// Map texels per pixel, along x and y.
fn map_scale() -> vec2<f32> {
    return vec2<f32>(textureDimensions(transmitted_map)) / vec2<f32>(camera.viewport_x, camera.viewport_y);
}

// The four map texels around a pixel, from `base` (k = 0..3: base + (k % 2, k / 2)): the
// bilinear weight of each that matches the pixel (`texel_matches`; 0 for the others),
// their sum, and their diffuse and unscattered light so weighted.
struct MapTexels {
    base: vec2<i32>,
    weight: f32,
    diffuse: vec3<f32>,
    ballistic: vec3<f32>,
};

// Whether a map texel's light can stand for the pixel's: its surface lies within the tolerance
// of the pixel's, extended as a plane to the texel's centre (a slanted surface keeps its texels,
// a depth edge loses them), and no light reaches it directly that the pixel is shadowed from.
// `lit`: the texel's `lit_code` (layer 1's `a`).
fn texel_matches(screen: ScreenSample, texel: vec2<i32>, scale: vec2<f32>, depth: f32, lit: f32, tolerance: f32) -> bool {
    if (depth <= 0.0 || abs(depth - plane_depth(screen, texel, scale)) > tolerance) {
        return false;
    }
    return reached_as_pixel(screen, lit);
}

// Whether no light reaches a texel of code `lit` (layer 1's `a`) directly that the pixel is
// shadowed from (`lit_code`).
fn reached_as_pixel(screen: ScreenSample, lit: f32) -> bool {
    return (u32(lit) & ~screen.lit) == 0u;
}

// The four texels around `screen`'s pixel that count with their bilinear weights where they
// match the pixel (`texel_matches`), their diffuse light blended linearly or, across a steep
// change, in the logarithm.
fn map_texels(screen: ScreenSample) -> MapTexels {
    let size = vec2<i32>(textureDimensions(transmitted_map));
    let scale = map_scale();
    let pos = screen.xy * scale - 0.5;
    var out = MapTexels(vec2<i32>(floor(pos)), 0.0, vec3<f32>(0.0), vec3<f32>(0.0));
    let f = pos - floor(pos);
    let tolerance = map_depth_tolerance();
    var values: array<vec3<f32>, 4>;
    var weights = vec4<f32>(0.0);
    var top = vec3<f32>(0.0);
    var low = vec3<f32>(3.4e38);
    for (var k = 0; k < 4; k++) {
        let texel = out.base + vec2<i32>(k % 2, k / 2);
        if (any(texel < vec2<i32>(0)) || any(texel >= size)) {
            continue;
        }
        let d = textureLoad(transmitted_map, texel, 0, 0);
        let b = textureLoad(transmitted_map, texel, 1, 0);
        if (!texel_matches(screen, texel, scale, d.w, b.a, tolerance)) {
            continue;
        }
        let w = select(1.0 - f.x, f.x, k % 2 == 1) * select(1.0 - f.y, f.y, k / 2 == 1);
        out.weight += w;
        out.diffuse += d.rgb * w;
        out.ballistic += b.rgb * w;
        weights[k] = w;
        values[k] = d.rgb;
        top = max(top, d.rgb);
        low = min(low, d.rgb);
    }
    if (out.weight > 0.0 && any(top > low * EXPONENTIAL_FROM)) {
        let floor_value = top * EXPONENTIAL_FLOOR + vec3<f32>(1e-30);
        var log_sum = vec3<f32>(0.0);
        for (var k = 0; k < 4; k++) {
            log_sum += weights[k] * log(max(values[k], floor_value));
        }
        let spread = log(max(top, floor_value) / max(low, floor_value));
        let share = smoothstep(vec3<f32>(log(EXPONENTIAL_FROM)), vec3<f32>(log(EXPONENTIAL_FULL)), spread);
        out.diffuse = mix(out.diffuse, exp(log_sum / out.weight) * out.weight, share);
    }
    return out;
}

// `diffusion`'s transmitted light at `screen`'s pixel, every light's together, interpolated
// from the map the map pass filled at 1/N resolution (fs_transmitted in lighting.wgsl).
// The four map texels around the pixel count with their bilinear weights where their surface
// lies within the tolerance of the pixel's, extended as a plane to the texel's centre (so a
// slanted surface keeps its texels and a depth edge loses them). Where they carry too little
// of the weight (a silhouette, a depth edge) the texel of the 4 x 4 around the pixel nearest
// its depth serves (its diffuse part), marked as not on the pixel's surface (shade then runs
// the chords there);
// where none of the 4 x 4 lies near the pixel's depth (a back face of an open mesh, which the
// map pass culls) it is zero, and the chords alone serve.
// The renderer sizes the map for the nearest skin (`lateral_texel_mm` there); skin whose
// texels come out more than `MAX_TEXEL_FACTOR` times coarser is drawn with a pipeline that
// evaluates everything per pixel (LATERAL_SOURCE 2).
fn transmitted_from_map(screen: ScreenSample) -> MapRead {
    let read = transmitted_on_surface(screen);
    if (read.on_surface) {
        return read;
    }
    return MapRead(Transmitted(nearest_texel_light(screen), vec3<f32>(0.0)), false);
}

// The first half of `transmitted_from_map`: the four texels' light where they hold the pixel's
// surface; zero and not on the surface where they do not. The lighting pass built with
// OUTLINE_PASS stops here and leaves the rest to the outline pass, whose pixels are the only
// ones that need it: a CPU rasteriser runs `nearest_texel_light`'s sixteen texels at every
// pixel it is compiled into (about 18 ms of the default scene's 1280x720 lighting pass on
// lavapipe, docs/lab/performance.md, session 39).
fn transmitted_on_surface(screen: ScreenSample) -> MapRead {
    let zero = Transmitted(vec3<f32>(0.0), vec3<f32>(0.0));
    if (object.translucency <= 0.0) {
        return MapRead(zero, true);
    }
    let around = map_texels(screen);
    if (around.weight >= LATERAL_MIN_WEIGHT) {
        return MapRead(Transmitted(around.diffuse / around.weight, around.ballistic / around.weight), true);
    }
    return MapRead(zero, false);
}

// The diffuse light of the texel of the 4 x 4 around the pixel nearest its depth, among those
// no light reaches that the pixel is shadowed from; zero where none lies within
// LATERAL_NEAREST_TOLERANCES tolerances. Only the diffuse part: the pixel runs its own
// unscattered and singly scattered light.
fn nearest_texel_light(screen: ScreenSample) -> vec3<f32> {
    let base = vec2<i32>(floor(screen.xy * map_scale() - 0.5));
    let size = vec2<i32>(textureDimensions(transmitted_map));
    let tolerance = map_depth_tolerance();
    var nearest = vec4<f32>(0.0, 0.0, 0.0, LATERAL_NEAREST_TOLERANCES * tolerance);
    for (var j = -1; j < 3; j++) {
        for (var i = -1; i < 3; i++) {
            let texel = base + vec2<i32>(i, j);
            if (any(texel < vec2<i32>(0)) || any(texel >= size)) {
                continue;
            }
            let d = textureLoad(transmitted_map, texel, 0, 0);
            let gap = abs(d.w - screen.depth);
            if (d.w > 0.0 && gap < nearest.w && reached_as_pixel(screen, textureLoad(transmitted_map, texel, 1, 0).a)) {
                nearest = vec4<f32>(d.rgb, gap);
            }
        }
    }
    return nearest.rgb;
}
