// Lighting pass: writes the inputs of screen-space subsurface scattering.
//   0: diffuse radiance (irradiance x albedo), the part that is blurred
//   1: specular radiance, added after the blur and never blurred
//   2: linear view depth in scene units (the blur width is divided by it)
//   3: SSS strength (0 = not skin), scene units per profile millimetre, profile row, 1 where
//      the outline pass adds the lights' chords


struct LitVarying {
    // Invariant: the depth pre-pass and the lighting pass must compute bit-identical depths
    // for the equal test to keep each pixel's nearest fragment.
    @builtin(position) @invariant clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) uv: vec2<f32>,
    @location(3) tangent: vec4<f32>,
};

@vertex
fn vs_main(v: VertexIn) -> LitVarying {
    var out: LitVarying;
    let world = world_position(v);
    out.world = world.xyz;
    out.clip = camera.view_proj * world;
    out.normal = world_normal(v);
    out.tangent = world_tangent(v);
    out.uv = v.uv;
    return out;
}

// Largest finite half float: what the Rgba16Float radiance targets can hold.
const HALF_MAX: f32 = 65504.0;

struct GBuffer {
    @location(0) diffuse: vec4<f32>,
    @location(1) specular: vec4<f32>,
    @location(2) depth: f32,
    @location(3) sss: vec4<f32>,   // strength, scene units per profile mm, profile index
};

// Beckmann distribution times pi (our radiance is pi times the path tracer's for one
// emitter; subsurface_profile::specular::beckmann).
fn beckmann(ndoth: f32, m: f32) -> f32 {
    let c2 = max(ndoth * ndoth, 1e-4);
    let tan2 = (1.0 - c2) / c2;
    let m2 = m * m;
    return exp(-tan2 / m2) / (m2 * c2 * c2);
}

// Schlick's Fresnel with F0 of the medium's boundary, ((eta - 1) / (eta + 1))^2: 0.017 for
// the measured media's 1.3 (d'Eon's 0.028 is skin at 1.4), so the specular is the reflection of
// the same boundary the path tracer renders.
fn fresnel(h: vec3<f32>, v: vec3<f32>) -> f32 {
    return boundary_fresnel(dot(v, h));
}

// The same boundary's Schlick reflectance at an angle of cosine `cos_theta`; transmittance.wgsl
// takes 1 minus it for light crossing the boundary.
fn boundary_fresnel(cos_theta: f32) -> f32 {
    // Clamped at 1 too: pow of a negative base is NaN, and the cosine of a unit vector with
    // itself rounds above 1 (the UV-space irradiance pass views every texel along its normal).
    let e = pow(1.0 - clamp(cos_theta, 0.0, 1.0), 5.0);
    let r = (object.eta - 1.0) / (object.eta + 1.0);
    return e + r * r * (1.0 - e);
}

// Smith's masking of a Beckmann surface seen at cosine `cos_theta` to its normal, by Walter et
// al. 2007's rational fit (0.35 % error), the form Mitsuba's rough dielectric uses.
fn beckmann_smith_g1(cos_theta: f32, m: f32) -> f32 {
    let c = clamp(cos_theta, 1e-4, 1.0);
    let a = c / (m * sqrt(max(1.0 - c * c, 1e-8)));
    if (a >= 1.6) {
        return 1.0;
    }
    return (3.535 * a + 2.181 * a * a) / (1.0 + 2.276 * a + 2.577 * a * a);
}

