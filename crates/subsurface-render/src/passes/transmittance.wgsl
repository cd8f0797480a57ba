// Transmittance through thin parts, evaluated per light inside the lighting pass
// (lighting.wgsl calls `transmittance`; shadow_coord and the bindings are declared there).

// The transmittance method this pipeline is built for (`TransmittanceMethod::code`), or 255
// to follow `lights.transmittance` at run time (the texture-space irradiance pass). The
// lighting pass builds one pipeline per method (frame_plan.rs, `LightingVariant`) so
// that the compiler drops the other methods' code: one shader for all of them made `paper`'s
// lighting pass pay for `diffusion`'s taps and LUT reads it never ran (lavapipe, 640x360:
// 117 ms against 77 specialized; on GPUs the unused branches still cost registers).
override TRANSMITTANCE_METHOD: u32 = FOLLOW_UNIFORM;

// Where this pipeline's `diffusion` comes from (frame_plan.rs, `LightingVariant::lateral`): 0 per point
// without lateral light (another method, or no taps), 1 the transmitted map (shade reads every
// light's transmitted light there at once, and runs the chords here, without taps, where the
// map has no texel of the pixel's surface), 2 per point with the taps (no map, skin too far for the map's texels:
// the renderer draws it with this variant, gpu_scene.rs `lateral_taps_objects`, and the
// map pass's fragment shader), 3 per point with the taps' sum given in `given_lateral`
// (the map pass's compute shader, transmitted_map.wgsl `cs_transmitted`, which spreads each texel's
// taps over several invocations), 255 per point with the taps (the texture-space pass). A
// pipeline per source, as for the method: the map's pipeline holds no tap loop, which llvmpipe
// runs for every pixel once any pixel needs it (7 of the lighting pass's 117 ms at 640x360)
// and a GPU pays for in registers.
override LATERAL_SOURCE: u32 = FOLLOW_UNIFORM;

// LATERAL_SOURCE 3: the light's entry (`light_entry`) at the point `transmittance` is called
// for, and the sum of `lateral_tap_sum` over all its taps, which the caller gathered before
// the call.
var<private> given_entry: Entry;
var<private> given_lateral: vec3<f32>;
// LATERAL_SOURCE 3: the taps' kernel masses (`lateral_mass`) summed over the texel's lanes.
var<private> given_mass: vec2<f32>;
// The lateral taps' last sum's kernel masses: x the slab kernel's weight of the taps that find
// the part (or whose mirror across the chord does), y of all taps; x / y is how much of the
// chord's slab exists around it (`transmittance`).
var<private> lateral_mass: vec2<f32>;

fn transmittance_method() -> u32 {
    if (TRANSMITTANCE_METHOD == FOLLOW_UNIFORM) {
        return lights.transmittance;
    }
    return TRANSMITTANCE_METHOD;
}

// Mean linear light distance over an N x N texel footprint around the projected point: the
// softer thickness that 000_* suggests (a single texel turns shadow-map aliasing into
// high-frequency transmitted light). Empty texels (nothing seen by the light) are skipped.
// x: the mean distance (< 0 if every texel is empty); y: the centre texel's encoded entry
// normal (< 0 if that texel is empty).
fn shadow_distance(light: Light, sc: ShadowCoord, taps: i32) -> vec2<f32> {
    let size = light.shadow_uv_scale / light.atlas_texel;
    let centre = vec2<i32>(floor(sc.uv * size));
    let max_texel = vec2<i32>(i32(size) - 1);
    let h = max(taps, 1) / 2;
    var sum = 0.0;
    var n = 0.0;
    var normal = -1.0;
    for (var j = -h; j <= h; j++) {
        for (var i = -h; i <= h; i++) {
            let texel = clamp(centre + vec2<i32>(i, j), vec2<i32>(0), max_texel);
            let d = textureLoad(shadow_atlas, texel, sc.layer, 0).rg;
            if (d.x < 1e30) {
                sum += d.x;
                n += 1.0;
                if (i == 0 && j == 0) {
                    normal = d.y;
                }
            }
        }
    }
    return vec2<f32>(select(-1.0, sum / max(n, 1.0), n > 0.0), normal);
}

const PI: f32 = 3.14159265;

// The texel of `light`'s map that holds the projected point.
fn shadow_texel(light: Light, sc: ShadowCoord) -> vec2<i32> {
    let size = light.shadow_uv_scale / light.atlas_texel;
    return clamp(vec2<i32>(floor(sc.uv * size)), vec2<i32>(0), vec2<i32>(i32(size) - 1));
}

