// Light that crosses a part without scattering: where it enters (along the camera's ray
// refracted into the part, so that a curved part bends it as a lens does) and how much of it the
// two rough boundaries send toward the camera. Part of the lighting shader after
// transmittance.wgsl, whose `transmittance` calls `unscattered_light`.

// Light that crosses a thin part without scattering (our extension of `diffusion`): the
// medium attenuates it by exp(-sigma_t s), the boundary refracts it twice, and its roughness
// spreads it into a narrow lobe around the refracted direction. For Beckmann slopes of RMS
// alpha / sqrt(2) per axis, one interface deviates a ray by about (eta - 1) times the facet
// tilt (Snell's law at small angles, measured outside), so the two interfaces give a Gaussian
// lobe of sigma = alpha (eta - 1) per axis. A collimated irradiance E then leaves radiance
// pi E T p(theta) in this renderer's units (pi, because our Lambertian radiance is albedo x E).
// It is what makes the thin end of a backlit wedge 2-6x brighter in the path tracer than any
// diffusion model (docs/lab/fidelity.md): a prism of skin bends the light toward the camera.
// `n_back` is the entry's normal and `through_mm` the path to it along the camera's ray
// refracted at p (`refracted_entry`); `bend` is the entry surface's curvature times that path,
// along the two axes across the light (`entry_bend`).
fn ballistic_transmittance(through_mm: f32, bend: vec2<f32>, n_back: vec3<f32>, n_front: vec3<f32>, l: vec3<f32>, v: vec3<f32>) -> vec3<f32> {
    let eta = max(object.eta, 1.0001);
    let inside = refract(-l, n_back, 1.0 / eta);
    let cos_i = dot(n_back, l);
    let cos_exit = dot(inside, n_front);
    if (cos_i <= 0.0 || cos_exit <= 0.0) {
        return vec3<f32>(0.0);
    }
    let out = refract(inside, -n_front, eta);
    if (dot(out, out) < 0.5) {
        return vec3<f32>(0.0); // total internal reflection at the exit
    }
    // How far a facet tilt d turns the ray: at the entry the refracted ray turns by
    // (1 - cos i / (eta cos t)) d, and the exit turns the inside spread by its angular
    // magnification m = eta cos t' / cos o and adds (m - 1) d of its own. At normal incidence
    // both are (eta - 1) d (outside); toward grazing, both grow without bound, which is what
    // spreads the light through a finger's thin rim over the view. Beckmann slopes of RMS
    // alpha / sqrt(2) per axis.
    let cos_t = -dot(inside, n_back);
    let cos_o = max(dot(normalize(out), n_front), 0.05);
    let turn_in = abs(1.0 - cos_i / (eta * max(cos_t, 1e-3)));
    let magnify = eta * cos_exit / cos_o;
    let slope = object.roughness * 0.70710678;
    // A curved entry is a lens: a ray the exit's facets turn by d meets the entry a path t
    // further aside, where the normal has turned by kappa t d, and the light it finds there is
    // turned back toward it by turn_in kappa t d. The exit's share of the spread shrinks by
    // |1 - turn_in kappa t| along each axis (a 25 mm ball of ketchup seen on its axis: 0.54),
    // which concentrates the light the camera sees; a slab (kappa = 0) keeps both shares.
    let exit_spread = (magnify - 1.0) * abs(vec2<f32>(1.0) - turn_in * bend);
    let spread2 = vec2<f32>(magnify * turn_in * magnify * turn_in) + exit_spread * exit_spread;
    // A smooth boundary's lobe is a delta that pixels cannot resolve: keep it a few mrad wide;
    // past a radian the small-angle lobe no longer means anything. One width for both axes,
    // their geometric mean, keeps the lobe's peak (1 / (2 pi sigma_x sigma_y)).
    let sigma = clamp(slope * sqrt(sqrt(spread2.x * spread2.y)), 0.005, 1.0);
    // The facets must turn the light by the angle between its refracted direction and the
    // camera's; the likeliest split gives each interface its share of the lobe's variance. The
    // share turned at the entry runs along the camera's refracted ray (`through_mm`), the share
    // turned at the exit along the light's own refracted way to the exit's plane (`own_mm`); at
    // the lobe's peak both are the refracted path Snell's law gives (a 1 mm slab turned 40
    // degrees: 1.125 mm, where the straight chord along the light is 1.31).
    let var_in = (magnify * turn_in) * (magnify * turn_in);
    let var_out = exit_spread.x * exit_spread.y;
    let r = refract(-v, n_front, 1.0 / eta);
    let own_mm = through_mm * max(-dot(r, n_front), 0.0) / cos_exit;
    let path_mm = mix(own_mm, through_mm, var_in / max(var_in + var_out, 1e-6));
    let theta2 = 2.0 * max(1.0 - dot(normalize(out), v), 0.0);
    let lobe = exp(-theta2 / (2.0 * sigma * sigma)) / (2.0 * PI * sigma * sigma);
    let t_in = 1.0 - boundary_fresnel(cos_i);
    let t_out = 1.0 - boundary_fresnel(dot(out, n_front));
    return PI * t_in * t_out * exp(-object.extinction * path_mm) * lobe;
}