// The boundary's specular reflection times N.L: rho_s * D * F * G / (4 N.V), Cook-Torrance
// with Beckmann facets and Smith's masking of both directions, the reflection of the rough
// dielectric the path tracer renders (rho_s = 1; CPU reference and tests in
// subsurface_profile::specular). Kelemen/Szirmay-Kalos (d'Eon and Luebke 2007) stands in
// |L + V|^2 / 4 for G's N.L N.V: the same at the highlight, but where a back light grazes a
// rim toward the camera |L + V| goes to 0, and it gave 44x the path tracer's reflection on the
// finger-backlit scene's outline (docs/lab/fidelity.md), where G bounds it.
fn boundary_specular(n: vec3<f32>, l: vec3<f32>, v: vec3<f32>, m: f32, rho_s: f32) -> f32 {
    let ndotl = dot(n, l);
    let ndotv = dot(n, v);
    let h_unnorm = l + v;
    if (!(ndotl > 0.0) || !(ndotv > 0.0) || dot(h_unnorm, h_unnorm) < 1e-12) {
        return 0.0;
    }
    let h = normalize(h_unnorm);
    let d = beckmann(max(dot(n, h), 0.0), m);
    let g = beckmann_smith_g1(ndotv, m) * beckmann_smith_g1(ndotl, m);
    return max(rho_s * d * fresnel(h, v) * g / (4.0 * ndotv), 0.0);
}

// How texture-space diffusion and translucent shadow maps enter this object's shading
// (group 2, one bind group per object; see texture_space.rs).
struct TextureSpace {
    // x = diffuse comes from the blurred UV-space map (0/1), y = translucent shadow maps and
    // the widest blurred map are available (0/1), z = share of the albedo applied before the
    // blur (exponent: 0 = all after, 0.5 = d'Eon's pre- and post-scatter, 1 = all before)
    params: vec4<f32>,
};

@group(2) @binding(0) var<uniform> texture_space: TextureSpace;
// Sum of the blurred Gaussians (the scattered irradiance), RGB, in UV space, padded.
@group(2) @binding(1) var ts_result: texture_2d<f32>;
// The widest blurred Gaussian alone: the back-side irradiance that translucent shadow maps read.
@group(2) @binding(2) var ts_widest: texture_2d<f32>;
@group(2) @binding(3) var ts_sampler: sampler;

// `diffusion`'s transmitted light at reduced resolution (transmitted_map/targets.rs, `TransmittedMapTargets`):
// layer 0 its diffuse part, layer 1 its unscattered and singly scattered part, every light's
// radiance summed, a = the texel's view depth (0: nothing there); the bounce's layer after
// them. Group 3 of the lighting pass; the map and bounce passes have no group 3.
@group(3) @binding(0) var transmitted_map: texture_2d_array<f32>;
// The nearest back face per pixel (lighting/targets.rs, BACK_FACES_FORMAT): r = its linear
// view depth (0: none), g = its outward normal (encode_normal). Written by `fs_back_faces`
// where the pipeline's terms hold TERM_THIN_PARTS.
@group(3) @binding(1) var back_faces: texture_2d<f32>;

// The back faces' pass (front faces culled, the nearest kept).
@fragment
fn fs_back_faces(in: LitVarying) -> @location(0) vec2<f32> {
    return vec2<f32>(dot(in.world - camera.position, camera.forward), encode_normal(normalize(in.normal)));
}

// A part thinner than a few diffusion lengths lets out through its far face some of the light
// its lit face takes in, so it reflects less than the half-space the albedo is measured on
// (2 mm of skin1 keep 0.75 of the red; a 1 mm slab of the suite's jade-like medium lit from
// the side read +64 % against the path tracer without it). The thickness along the normal is
// the view ray's chord to the nearest back face times |n.v|, exact for a slab seen at any
// angle; divided by how squarely the back face looks away from the front, so that a thick
// sphere's or finger's rim, whose back face is the same surface curving away (a short chord
// between faces that look the same way), keeps its reflectance instead of reading as a sheet:
// through a sphere the estimate never falls below the diameter.
fn thin_part_reflectance(pixel: vec2<f32>, depth: f32, world: vec3<f32>, n: vec3<f32>, v: vec3<f32>) -> vec3<f32> {
    let texel = textureLoad(back_faces, vec2<i32>(pixel), 0).rg;
    let across = -dot(n, decode_normal(texel.y));
    if (!(texel.x > depth) || !(depth > 0.0) || across <= 0.0 || object.world_per_mm <= 0.0) {
        return vec3<f32>(1.0);
    }
    let chord = length(camera.position - world) * (texel.x / depth - 1.0);
    let s_mm = chord * abs(dot(n, v)) / (across * object.world_per_mm);
    if (!(s_mm < DIFFUSION_RANGE_MM)) {
        return vec3<f32>(1.0);
    }
    return lut_row(s_mm, DIFFUSION_RANGE_MM, THIN_ROW);
}