// Must match TransmittanceLut::DIFFUSION_S_MAX_MM (the range of the transport rows, 1..=16).
const DIFFUSION_RANGE_MM: f32 = 32.0;
// The LUT's rows (transmittance.rs, `lut_texture`): 0 the sum-of-Gaussians T(s), 1..=16 the
// transport T(s) per exit direction (SlabSolver::EXIT_ANGLES), then the lateral taps' three,
// then the thin parts' reflectance.
const EXIT_ROWS: f32 = 16.0;
const FLUX_ROW: f32 = 17.0;
const SLOPE_ROW: f32 = 18.0;
const RISE_ROW: f32 = 19.0;
// What a slab reflects as a share of the half-space's albedo (lighting.wgsl, thin_part_reflectance).
const THIN_ROW: f32 = 20.0;

// One row of the object's T(s) LUT over 0..range mm, 0 beyond it. `row` is in texels: row 0
// holds the sum-of-Gaussians T(s), rows 1..=N the transport T(s) per exit direction; a
// fractional row between 1 and N blends two exit directions, never row 0.
fn lut_row(s_mm: f32, range: f32, row: f32) -> vec3<f32> {
    let size = vec2<f32>(textureDimensions(transmittance_lut));
    if (s_mm > range) {
        return vec3<f32>(0.0);
    }
    let u = (s_mm / range * (size.x - 1.0) + 0.5) / size.x;
    return textureSampleLevel(transmittance_lut, lut_sampler, vec2<f32>(u, (row + 0.5) / size.y), 0.0).rgb;
}

// T(s) of the object's sum-of-Gaussians profile (000_*).
fn profile_transmittance(s_mm: f32) -> vec3<f32> {
    return lut_row(s_mm, object.lut_range_mm, 0.0);
}

// What the object's rough boundary (Beckmann facets of its roughness, its medium's eta) lets
// through at cosine `mu` to its normal, entering or, by reciprocity, leaving diffusely lit
// from inside (subsurface_profile::specular::rough_transmittance, Walter et al. 2007 as
// Mitsuba's rough dielectric evaluates it). A smooth boundary's 1 - F goes to 0 at grazing;
// this stays near 0.73 for roughness 0.3, because facets tilted toward a grazing direction see
// it less obliquely. Where the camera grazes a backlit rim that is most of the light leaving:
// with the smooth 1 - F the finger proxy's light-side outline read -25 % against the path
// tracer, with this -14 % (docs/lab/fidelity.md, finding 8).
// A polynomial fit of the integral rather than a LUT row (within 0.003 of it for roughness
// 0.15 to 1): `diffusion` evaluates it up to a dozen times per light and pixel, and the reads
// were 14 of its lighting pass's 117 ms on lavapipe at 640x360 (docs/lab/performance.md).
fn boundary_transmittance(mu: f32) -> f32 {
    let x = clamp(mu, 0.0, 1.0);
    let lo = object.boundary_fit[0];
    let hi = object.boundary_fit[1];
    return ((((((hi.w * x + hi.z) * x + hi.y) * x + hi.x) * x + lo.w) * x + lo.z) * x + lo.y) * x + lo.x;
}

// Multiply scattered light through a slab of the object's medium by exact transport
// (lut.rs, `transport_at`), arriving at the surface with direction cosine `c` to the way it
// flows: behind thick parts it travels mostly along its flow (1.1-1.7x a Lambertian exit's
// radiance there, bluer channels more).
fn diffusion_transmittance(s_mm: f32, c: f32) -> vec3<f32> {
    return lut_row(s_mm, DIFFUSION_RANGE_MM, 1.0 + clamp(c, 0.0, 1.0) * (EXIT_ROWS - 1.0));
}

// The factor of the transmitted light's Lambertian radiance that leaves toward the camera:
// inside, the slab's angular shape around the direction `flow` the light moves in, then what
// the rough boundary at the shaded point lets out toward the camera. In a slab the light flows
// along the normal; through a part it flows along the light, the chord's own direction, bent
// toward the normal where it leaves (`exit_flow`).
fn transmitted_exit(s_mm: f32, n: vec3<f32>, v: vec3<f32>, flow: vec3<f32>) -> vec3<f32> {
    let eta = max(object.eta, 1.0001);
    let mu_o = dot(n, v);
    // `!(> 0)`: a degenerate normal (NaN) must give nothing, not NaN that a blur spreads.
    if (!(mu_o > 0.0)) {
        return vec3<f32>(0.0);
    }
    // The direction inside that refracts into v.
    let inside = -refract(-v, n, 1.0 / eta);
    return diffusion_transmittance(s_mm, dot(inside, flow)) * boundary_transmittance(mu_o);
}

