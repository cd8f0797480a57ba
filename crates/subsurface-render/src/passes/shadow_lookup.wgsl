// Shadow lookups of the lighting pass (lighting/mod.rs puts this file after lighting.wgsl):
// which shadow-map layer and texel a point projects to, percentage-closer filtering through
// comparison gathers, and the shadow of the diffusion source that oblique light feeds.


// Point lights keep six layers in the order +X, -X, +Y, -Y, +Z, -Z (see shadow.rs).
fn cube_face(d: vec3<f32>) -> u32 {
    let a = abs(d);
    if (a.x >= a.y && a.x >= a.z) {
        return select(1u, 0u, d.x > 0.0);
    }
    if (a.y >= a.z) {
        return select(3u, 2u, d.y > 0.0);
    }
    return select(5u, 4u, d.z > 0.0);
}

// The light camera of one shadow layer. Constant indices only: indexing the copied light's
// matrix array at run time makes compilers keep all six matrices in per-pixel scratch memory
// (on lavapipe that alone cost a third of the lighting pass).
fn face_matrix(light: Light, face: u32) -> mat4x4<f32> {
    switch face {
        case 1u: { return light.view_proj[1]; }
        case 2u: { return light.view_proj[2]; }
        case 3u: { return light.view_proj[3]; }
        case 4u: { return light.view_proj[4]; }
        case 5u: { return light.view_proj[5]; }
        default: { return light.view_proj[0]; }
    }
}

struct ShadowCoord {
    uv: vec2<f32>,   // in the light's own map, 0..1
    layer: i32,
    face: u32,       // the point light's cube face (0 for other lights)
    inside: bool,
};

// Where a light camera's clip position (w > 0) falls on its map, 0..1: texture v runs down
// where clip y runs up. Every lookup of the lights' maps goes through it.
fn clip_to_map(clip: vec4<f32>) -> vec2<f32> {
    return clip.xy / clip.w * vec2<f32>(0.5, -0.5) + vec2<f32>(0.5);
}

// The depth a biased clip position is compared with; past the far plane nothing was drawn.
fn compared_depth(biased: vec4<f32>) -> f32 {
    return min(biased.z / max(biased.w, 1e-20), 1.0);
}

fn shadow_coord(light: Light, p: vec3<f32>) -> ShadowCoord {
    var sc: ShadowCoord;
    sc.inside = false;
    sc.layer = -1;
    sc.face = 0u;
    sc.uv = vec2<f32>(0.0);
    if (light.first_layer < 0.0) {
        return sc;
    }
    var face = 0u;
    if (light.kind == KIND_POINT) {
        face = cube_face(p - light.position);
    }
    let clip = face_matrix(light, face) * vec4<f32>(p, 1.0);
    if (clip.w <= 0.0) {
        return sc;
    }
    sc.uv = clip_to_map(clip);
    sc.layer = i32(light.first_layer) + i32(face);
    sc.face = face;
    sc.inside = all(sc.uv >= vec2<f32>(0.0)) && all(sc.uv <= vec2<f32>(1.0));
    return sc;
}

// The comparison results of the 2x2 texels around the texel corner `uv`.
fn shadow_gather(uv: vec2<f32>, layer: i32, reference: f32) -> vec4<f32> {
    return textureGatherCompare(shadow_depth, shadow_compare, uv, layer, reference);
}

fn gather_weights(wx: vec2<f32>, wy: vec2<f32>) -> vec4<f32> {
    return vec4<f32>(wx.x * wy.y, wx.y * wy.y, wx.y * wy.x, wx.x * wy.x);
}

// Where `p` falls on `light`'s map `sc`, in texels (centres at .5), and the depth it is
// compared with: its projected depth after moving it shadow_bias toward the light, which
// along its ray is the same test as distance - bias <= occluder distance. Beyond the far
// plane nothing was drawn (cleared to 1): lit.
struct ShadowTest {
    texel: vec2<f32>,
    reference: f32,
};

fn shadow_test(light: Light, sc: ShadowCoord, p: vec3<f32>) -> ShadowTest {
    let to_light = light_direction(light.kind, light.position, light.direction, p);
    let biased = face_matrix(light, sc.face) * vec4<f32>(p + to_light * light.shadow_bias, 1.0);
    let size = light.shadow_uv_scale / light.atlas_texel; // this light's map size in texels
    return ShadowTest(sc.uv * size - vec2<f32>(0.5), compared_depth(biased));
}

// Percentage-closer filtering over a 3x3 texel area with bilinear weights: a tent of 4x4
// texels, weights (1 - f, 1, 1, f) per axis. The comparison sampler's gather tests a 2x2 block
// of texels in one fetch, so four fetches do what sixteen loads and compares did, with the
// same weights.
fn shadow_factor(light: Light, p: vec3<f32>) -> f32 {
    let sc = shadow_coord(light, p);
    if (!sc.inside) {
        return 1.0;
    }
    let test = shadow_test(light, sc, p);
    let t = test.texel;
    let reference = test.reference;
    let base = floor(t) - vec2<f32>(1.0);
    let f = t - floor(t);
    // Weights of the four texels a gather returns: x = (left, bottom), y = (right, bottom),
    // z = (right, top), w = (left, top).
    let wx0 = vec2<f32>(1.0 - f.x, 1.0);
    let wx1 = vec2<f32>(1.0, f.x);
    let wy0 = vec2<f32>(1.0 - f.y, 1.0);
    let wy1 = vec2<f32>(1.0, f.y);
    // Written out rather than looped over arrays: a run-time index into a local array costs
    // per-pixel scratch memory on some compilers.
    let corner = (base + vec2<f32>(1.0)) * light.atlas_texel;
    let step = 2.0 * light.atlas_texel;
    var lit = dot(shadow_gather(corner, sc.layer, reference), gather_weights(wx0, wy0));
    lit += dot(shadow_gather(corner + vec2<f32>(step, 0.0), sc.layer, reference), gather_weights(wx1, wy0));
    lit += dot(shadow_gather(corner + vec2<f32>(0.0, step), sc.layer, reference), gather_weights(wx0, wy1));
    lit += dot(shadow_gather(corner + vec2<f32>(step, step), sc.layer, reference), gather_weights(wx1, wy1));
    return lit / 9.0;
}