fn oriented_normal(in: LitVarying, front: bool) -> vec3<f32> {
    let n = normalize(in.normal);
    return select(-n, n, front);
}

// The shading normal: the interpolated (already oriented) normal bent by the tangent-space
// normal map.
fn shading_normal(in: LitVarying, n_vertex: vec3<f32>) -> vec3<f32> {
    var n = n_vertex;
    if (object.has_normal_map != 0u) {
        let t = normalize(in.tangent.xyz - n_vertex * dot(n_vertex, in.tangent.xyz));
        let b = cross(n_vertex, t) * select(-1.0, 1.0, in.tangent.w >= 0.0);
        let tn = textureSample(normal_map, material_sampler, in.uv).xyz * 2.0 - vec3<f32>(1.0);
        n = normalize(t * tn.x + b * tn.y + n_vertex * tn.z);
    }
    return n;
}

struct Shading {
    irradiance: vec3<f32>,  // sum of radiance x shadow x N.L
    transmitted: vec3<f32>, // T(s) x back irradiance of the 2010-style methods (transmittance.wgsl)
    tsm: vec3<f32>,         // translucent shadow maps: T(s) x blurred back-side irradiance
    specular: vec3<f32>,
    // The pixel's chords are left to the outline pass (OUTLINE_PASS, where the map misses it).
    outline: bool,
};

// The radiance `light` sends toward `world` (direction `l` to the light): its colour, the
// inverse square of its distance, its spot cone.
fn light_radiance(light: Light, world: vec3<f32>, l: vec3<f32>) -> vec3<f32> {
    var attenuation = 1.0;
    if (light.kind != KIND_DIRECTIONAL) {
        let to_light = light.position - world;
        attenuation = 1.0 / max(dot(to_light, to_light), 1e-8);
    }
    var spot = 1.0;
    if (light.kind == KIND_SPOT) {
        spot = smoothstep(light.cos_outer, light.cos_inner, dot(-l, light.direction));
    }
    // Saturate before the spot factor: a light bright enough to overflow f32 at this
    // distance would otherwise turn inf x 0 into NaN outside its cone (black pixels);
    // the half-float targets cannot hold more anyway.
    return min(light.color * attenuation, vec3<f32>(HALF_MAX)) * spot;
}

// Light `i`'s `transmittance` at `world`, times its radiance there. `shadow`: its shadow factor
// at `world`, or < 0 to look it up here, after the radiance test (a point outside the light's
// cone reads no shadow map).
fn radiant_transmittance(i: u32, world: vec3<f32>, n_vertex: vec3<f32>, v: vec3<f32>, shadow: f32) -> Transmitted {
    let light = lights.lights[i];
    let l = light_direction(light.kind, light.position, light.direction, world);
    let radiance = light_radiance(light, world, l);
    if (all(radiance <= vec3<f32>(0.0))) {
        return Transmitted(vec3<f32>(0.0), vec3<f32>(0.0));
    }
    let lit = select(shadow, shadow_factor(light, world), shadow < 0.0);
    let t = transmittance(light, world, n_vertex, l, v, lit);
    return Transmitted(radiance * t.diffuse, radiance * t.ballistic);
}

// Where a pipeline that reads `diffusion` from the transmitted map runs each light's chord at
// the pixels the map misses (`frame_plan::LightingVariant::outline_pass`): false in `shade`
// below, true in the outline pass after the lighting pass (outline.wgsl). A CPU rasteriser
// runs a branch's code at every pixel whether or not any takes it; a pass of its own runs it
// only where the pixels are.
override OUTLINE_PASS: bool = false;