// The direction the chord's light moves in where it leaves p (normal `n`, light direction
// `l`): the light's own direction plus EXIT_FLOW_NORMAL of the normal. Taken halfway (weight 1,
// until session 43), the flow leaned toward the normal wherever the light crosses the surface
// at a slant, and points past the terminator of a part lit from the side or off the axis read
// 1.1-1.7x a random walk in the same media (tools/reference/confinement_mc.py, 108 windows
// across 8 and 18 mm rods lit at 0, 35, 90 and 120 degrees: mean |log(renderer / walk)| 0.239;
// the light's direction alone 0.192, weight 0.4 0.202). The path-traced rims of backlit parts
// (the canonical finger, sphere and hand) darken as the weight goes to 0 (-2 points at 0),
// where the walk sees no difference; 0.4 is the smallest weight, in tenths, that leaves every
// canonical region at every preset at least as far inside its target as weight 1 did
// (docs/lab/suite.md, session 43). The same weight where a shadowed point faces the light:
// keeping the halfway direction there left `wedge--chicken1--side60`'s far outline at +27 %
// against the path tracer instead of +21 %, and put a step in the flow at the terminator.
const EXIT_FLOW_NORMAL: f32 = 0.4;

fn exit_flow(n: vec3<f32>, l: vec3<f32>) -> vec3<f32> {
    // Never zero for unit vectors: |0.4 n - l| >= 0.6.
    return normalize(n * EXIT_FLOW_NORMAL - l);
}

// Where `light` enters the object on its way to `p`, read from the standard linear-distance
// shadow map (Jimenez et al. 2010).
struct Entry {
    // The thickness s between the entry and p, in millimetres of the object's profile; < 0
    // where it is unknown (no shadow map, outside it, not translucent).
    s_mm: f32,
    // The normal of the entry surface, turned toward the light; zero where unknown.
    normal: vec3<f32>,
};

fn light_entry(light: Light, p: vec3<f32>, n_vertex: vec3<f32>) -> Entry {
    var e: Entry;
    e.s_mm = -1.0;
    e.normal = vec3<f32>(0.0);
    // Only lights with a shadow map know the thickness: the others add nothing (no glow).
    if (light.first_layer < 0.0 || object.translucency <= 0.0) {
        return e;
    }
    // Shrink along the vertex normal so points at the silhouette project inside the object
    // in the shadow map rather than onto background texels (000_*, instead of Green's growing
    // of the shadow caster).
    let shrunk = p - n_vertex * lights.normal_shrink;
    let sc = shadow_coord(light, shrunk);
    if (!sc.inside) {
        return e;
    }
    // The lighting pipeline that reads the transmitted map runs this only at outline pixels, with
    // one texel: the N x N loop's code cost 0.14 ms of registers at every pixel of that pass on
    // an H100 (docs/lab/performance.md). Written as min(N, 1), not a literal 1: with the literal,
    // Mesa 22.3's lavapipe chose to inline this pipeline's uniforms and compiled a new copy of
    // it at every bind without freeing the last (11 MB and 55 ms a frame at 320x240; the
    // viewer's soak test grew 18 % in ten cycles), while a bound that still reads a uniform
    // keeps the shader it compiled once (docs/lab/performance.md, "lavapipe's inlined uniforms").
    let taps = i32(lights.thickness_filter);
    let texels = shadow_distance(light, sc, select(taps, min(taps, 1), LATERAL_SOURCE == LATERAL_MAP));
    let d_in = texels.x;
    if (d_in < 0.0) {
        return e;
    }
    if (texels.y >= 0.0) {
        e.normal = decode_normal(texels.y);
    }
    // 000_* measures from the shrunk point too, which makes every part thinner by the shrink
    // (0.5 mm in the canonical scenes: +15 % of red diffusion through thick parts, 1.5x the
    // unscattered light through thin ones). The extensions measure from p itself and use the
    // shrunk point only to find the entry texel.
    let measured_at = select(p, shrunk, transmittance_method() == TRANSMITTANCE_PAPER);
    let s_units = abs(light_distance(light.kind, light.position, light.direction, measured_at) - d_in);
    // Into the profile's millimetres: scene units per mm (sss width) times translucency.
    e.s_mm = s_units / (object.world_per_mm * object.translucency);
    return e;
}

// The back-irradiance factor of `transmittance`: the 0.3 lets light wrap around thin edges
// (000_*, Figure 7); 0 where the surface faces the light.
fn back_irradiance(n_vertex: vec3<f32>, l: vec3<f32>) -> f32 {
    return max(0.3 + dot(-n_vertex, l), 0.0);
}

