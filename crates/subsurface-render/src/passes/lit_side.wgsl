// The lit side of a part (`transmittance.lit_side`): light a point the light reaches directly
// takes from the beam beneath it, beyond what the half-space through the point would carry.
// Part of the lighting shader's list (passes/mod.rs), after transmittance.wgsl, which calls it.
//
// The profile (and `diffusion`'s R_d) is the half-space's: below a lit point it assumes the
// beam that entered the plane through the point, refracted and falling off with depth. In a
// part curving away from the light, the beam below a point near its terminator entered the
// flank instead, head-on, through a few millimetres of medium, and it is far stronger than the
// plane's grazing one; where the medium's mean free path is long against the part (a weak
// scatterer, a thin rod), the light scattered from it leaves through the lit side as well as
// the unlit one. Without this the lit sides of the suite's cylinders lit at 60 degrees read
// 0.54-0.89 of the path tracer, alike in every channel, while balls of diffusive media lit so
// read within 4 % (docs/lab/suite.md, sessions 39 and 40).

// The collimated beam's power per unit volume just inside a boundary it crosses at cosine `c`,
// per unit of the light's radiance: what the rough boundary lets in, narrowed from the
// beam's width on the surface to its refracted width.
fn beam_entering(c: f32) -> f32 {
    return boundary_transmittance(c) * c / refracted_cosine(c);
}

// The cosine to the normal inside the object of light that crossed its boundary at cosine `c`
// (Snell's law).
fn refracted_cosine(c: f32) -> f32 {
    let eta = max(object.eta, 1.0001);
    return sqrt(max(1.0 - (1.0 - c * c) / (eta * eta), 1e-6));
}

// Multiply scattered light leaving lit point p, in the albedo units of `transmittance`'s
// diffuse part: the beam at depths z below p along the normal, as the shadow map finds it
// (entered where the light first meets the part, through b of medium), less the beam the
// half-space through p holds there (entered at p's own cosine, along the refracted path),
// each weighted by exp(-sigma_tr z), diffusion's escape from depth z. The weight is scaled so
// that the half-space at normal incidence gives its own R_d (1 in these units): nothing in it
// is fitted, and on a plane, or wherever the part holds no more light than the half-space, it
// is zero. Depths are drawn from the slowest channel's extinction.
fn lit_side_light(light: Light, p: vec3<f32>, n_front: vec3<f32>, l: vec3<f32>) -> vec3<f32> {
    let mu_l = clamp(dot(n_front, l), 0.0, 1.0);
    if (mu_l <= 0.0) {
        return vec3<f32>(0.0);
    }
    // The plane's beam runs the refracted path z / mu', as the half-space's does; the part's
    // runs the shadow map's straight one, longer on an oblique face, so a plane reads less
    // than its own beam and takes nothing. Against the plane's straight path instead (two
    // unrefracted paths), curved faces the light meets obliquely took light the path tracer
    // does not show: the suite's tuning regions within +-25 % went from 91 to 90 % (a 10 mm
    // ball of skin1 lit from the front: +29 % at its far outline, -3 % with this).
    let mu_l_in = refracted_cosine(mu_l);
    let units_per_mm = object.world_per_mm * object.translucency;
    let rate = min_extinction();
    let beam_plane = beam_entering(mu_l);
    var part = vec3<f32>(0.0);
    var plane = vec3<f32>(0.0);
    for (var k = 0; k < MARCH_STEPS; k++) {
        let u = (f32(k) + 0.5) / f32(MARCH_STEPS);
        let z = -log(1.0 - u) / rate;
        let w = 1.0 / (f32(MARCH_STEPS) * rate * (1.0 - u));
        let b = depth_below_entry(light, p - n_front * (z * units_per_mm), units_per_mm);
        // Past the map, or where the light sees nothing: the part ends there.
        if (b.x <= 0.0) {
            break;
        }
        let cos_e = select(1.0, max(dot(decode_normal(b.y), l), 0.0), b.y >= 0.0);
        let escape = exp(-object.transport_decay * z) * w;
        part += beam_entering(cos_e) * exp(-object.extinction * b.x) * escape;
        plane += beam_plane * exp(-object.extinction * (z / mu_l_in)) * escape;
    }
    let to_albedo = (object.extinction + object.transport_decay) / beam_entering(1.0);
    return max(part - plane, vec3<f32>(0.0)) * to_albedo;
}