// Where the camera's ray, refracted into p, meets the surface the light enters: the entry of the
// light that reaches p unscattered and leaves toward the camera. A curved part refracts that
// light like a lens, so its entry is not the chord's along the light (a backlit ball of a weak
// scatterer focuses it toward its middle; off the axis it bends it toward the far outline).
// Marched in the shadow map as the single scattering is, out to `reach_mm`, then halved: the
// ray's crossing of the lit surface is where its point's light distance meets the stored one.
// Against the path tracer (docs/lab/suite.md, session 36) a 10 mm ball of chicken1 lit 35
// degrees off the axis read -88 % at its far outline with the chord's entry, +19 % with both
// boundaries index-matched, -44 % with this entry and -25 % with the entry's curvature too.
const ENTRY_STEPS: i32 = 12;
const ENTRY_HALVINGS: i32 = 4;
struct Through {
    s_mm: f32,          // the path from p, profile mm (-1: no entry)
    normal: vec3<f32>,  // the entry's normal
    point: vec3<f32>,   // the entry
};
fn refracted_entry(light: Light, p: vec3<f32>, n_front: vec3<f32>, v: vec3<f32>, reach_mm: f32) -> Through {
    var e: Through;
    e.s_mm = -1.0;
    e.normal = vec3<f32>(0.0);
    e.point = p;
    let eta = max(object.eta, 1.0001);
    let r = refract(-v, n_front, 1.0 / eta);
    if (dot(v, n_front) <= 0.0 || dot(r, r) < 0.5) {
        return e;
    }
    let units_per_mm = object.world_per_mm * object.translucency;
    let step_mm = reach_mm / f32(ENTRY_STEPS);
    var inside = 0.0;
    var outside = -1.0;
    var normal_code = -1.0;
    for (var k = 1; k <= ENTRY_STEPS; k++) {
        let t = f32(k) * step_mm;
        let b = depth_below_entry(light, p + r * (t * units_per_mm), units_per_mm);
        if (b.x <= 0.0) {
            // Nothing the light sees there (d > 1e30): the ray left through a shadowed side.
            if (b.y < -0.5 && b.x < 0.0) {
                return e;
            }
            outside = t;
            normal_code = b.y;
            break;
        }
        inside = t;
    }
    if (outside < 0.0) {
        return e;
    }
    for (var k = 0; k < ENTRY_HALVINGS; k++) {
        let t = 0.5 * (inside + outside);
        let b = depth_below_entry(light, p + r * (t * units_per_mm), units_per_mm);
        if (b.x > 0.0) {
            inside = t;
        } else {
            outside = t;
            if (b.y >= 0.0) {
                normal_code = b.y;
            }
        }
    }
    if (normal_code < 0.0) {
        return e;
    }
    e.s_mm = 0.5 * (inside + outside);
    e.normal = decode_normal(normal_code);
    e.point = p + r * (e.s_mm * units_per_mm);
    return e;
}

// The entry surface's curvature (1 / profile mm, positive where it bulges toward the light)
// along the two axes across the light: its stored normals a quarter of the path to either side
// (at least 0.25 mm), differenced. 0 along an axis where either side finds no surface.
fn entry_bend(light: Light, e: Through, l: vec3<f32>) -> vec2<f32> {
    let units_per_mm = object.world_per_mm * object.translucency;
    let eps_mm = max(0.25 * e.s_mm, 0.25);
    let axes = across_light(l);
    var kappa = vec2<f32>(0.0);
    for (var i = 0; i < 2; i++) {
        let a = axes[i];
        let plus = depth_below_entry(light, e.point + a * (eps_mm * units_per_mm), units_per_mm).y;
        let minus = depth_below_entry(light, e.point - a * (eps_mm * units_per_mm), units_per_mm).y;
        if (plus >= 0.0 && minus >= 0.0) {
            kappa[i] = dot(decode_normal(plus) - decode_normal(minus), a) / (2.0 * eps_mm);
        }
    }
    return kappa;
}

// The unscattered light that leaves p toward the camera, as a factor of the light's radiance.
// The march runs where the chord along the light keeps exp(-sigma_t s) of at least 4e-6 in the
// medium's slowest channel (twice single scattering's SCATTER_DEPTH): a refracted path half as
// long as the chord would still keep 0.2 % there, and past it thick skin pays no loads.
fn unscattered_light(light: Light, p: vec3<f32>, n_front: vec3<f32>, l: vec3<f32>, v: vec3<f32>, chord_mm: f32) -> vec3<f32> {
    if (chord_mm * min_extinction() > 2.0 * SCATTER_DEPTH) {
        return vec3<f32>(0.0);
    }
    let through = refracted_entry(light, p, n_front, v, 3.0 * chord_mm);
    if (through.s_mm <= 0.0) {
        return vec3<f32>(0.0);
    }
    let bend = entry_bend(light, through, l) * through.s_mm;
    return ballistic_transmittance(through.s_mm * object.translucency, bend, through.normal, n_front, l, v);
}