// The thinnest thickness over the lights that transmit light here, those with a shadow map
// behind the surface (the thickness debug view); < 0 if none. Lights in front are left out:
// they see the point itself (thickness 0) and transmit nothing through it.
fn min_thickness_mm(p: vec3<f32>, n_vertex: vec3<f32>) -> f32 {
    var best = -1.0;
    let count = min(lights.count, MAX_LIGHTS);
    for (var i = 0u; i < count; i++) {
        let light = lights.lights[i];
        let l = light_direction(light.kind, light.position, light.direction, p);
        if (back_irradiance(n_vertex, l) <= 0.0) {
            continue;
        }
        let s = light_entry(light, p, n_vertex).s_mm;
        if (s >= 0.0 && (best < 0.0 || s < best)) {
            best = s;
        }
    }
    return best;
}

// Light scattered once on its way from the lit side to the camera (our extension of
// `diffusion`; Jensen et al. 2001's single-scattering term, which diffusion leaves out).
// Along the camera ray refracted into p, each point q at depth t sees the light after the
// distance s_i it has crossed since its entry, which the shadow map gives (q's light distance
// less the stored one, as for the thickness): L = sigma_s' / 4 x int T_in exp(-sigma_t (t +
// s_i)) dt x T_out, the isotropic phase 1 / (4 pi) times pi for this renderer's radiance
// (albedo x E). It is what lights a backlit finger's rim, where the lit side is a couple of
// millimetres away but the chord along the light is long; on a slab facing the light with the
// camera behind it, t + s_i is the thickness s everywhere and L = sigma_s' s exp(-sigma_t s) / 4.
// Eight steps over the thickness s at p, and only where the medium's slowest channel keeps
// exp(-sigma_t s) of at least 0.2 % (SCATTER_DEPTH): past that the march would cost eight
// loads per light over most of a head for nothing (the five-light head on lavapipe: without a
// bound the march alone added 35 % to the frame; with it, all of `diffusion` adds 6-8 %).
// The bound is an optical depth, not a length: it is 8 mm in skin1, 5.6 in skin2, but 38 mm in
// chicken1, whose light mostly crosses a 10 mm sphere unscattered or scattered once (a bound of
// 8 mm for every medium left a 15 mm slab of chicken1 -23 % against the path tracer, and
// +4 % with this one; docs/lab/suite.md).
const SCATTER_STEPS: i32 = 8;
// The lighting pipeline that reads the transmitted map runs `transmittance` only at the pixels the
// map has no texel for (an outline; shade in lighting.wgsl), with this many steps: the code a
// shader holds costs registers at every pixel of that pipeline on an H100, taken or not
// (1920x1080, the default scene: its lighting pass 2.80 ms with eight steps, 2.71 with four,
// `paper`'s 2.55), for 0.8 point on the finger's outline against the path tracer
// (docs/lab/performance.md); the thickness there is a single texel (light_entry).
const OUTLINE_SCATTER_STEPS: i32 = 4;
// An override, so that each pipeline's march has a constant trip count.
override MARCH_STEPS: i32 = select(SCATTER_STEPS, OUTLINE_SCATTER_STEPS, LATERAL_SOURCE == LATERAL_MAP);
// exp(-6.2) = 0.2 %: skin1's red (sigma_t 0.772 per mm) at 8 mm, the bound this replaced.
const SCATTER_DEPTH: f32 = 6.2;

// The object's smallest extinction over the channels: the slowest decay of unscattered light.
fn min_extinction() -> f32 {
    return min(min(object.extinction.x, object.extinction.y), object.extinction.z);
}

// q's depth below the lit surface along the light, in profile mm, and the stored normal's code;
// (-1, -1) outside the map or where the light sees nothing. The single scattering's march and
// the unscattered light's entry (unscattered.wgsl) both step along the refracted camera ray.
fn depth_below_entry(light: Light, q: vec3<f32>, units_per_mm: f32) -> vec2<f32> {
    let sc = shadow_coord(light, q);
    if (!sc.inside) {
        return vec2<f32>(-1.0, -1.0);
    }
    let d = textureLoad(shadow_atlas, shadow_texel(light, sc), sc.layer, 0).rg;
    if (d.x > 1e30) {
        return vec2<f32>(-1.0, -1.0);
    }
    return vec2<f32>((light_distance(light.kind, light.position, light.direction, q) - d.x) / units_per_mm, d.y);
}