// The thickness debug view (overrides.rs, THICKNESS_VIEW): the diffuse target holds the
// thickness the transmittance sees, in profile mm (tonemap.wgsl draws it).
override THICKNESS_VIEW: bool = false;

// Every light's contribution at `world`. The UV-space irradiance pass calls it too, so both
// see the same lights, shadows and transmittance.
// `screen`: where `world` is the pixel's surface, `diffusion` may read its transmitted light
// from the transmitted map (transmittance.wgsl, transmitted_from_map).
fn shade(world: vec3<f32>, n: vec3<f32>, n_vertex: vec3<f32>, v: vec3<f32>, m: f32, rho_s: f32, with_tsm: bool, screen: ScreenSample) -> Shading {
    var s: Shading;
    s.irradiance = vec3<f32>(0.0);
    s.transmitted = vec3<f32>(0.0);
    s.tsm = vec3<f32>(0.0);
    s.specular = vec3<f32>(0.0);
    s.outline = false;
    let count = min(lights.count, MAX_LIGHTS);
    // Translucent shadow maps are method 4's: a pipeline built for another leaves them out.
    let tsm = with_tsm && (TRANSMITTANCE_METHOD == FOLLOW_UNIFORM || TRANSMITTANCE_METHOD == TRANSMITTANCE_TSM);
    // `diffusion` from the transmitted map: where the map holds the pixel's surface, one read
    // serves every light. Where it does not (an outline, whose outer pixels no texel centre
    // covers; a depth edge), each light's chord runs here (`transmittance`, without taps) and
    // the diffuse part becomes the larger of their sum and the nearest texel's: the grazing
    // view and the thin rim make an outline's transmitted light change within a texel, and the
    // nearest texel alone, lying further in, left the finger's light-side outline at -27 %
    // against the path tracer instead of -17 % (docs/lab/fidelity.md, finding 14).
    // With OUTLINE_PASS the chords and the nearest texel are both left to the outline pass
    // (outline.wgsl), which adds the larger; this pass adds no transmitted light there.
    let from_map = TRANSMITTANCE_METHOD == TRANSMITTANCE_DIFFUSION && LATERAL_SOURCE == LATERAL_MAP;
    let chords_here = !(from_map && OUTLINE_PASS);
    var shadows: array<f32, MAX_LIGHTS>;
    var lit = 0u;
    for (var i = 0u; i < count; i++) {
        let light = lights.lights[i];
        let l = light_direction(light.kind, light.position, light.direction, world);
        let radiance = light_radiance(light, world, l);
        let dark = all(radiance <= vec3<f32>(0.0));
        if (dark && !tsm) {
            continue;
        }
        let shadow = shadow_factor(light, world);
        shadows[i] = shadow;
        if (tsm) {
            // The back-side irradiance already holds every light's radiance; a point this
            // light sees directly is the entry point itself and receives nothing through it.
            s.tsm += tsm_transmittance(light, world, n_vertex, shadow);
        }
        if (dark) {
            continue;
        }
        s.irradiance += radiance * source_shadow(light, world, n_vertex, l, shadow) * max(dot(n, l), 0.0);
        s.specular += radiance * shadow * boundary_specular(n, l, v, m, rho_s);
        lit = lit_code(lit, i, dot(n_vertex, l), shadow);
    }
    var mapped = MapRead(Transmitted(vec3<f32>(0.0), vec3<f32>(0.0)), false);
    if (from_map) {
        var at = screen;
        at.lit = lit;
        if (OUTLINE_PASS) {
            mapped = transmitted_on_surface(at);
        } else {
            mapped = transmitted_from_map(at);
        }
    }
    if (!mapped.on_surface && chords_here) {
        for (var i = 0u; i < count; i++) {
            let t = radiant_transmittance(i, world, n_vertex, v, shadows[i]);
            s.transmitted += t.diffuse;
            s.specular += t.ballistic;
        }
    }
    if (from_map) {
        if (mapped.on_surface) {
            s.transmitted += mapped.t.diffuse;
            s.specular += mapped.t.ballistic;
        } else {
            s.transmitted = max(s.transmitted, mapped.t.diffuse);
            s.outline = !chords_here;
        }
    }
    return s;
}

