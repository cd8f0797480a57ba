// The side walls of a part narrower than the light's spread (`transmittance.side_walls`): the
// share of the chord's and the lateral taps' light that such a part keeps. Part of the
// lighting shader's list (passes/mod.rs), after transmittance.wgsl, which calls it.

// Whether the light's shadow map holds any surface on the ray through q.
fn shadow_covered(light: Light, q: vec3<f32>) -> bool {
    let sc = shadow_coord(light, q);
    return sc.inside && textureLoad(shadow_atlas, shadow_texel(light, sc), sc.layer, 0).r <= 1e30;
}

// The first step of a march across the light from `start` mm, within `reach` mm, that finds
// surface (`want_covered`) or none; then two halvings of the bracket. Returns (the last step
// without, the first with) the wanted state, or (-1, -1) where the march ends first. Steps of
// half a millimetre to 8 mm, so that the march does not jump the gap between two fingers
// (steps growing from the start left blotches along the default scene's fingers, where a
// texel's march landed on the next finger and found no wall), then growing by half.
fn march_across(light: Light, origin: vec3<f32>, d: vec3<f32>, start: f32, reach: f32, want_covered: bool) -> vec2<f32> {
    let units_per_mm = object.world_per_mm * object.translucency;
    var before = start;
    var at = -1.0;
    var rho = 0.5;
    for (var j = 0u; j < 18u; j++) {
        if (start + rho > reach) {
            break;
        }
        if (shadow_covered(light, origin + d * ((start + rho) * units_per_mm)) == want_covered) {
            at = start + rho;
            break;
        }
        before = start + rho;
        rho = select(rho + 0.5, rho * 1.5, rho >= 8.0);
    }
    if (at < 0.0) {
        return vec2<f32>(-1.0);
    }
    for (var j = 0u; j < 2u; j++) {
        let mid = 0.5 * (before + at);
        if (shadow_covered(light, origin + d * (mid * units_per_mm)) == want_covered) {
            at = mid;
        } else {
            before = mid;
        }
    }
    return vec2<f32>(before, at);
}

// The share of the chord's slab light that a part narrower than the light's spread keeps:
// 1 - sum over its side walls of the light each takes (per channel). A slab is infinite
// across the light; a rod or a ball lit from behind has walls beside the chord, and light
// that wanders to them leaves. Diffusion theory's method of images: a wall puts a negative
// image of the source beyond its extrapolated boundary (z_b = 2 A D), which takes
// (s / r') exp(-sigma_tr (r' - s)) of the light arriving at distance s, r' being the image's
// distance, sqrt(s^2 + 4 (w + z_b)^2) for a wall w from the chord. Nothing in it is fitted: at
// the middle of backlit rods it matches a random walk in the same media
// (tools/reference/confinement_mc.py; docs/lab/suite.md, session 32). The walls are where the
// shadow map finds no surface, marching across the light in four directions; sigma_tr and z_b
// are the dipole's (dipole.rs), in the object's uniform.
fn side_wall_share(light: Light, p: vec3<f32>, n_vertex: vec3<f32>, l: vec3<f32>, s_mm: f32) -> vec3<f32> {
    let shrunk = p - n_vertex * lights.normal_shrink;
    let across = across_light(l);
    let sigma_tr = object.transport_decay;
    let z_b = object.extrapolation_mm;
    let s = max(s_mm, 1e-3);
    var taken = vec3<f32>(0.0);
    for (var k = 0u; k < 4u; k++) {
        let sign = select(1.0, -1.0, (k & 1u) == 1u);
        let d = select(across[0], across[1], k >= 2u) * sign;
        // The wall lies between the last covered step and the first uncovered one, to 18 mm,
        // past which a wall takes about a per cent of the light of the slowest medium (marble)
        // and nothing measurable of skin's. The halvings place the wall within an eighth of a
        // step, so that it moves smoothly with the point (a wall at the bracket's middle jumped
        // between neighbouring texels of the transmitted map).
        let open = march_across(light, shrunk, d, 0.0, 18.0, false);
        if (open.y < 0.0) {
            continue;
        }
        let wall = 0.5 * (open.x + open.y);
        // Across a gap g a neighbouring part (the next finger) takes the wall's light in and
        // sends as much back, the two being alike: the wall loses only what leaves the gap,
        // 1 - F, F = sqrt(1 + H^2) - H (H = g / s) being the view factor between two parallel
        // strips of height s across g.
        var returned = 0.0;
        let next = march_across(light, shrunk, d, open.y, open.y + 2.0 * s, true);
        if (next.y >= 0.0) {
            let h = (0.5 * (next.x + next.y) - wall) / s;
            returned = sqrt(1.0 + h * h) - h;
        }
        let image = sqrt(s * s + 4.0 * (wall + z_b) * (wall + z_b));
        // A wall the exit point faces is its own surface curving away (a rim), whose image the
        // chord's slab already holds; only the share of the wall's direction across the exit's
        // normal is a boundary of its own (without this a backlit sphere's rim read -26 %
        // against the path tracer, with it -15 %; -4 % without walls).
        let facing = max(dot(n_vertex, d), 0.0);
        taken += s / image * exp(-sigma_tr * (image - s)) * (1.0 - facing * facing) * (1.0 - returned);
    }
    return max(vec3<f32>(1.0) - taken, vec3<f32>(0.0));
}