fn single_scattering(light: Light, p: vec3<f32>, n_front: vec3<f32>, l: vec3<f32>, v: vec3<f32>, s_mm: f32) -> vec3<f32> {
    let eta = max(object.eta, 1.0001);
    let r = refract(-v, n_front, 1.0 / eta);
    let cos_v = dot(v, n_front);
    if (cos_v <= 0.0 || dot(r, r) < 0.5) {
        return vec3<f32>(0.0);
    }
    let units_per_mm = object.world_per_mm * object.translucency;
    let step_mm = s_mm / f32(MARCH_STEPS);
    var sum = vec3<f32>(0.0);
    for (var k = 0; k < MARCH_STEPS; k++) {
        let t = (f32(k) + 0.5) * step_mm;
        let b = depth_below_entry(light, p + r * (t * units_per_mm), units_per_mm);
        // Beyond the far side (or outside the map, or nothing seen by the light there): the
        // ray has left.
        if (b.x <= 0.0) {
            break;
        }
        let cos_e = select(1.0, max(dot(decode_normal(b.y), l), 0.0), b.y >= 0.0);
        sum += boundary_transmittance(cos_e) * exp(-object.extinction * (t + b.x));
    }
    let t_out = boundary_transmittance(cos_v);
    return object.reduced_scattering * 0.25 * sum * step_mm * t_out;
}

// Light that enters the lit surface around the chord and reaches p through the medium
// (subsurface_profile::lateral, whose `lateral_transmittance` this mirrors): a point kernel
// K(r) = -T'(r) / (2 pi r) of the slab's own T_ms, summed over taps on the plane through p
// across the light, each finding in the shadow map where the light entered there. Behind a
// plane it gives the slab's T_ms(s); behind the backlit hand's palm, whose chords are 24-40 mm
// but whose finger roots beside it are 15, the path tracer shows 3-5x the chord's slab and
// the taps find it. Taps are spaced by the medium's slowest decay so that on a slab they all
// weigh the same. Entries above p's tangent plane are left out: light entering the same face
// beside p (a front-lit surface next to a shadow) is the reflectance profile's, which the
// screen-space blur already spreads. In T_ms / albedo units, as the LUT rows.
fn lateral_transmittance(light: Light, p: vec3<f32>, n_vertex: vec3<f32>, l: vec3<f32>, s_mm: f32) -> vec3<f32> {
    return lateral_tap_sum(light, p, n_vertex, l, s_mm, 0u, 1u) * lut_row(s_mm, DIFFUSION_RANGE_MM, RISE_ROW);
}

// Two unit vectors across the light's direction `l`: the lateral taps' and the walls' plane.
fn across_light(l: vec3<f32>) -> mat2x3<f32> {
    let a = select(vec3<f32>(0.0, 1.0, 0.0), vec3<f32>(1.0, 0.0, 0.0), abs(l.y) > 0.9);
    let t1 = normalize(cross(l, a));
    return mat2x3<f32>(t1, cross(l, t1));
}