// The optional terms this pipeline evaluates, a bit each (overrides.rs, `Terms`): 1
// `diffusion`'s unscattered lobe, 2 its single scattering, 4 the diffusion source's shadow
// along the refracted ray (source_shadow), 8 thin parts' reflectance (lighting.wgsl,
// thin_part_reflectance), 16 the side walls' share of the chord's and the lateral taps' light
// (side_walls.wgsl, side_wall_share). Pipelines without a term compile without its code.
override DIFFUSION_TERMS: u32 = 31u;

fn has_term(bit: u32) -> bool {
    return (DIFFUSION_TERMS & bit) != 0u;
}

// The light's visibility for the diffusion seen at p, per channel. Light entering at an angle
// refracts, and the diffusion source it feeds lies 1 / sigma_t' along the refracted ray
// (Jensen et al. 2001's real source), so the source under p was lit where the refracted ray
// entered: tan(theta_t) / sigma_t' back toward the light, per channel. Red's entry point is
// looked up first; where it sees the same shadow as p itself (everywhere but near shadow
// edges), green and blue, whose sources lie between, see it too.
fn source_shadow(light: Light, p: vec3<f32>, n_vertex: vec3<f32>, l: vec3<f32>, shadow: f32) -> vec3<f32> {
    let cos_i = dot(n_vertex, l);
    let scatters = lights.sss_runs != 0u && object.sss_strength > 0.0;
    if (!has_term(TERM_SOURCE_SHIFT) || !scatters || cos_i <= 0.0 || any(object.extinction <= vec3<f32>(0.0)) || light.first_layer < 0.0) {
        return vec3<f32>(shadow);
    }
    let sin_t = sqrt(max(1.0 - cos_i * cos_i, 0.0)) / object.eta;
    let tan_t = sin_t / sqrt(max(1.0 - sin_t * sin_t, 1e-6));
    let along = l - n_vertex * cos_i; // toward the light, in the tangent plane
    let len = length(along);
    if (len < 1e-6 || tan_t < 1e-4) {
        return vec3<f32>(shadow);
    }
    let step = along / len * (tan_t * object.world_per_mm);
    // The three entry points lie on one line through p, and a light's projection is linear
    // before its divide: p's clip position, its biased one and the step's clip offset serve
    // all three, where a lookup of its own per point would fetch the light's matrix and
    // project twice (on lavapipe that was half the shift's cost, 17 ms of the default
    // scene's 1280x720 lighting pass, docs/lab/performance.md, session 39). The shift is
    // millimetres: the bias keeps p's direction to the light, and a point light keeps p's
    // cube face (an entry point beyond that face's edge takes p's own shadow, the unshifted
    // answer, rather than a seam of light).
    var face = 0u;
    if (light.kind == KIND_POINT) {
        face = cube_face(p - light.position);
    }
    let m = face_matrix(light, face);
    let on_p = ShiftedLookup(
        m * vec4<f32>(p, 1.0),
        m * vec4<f32>(p + l * light.shadow_bias, 1.0),
        m * vec4<f32>(step, 0.0),
        i32(light.first_layer) + i32(face),
    );
    let red = shifted_shadow(light, on_p, 1.0 / object.extinction.x, shadow);
    if (red == shadow) {
        return vec3<f32>(shadow);
    }
    let green = shifted_shadow(light, on_p, 1.0 / object.extinction.y, shadow);
    let blue = shifted_shadow(light, on_p, 1.0 / object.extinction.z, shadow);
    return vec3<f32>(red, green, blue);
}

// p on a light's map for `source_shadow`: its clip position, that of p moved the shadow bias
// toward the light, the clip offset of one refraction step, and the layer.
struct ShiftedLookup {
    clip: vec4<f32>,
    biased: vec4<f32>,
    step: vec4<f32>,
    layer: i32,
};

// Percentage-closer filtering over the 2x2 texels around p moved `steps` refraction steps,
// with bilinear weights: one gather. What the shifted lookups feed is blurred by the profile,
// which hides the narrower penumbra, and `shadow_factor`'s tent of four gathers per lookup was
// most of the shift's cost. `own`: p's shadow, for a point off the map (beyond the cube face
// p lies on, or beyond a spot light's frustum, where its cone gives no light anyway).
fn shifted_shadow(light: Light, at: ShiftedLookup, steps: f32, own: f32) -> f32 {
    let clip = at.clip + at.step * steps;
    let uv = clip_to_map(clip);
    if (clip.w <= 0.0 || any(uv < vec2<f32>(0.0)) || any(uv > vec2<f32>(1.0))) {
        return own;
    }
    let reference = compared_depth(at.biased + at.step * steps);
    let texel = uv * (light.shadow_uv_scale / light.atlas_texel) - vec2<f32>(0.5);
    let f = texel - floor(texel);
    let corner = (floor(texel) + vec2<f32>(1.0)) * light.atlas_texel;
    let weights = gather_weights(vec2<f32>(1.0 - f.x, f.x), vec2<f32>(1.0 - f.y, f.y));
    return dot(shadow_gather(corner, at.layer, reference), weights);
}