// pow(albedo, e) without pow(0, 0).
fn albedo_power(albedo: vec3<f32>, e: f32) -> vec3<f32> {
    return pow(max(albedo, vec3<f32>(1e-6)), vec3<f32>(e));
}

@fragment
fn fs_main(in: LitVarying, @builtin(front_facing) front: bool) -> GBuffer {
    var n_vertex = normalize(in.normal);
    if (!front) {
        n_vertex = -n_vertex;
    }
    let n = shading_normal(in, n_vertex);
    var albedo = object.albedo;
    if (object.has_albedo_map != 0u) {
        albedo *= textureSample(albedo_map, material_sampler, in.uv).rgb;
    }
    var rho_s = object.specular;
    if (object.has_specular_map != 0u) {
        rho_s *= textureSample(specular_map, material_sampler, in.uv).r;
    }
    let m = object.roughness;
    let v = normalize(camera.position - in.world);
    let ts = texture_space.params;
    // In uniform control flow: the derivatives extend the pixel's surface to the transmitted map's
    // texels around it.
    let depth = dot(in.world - camera.position, camera.forward);
    let screen = ScreenSample(in.clip.xy, depth, vec2<f32>(dpdx(depth), dpdy(depth)), 0u);
    let s = shade(in.world, n, n_vertex, v, m, rho_s, ts.y > 0.5, screen);

    var out: GBuffer;
    if (ts.x > 0.5) {
        // Texture-space diffusion: the blurred UV-space map already holds lights, shadows,
        // ambient and transmittance (and albedo^z); the rest of the albedo is applied here.
        let blurred = textureSampleLevel(ts_result, ts_sampler, in.uv, 0.0).rgb;
        out.diffuse = vec4<f32>(albedo_power(albedo, 1.0 - ts.z) * (blurred + s.tsm), 1.0);
    } else {
        // Transmitted light joins the reflected diffuse light before the SSS blur, so the two
        // are blurred together (000_*).
        // The bounce is light arriving like the lights' own: it enters and diffuses too.
        let bounce = pixel_bounce(in.world, n_vertex, screen);
        // Light arriving at the front face (the lights, the ambient, the bounce) is what a thin
        // part lets out through its back; light transmitted from behind has its own T(s).
        var thin = vec3<f32>(1.0);
        if (has_term(TERM_THIN_PARTS) && object.sss_strength > 0.0) {
            thin = thin_part_reflectance(in.clip.xy, depth, in.world, n_vertex, v);
        }
        out.diffuse = vec4<f32>(albedo * ((s.irradiance + lights.ambient + bounce) * thin + s.transmitted + s.tsm), 1.0);
    }
    if (THICKNESS_VIEW) {
        // Thickness debug view (tonemap.wgsl reads it back from diffuse.r).
        out.diffuse = vec4<f32>(min_thickness_mm(in.world, n_vertex), 0.0, 0.0, 1.0);
    }
    // Sums of many saturated lights could still pass the half-float range: clamp rather than
    // let the target round to infinity (which the blur would spread as NaN).
    out.diffuse = vec4<f32>(min(out.diffuse.rgb, vec3<f32>(HALF_MAX)), 1.0);
    out.specular = vec4<f32>(min(s.specular, vec3<f32>(HALF_MAX)), 1.0);
    out.depth = depth;
    // a: where the outline pass adds the chords (its full-screen mark reads it).
    let outline = s.outline && ts.x <= 0.5 && !THICKNESS_VIEW;
    out.sss = vec4<f32>(object.sss_strength, object.world_per_mm, f32(object.profile), select(0.0, 1.0, outline));
    return out;
}