// The taps `first`, `first + stride`, ... of `lateral_transmittance`'s sum, before its factor
// of the chord's rise: invocations that share a texel each take a stride of the taps, so that
// the texel waits for a few of their shadow-map loads in turn rather than for all of them.
fn lateral_tap_sum(light: Light, p: vec3<f32>, n_vertex: vec3<f32>, l: vec3<f32>, s_mm: f32, first: u32, stride: u32) -> vec3<f32> {
    var mass_all = 0.0;
    var mass_hit = 0.0;
    let sigma = object.lateral_decay;
    let taps = min(lights.lateral_taps, 32u);
    let units_per_mm = object.world_per_mm * object.translucency;
    let shrunk = p - n_vertex * lights.normal_shrink;
    let across = across_light(l);
    let t1 = across[0];
    let t2 = across[1];
    let chord = max(s_mm, 1.0);
    // Loop invariants and recurrences rather than per-tap transcendentals: this loop is most
    // of the map pass (lavapipe, 640x360: 12 taps cost 0.7 ms each, the rest of the pass 8).
    let normal_in = 1.0 / boundary_transmittance(1.0);
    let per_tap = 1.0 / (f32(taps) * sigma);
    // The taps turn by the golden angle: (cos, sin) of tap i, rotated once per tap; a stride
    // of taps turns `stride` times as far (with stride 1, exactly `golden`).
    let golden = vec2<f32>(-0.73736887, 0.67549029); // cos, sin of 2.39996323
    var dir = vec2<f32>(1.0, 0.0);
    var turn = vec2<f32>(1.0, 0.0);
    for (var k = 0u; k < stride; k++) {
        if (k == first) {
            dir = turn;
        }
        turn = vec2<f32>(turn.x * golden.x - turn.y * golden.y, turn.x * golden.y + turn.y * golden.x);
    }
    var sum = vec3<f32>(0.0);
    for (var i = first; i < taps; i += stride) {
        let xi = (f32(i) + 0.5) / f32(taps);
        let u = -log(1.0 - xi) / sigma;
        let r_tap = chord + u;
        let rho = sqrt(r_tap * r_tap - chord * chord);
        let q = shrunk + (t1 * dir.x + t2 * dir.y) * (rho * units_per_mm);
        // The stratified taps' density is sigma exp(-sigma u) = sigma (1 - xi) per mm.
        let weight = r_tap * per_tap / (1.0 - xi);
        dir = vec2<f32>(dir.x * turn.x - dir.y * turn.y, dir.x * turn.y + dir.y * turn.x);
        // The tap's weight in the chord's own slab (its entry at the chord's depth): the taps'
        // sum of it over a slab is the slab's T_ms, the chord term; the green channel, the
        // middle of the kernels, stands for all three.
        let slab_r = min(r_tap, DIFFUSION_RANGE_MM);
        let slab_w = lut_row(slab_r, DIFFUSION_RANGE_MM, SLOPE_ROW).g / r_tap * weight;
        mass_all += slab_w;
        let sc = shadow_coord(light, q);
        var texel = vec2<f32>(3.4e38, -1.0);
        if (sc.inside) {
            texel = textureLoad(shadow_atlas, shadow_texel(light, sc), sc.layer, 0).rg;
        }
        let d = texel.x;
        // The mirrored tap, across the chord: at an outline one of the two lies on the part,
        // beside a part narrower than the kernel neither does.
        if (d <= 1e30 || shadow_covered(light, 2.0 * shrunk - q)) {
            mass_hit += slab_w;
        }
        if (!sc.inside || d > 1e30) {
            continue;
        }
        let to_light = light_direction(light.kind, light.position, light.direction, q);
        // What the boundary lets in there, relative to the slab's normal incidence that K is
        // calibrated on: the grazing entries near a sphere's or a finger's terminator pass
        // less (without it a backlit sphere's centre read +16 % against the path tracer, with
        // a smooth boundary's 1 - F +5 %, with the rough boundary's +9 %).
        var entry_in = 1.0;
        if (texel.y >= 0.0) {
            let cos_e = max(dot(decode_normal(texel.y), to_light), 0.0);
            entry_in = boundary_transmittance(cos_e) * normal_in;
        }
        let entry = q + to_light * (light_distance(light.kind, light.position, light.direction, q) - d);
        let offset = entry - p;
        let r_units = length(offset);
        // Full weight from 30 degrees below p's tangent plane, none on or above it.
        let below = clamp(-2.0 * dot(offset, n_vertex) / max(r_units, 1e-12), 0.0, 1.0);
        let r = r_units / units_per_mm;
        if (below <= 0.0 || r <= 0.0) {
            continue;
        }
        // Past the table the kernel goes on decaying at the slowest rate (lateral.rs, slope_at).
        let tail = exp(-sigma * max(r - DIFFUSION_RANGE_MM, 0.0));
        let slope = lut_row(min(r, DIFFUSION_RANGE_MM), DIFFUSION_RANGE_MM, SLOPE_ROW) * tail;
        sum += slope / r * weight * below * entry_in;
    }
    lateral_mass = vec2<f32>(mass_hit, mass_all);
    return sum;
}

struct Transmitted {
    diffuse: vec3<f32>,   // joins the irradiance before the blur (times the albedo)
    ballistic: vec3<f32>, // unscattered: joins the specular target, neither blurred nor tinted
};

// `lit` is the light's shadow factor at p (1 = the light reaches p directly); v points to the
// camera. Returns factors of the light's radiance.
fn transmittance(light: Light, p: vec3<f32>, n_vertex: vec3<f32>, l: vec3<f32>, v: vec3<f32>, lit: f32) -> Transmitted {
    var out: Transmitted;
    out.diffuse = vec3<f32>(0.0);
    out.ballistic = vec3<f32>(0.0);
    let method = transmittance_method();
    // 4 (translucent shadow maps) has its own path, tsm_transmittance.
    if (method == TRANSMITTANCE_OFF || method == TRANSMITTANCE_TSM || method > TRANSMITTANCE_DIFFUSION) {
        return out;
    }
    // Where the method's own back-irradiance factor is zero (`diffusion`: a point the light
    // reaches directly on a surface facing it; the others: the wrap 0.3 - n.l), nothing
    // crosses along the chord: skip the thickness lookup and its N x N shadow-map loads.
    // Every directly lit pixel of a front-lit frame takes this exit, after the lit side's
    // march below.
    let facing = dot(n_vertex, l);
    // A point the light reaches also takes the light of the beam beneath it, where the part
    // carries more of it than the half-space the profile assumes (lit_side.wgsl).
    if (method == TRANSMITTANCE_DIFFUSION && facing > 0.0 && lit > 0.0 && has_term(TERM_LIT_SIDE)) {
        out.diffuse = lit_side_light(light, p, n_vertex, l) * lit;
    }
    if ((method == TRANSMITTANCE_DIFFUSION && facing > 0.0 && lit >= 1.0) || (method != TRANSMITTANCE_DIFFUSION && facing >= 0.3)) {
        return out;
    }
    var entry: Entry;
    if (LATERAL_SOURCE == LATERAL_GIVEN) {
        entry = given_entry;
    } else {
        entry = light_entry(light, p, n_vertex);
    }
    let s_mm = entry.s_mm;
    if (s_mm < 0.0) {
        return out;
    }
    var t = vec3<f32>(0.0);
    switch method {
        case TRANSMITTANCE_PAPER: {
            t = profile_transmittance(s_mm);
        }
        case TRANSMITTANCE_BEER: {
            // Green's Beer-Lambert attenuation exp(-sigma_t s): one layer, no colour shift
            // with depth beyond what sigma_t gives.
            t = exp(-object.extinction * s_mm);
        }
        case TRANSMITTANCE_SEED_REPORT: {
            // The ad-hoc falloff of 001_*, proportional to s^-0.6 (its constants are not
            // given; 0.15 makes 1 mm transmit about as much as the profile does).
            t = vec3<f32>(min(0.15 / pow(max(s_mm, 1e-3), 0.6), 1.0));
        }
        case TRANSMITTANCE_DIFFUSION: {
            // A point the light reaches directly is its own entry point: its light is the
            // diffuse term's, and adding T(~0) E through the wrap below doubled it along
            // every terminator (a front-lit sphere's shadow side read +23 % against the path
            // tracer). As translucent shadow maps do, only the unlit part transmits.
            // The back irradiance is the entry surface's own, E (n_entry . l), from the normal
            // the shadow map stores, rather than 000_*'s wrapped front normal (1.3x on a slab
            // facing the light).
            // Where the surface faces away from the light its direct term is zero whatever
            // the shadow map says, so nothing is counted twice: there the shadow test (which
            // the bias makes pass through the last half millimetre of a thin edge) must not
            // switch the transmitted light off.
            let n_back = entry.normal;
            if (dot(n_back, n_back) > 0.5) {
                let unlit = select(1.0 - lit, 1.0, facing <= 0.0);
                let flow = exit_flow(n_vertex, l);
                // The chord's slab, read inside the table so that its exit shape per unit of
                // T_ms also serves the lateral light past the table's end.
                let s_shape = min(s_mm, DIFFUSION_RANGE_MM - 0.25);
                let exit = transmitted_exit(s_shape, n_vertex, v, flow);
                // The slab's T(s) is solved for light arriving head-on; at the entry's own angle
                // the rough boundary lets in its share of that.
                let cos_back = max(dot(n_back, l), 0.0);
                let entry_in = cos_back * boundary_transmittance(cos_back) / boundary_transmittance(1.0);
                var diffuse = select(vec3<f32>(0.0), exit, s_mm <= s_shape) * entry_in;
                // The slab of the chord and the light from the surface around it are two
                // estimates of one flux: the chord's holds where the part is narrow and the
                // medium keeps the light in (a finger, a wedge), the lateral one where light
                // finds a shorter way than the chord (a palm beside the finger roots). Each is
                // low where the other holds; the larger one counts.
                if (LATERAL_SOURCE >= LATERAL_TAPS && lights.lateral_taps > 0u && object.lateral_decay > 0.0) {
                    let flux = lut_row(s_shape, DIFFUSION_RANGE_MM, FLUX_ROW);
                    let shape = select(vec3<f32>(0.0), exit / flux, flux > vec3<f32>(1e-7));
                    var lateral: vec3<f32>;
                    if (LATERAL_SOURCE == LATERAL_GIVEN) {
                        lateral = given_lateral * lut_row(s_mm, DIFFUSION_RANGE_MM, RISE_ROW);
                        lateral_mass = given_mass;
                    } else {
                        lateral = lateral_transmittance(light, p, n_vertex, l, s_mm);
                    }
                    // The chord's slab is infinite; a part narrower than the slab's kernel
                    // (a cylinder, a sphere, lit from behind) loses through its sides what
                    // the slab would send back to the exit point. Its share of the kernel that
                    // the part holds scales the chord term: beside the part a tap and its
                    // mirror across the chord both find nothing, at an outline one of them
                    // finds the part, so an outline keeps its chord (suite: a marble
                    // cylinder's middle read +90 % without it; docs/lab/suite.md). With
                    // `transmittance.side_walls` the walls' images give that share instead:
                    // the kernel's mass counts where the slab's light comes from, not how much
                    // of it the walls take, which depends on the medium's absorption (skin2's
                    // 10 mm rods read +40 % with the coverage, skin1's -4 %).
                    // The lateral taps' light crosses the same part and meets the same walls
                    // (without their loss, where the taps give more than the chord a 16 mm
                    // skin2 rod read 0.97 of its slab against a random walk's 0.77, and the
                    // suite's backlit marble ball +69 % in its middle; with it +5 %). The
                    // kernel-mass coverage is the chord's alone: it is what the taps miss.
                    let coverage = select(1.0, lateral_mass.x / lateral_mass.y, lateral_mass.y > 0.0);
                    var kept = vec3<f32>(coverage);
                    var lateral_kept = vec3<f32>(1.0);
                    if (has_term(TERM_SIDE_WALLS)) {
                        kept = side_wall_share(light, p, n_vertex, l, s_mm);
                        lateral_kept = kept;
                    }
                    diffuse = max(diffuse * kept, shape * lateral * lateral_kept);
                }
                out.diffuse += diffuse * unlit;
                var ballistic = vec3<f32>(0.0);
                if (has_term(TERM_BALLISTIC)) {
                    ballistic = unscattered_light(light, p, n_vertex, l, v, s_mm);
                }
                // Single scattering only where the surface faces away from the light: where it
                // faces the light, its shadow test's penumbra and the map's texels would print
                // onto the unblurred specular target (and a lit point's own single scattering
                // is a reflection term this renderer does not model).
                var single = vec3<f32>(0.0);
                if (has_term(TERM_SINGLE_SCATTERING) && facing <= 0.0 && s_mm * min_extinction() <= SCATTER_DEPTH) {
                    single = single_scattering(light, p, n_vertex, l, v, s_mm);
                }
                out.ballistic = (ballistic + single) * unlit;
            }
            return out;
        }
        default: {}
    }
    // Back irradiance is taken as locally constant from the low-frequency vertex normal.
    out.diffuse = t * back_irradiance(n_vertex, l);
    return out;
}

// Translucent shadow maps (d'Eon et al.; method 4): the thickness s comes from the
// linear-distance shadow map exactly as above, and the translucent shadow map gives the (u, v)
// of the entry point on the side facing the light. The light leaving here is the irradiance
// there, already blurred in texture space (the widest Gaussian), attenuated by the same T(s)
// as the 2010 method: M = T(s) E_widest(u_in, v_in). `lit` is this light's shadow factor at
// the shaded point: a point the light sees is its own entry point, so it gets (1 - lit), and
// the term fades in between 0.25 and 1 mm of thickness for the same reason.
fn tsm_transmittance(light: Light, p: vec3<f32>, n_vertex: vec3<f32>, lit: f32) -> vec3<f32> {
    if (light.first_layer < 0.0 || object.translucency <= 0.0 || lit >= 1.0) {
        return vec3<f32>(0.0);
    }
    let shrunk = p - n_vertex * lights.normal_shrink;
    let sc = shadow_coord(light, shrunk);
    if (!sc.inside) {
        return vec3<f32>(0.0);
    }
    let d_in = shadow_distance(light, sc, i32(lights.thickness_filter)).x;
    if (d_in < 0.0) {
        return vec3<f32>(0.0);
    }
    let s_units = abs(light_distance(light.kind, light.position, light.direction, shrunk) - d_in);
    let s_mm = s_units / (object.world_per_mm * object.translucency);
    let uv_in = textureLoad(tsm_atlas, shadow_texel(light, sc), sc.layer, 0).xy;
    if (uv_in.x < 0.0) {
        return vec3<f32>(0.0);
    }
    let e = textureSampleLevel(ts_widest, ts_sampler, uv_in, 0.0).rgb;
    // Within a fraction of a millimetre of the surface the light sees, the entry point is the
    // shaded point itself (shadow-map acne would otherwise add its own irradiance again).
    let own = 1.0 - smoothstep(0.25, 1.0, s_mm);
    return profile_transmittance(s_mm) * e * (1.0 - lit) * (1.0 - own);
}
