// The light one lit part of the skin sends another across the air (lighting/mod.rs puts this file
// after transmittance.wgsl; the gather, the transmitted map's bounce pass `fs_bounce` and a pixel's
// bounce `pixel_bounce` are all here): gathered from the flux pyramid of each light's shadow map that
// bounce_build.wgsl sums (a reflective shadow map, Dachsbacher and Stamminger 2005, summed
// into cells so that a few hundred reads cover the whole map). Every cell sends on what the
// light delivered to it: diffusely (the medium's albedo, through the flux-weighted normal sum)
// and by its rough boundary's reflection. The cells are not tested for visibility: a shadow
// map cannot tell whether two lit points see each other (docs/lab/fidelity.md, finding 11).


// The irradiance (the receiver's albedo not yet applied) that the lit surfaces send the point
// `p` of vertex normal `n`, from every light with a spot or directional shadow map. Each level
// of the pyramid is read from `ring` to `2 ring` of its cells away from the point's place in
// the map (the finest level every cell nearer, the coarsest every cell farther), so each read
// stands for a solid angle of about the same size.
fn bounce_irradiance(p: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    return bounce_rows(p, n, 0u, 1u);
}

// The rows `first_row`, `first_row + stride`, ... of each level's cells in
// `bounce_irradiance`'s sum: invocations that share a texel each take a stride of the rows
// (transmitted_map.wgsl, `cs_bounce`).
fn bounce_rows(p: vec3<f32>, n: vec3<f32>, first_row: u32, stride: u32) -> vec3<f32> {
    var sum = vec3<f32>(0.0);
    let ring = f32(lights.bounce_ring);
    if (ring <= 0.0) {
        return sum;
    }
    let levels = i32(textureNumLevels(flux_position));
    let count = min(lights.count, MAX_LIGHTS);
    let cell_units = lights.bounce_cell_mm * object.world_per_mm;
    for (var li = 0u; li < count; li++) {
        let light = lights.lights[li];
        if (light.first_layer < 0.0 || light.kind == KIND_POINT) {
            continue;
        }
        let clip = light.view_proj[0] * vec4<f32>(p, 1.0);
        if (clip.w <= 0.0) {
            continue;
        }
        let uv = clip_to_map(clip);
        // Texels per side of the finest cell (bounce.rs, base_texels): the atlas's size over
        // the pyramid's.
        let base_texels = 1.0 / (light.atlas_texel * f32(textureDimensions(flux_position).x));
        let cells0 = light.shadow_uv_scale / light.atlas_texel / base_texels;
        let u0 = uv * cells0;
        // The finest level read: cells about `cell_mm` wide where the point is, measured by
        // projecting a step of that length across the light.
        let l = light_direction(light.kind, light.position, light.direction, p);
        let a = select(vec3<f32>(0.0, 1.0, 0.0), vec3<f32>(1.0, 0.0, 0.0), abs(l.y) > 0.9);
        let across = normalize(cross(l, a)) * cell_units;
        let c2 = light.view_proj[0] * vec4<f32>(p + across, 1.0);
        let step = length((c2.xy / c2.w - clip.xy / clip.w) * 0.5) * cells0;
        let first = clamp(i32(round(log2(max(step, 1e-6)))), 0, levels - 1);
        // A finest cell's area on the surface where the point is.
        let cell0 = cell_units / max(step, 1e-6);
        let area0 = cell0 * cell0;
        let layer = i32(light.first_layer);
        let colour = min(light.color, vec3<f32>(HALF_MAX));
        var e = vec3<f32>(0.0);
        for (var k = first; k < levels; k++) {
            let scale = exp2(f32(k));
            // A cell is a patch, not a point: a uniform disc of radius R sends a point on its
            // axis flux / (pi (d^2 + R^2)), finite where d goes to 0, and its points' mean
            // squared distance from the centre is R^2 / 2. So each cell counts as the disc of
            // its own spread, at least of its area. Without it a cell averaging surfaces far
            // apart (a floor and the top of a wall standing on it) whose mean lands next to
            // the point lit a band across the wall 1.7 times too bright (tests/bounce.rs).
            let flat = area0 * scale * scale / PI;
            let dim = max(i32(cells0 / scale), 1);
            let uk = u0 / scale;
            // The last level whose annulus reaches past the map's far corner takes the rest.
            let last = k == levels - 1 || 2.0 * ring * scale >= 1.5 * cells0;
            let lo = clamp(vec2<i32>(floor(uk - 2.0 * ring)), vec2<i32>(0), vec2<i32>(dim - 1));
            let hi = clamp(vec2<i32>(floor(uk + 2.0 * ring)), vec2<i32>(0), vec2<i32>(dim - 1));
            let rows = select(vec2<i32>(lo.y, hi.y), vec2<i32>(0, dim - 1), last);
            for (var j = rows.x + i32(first_row); j <= rows.y; j += i32(stride)) {
                // The row's cells whose centres lie within the annulus: |dx| below the outer
                // radius's half-chord, and at or past the inner one's (the finer levels read
                // inside it). Only those are visited: a square would visit 81 cells a level at
                // ring 2 for the annulus's 38.
                let dy = f32(j) + 0.5 - uk.y;
                let outer = select(sqrt(max(4.0 * ring * ring - dy * dy, 0.0)), f32(dim), last);
                let inner = select(sqrt(max(ring * ring - dy * dy, 0.0)), 0.0, k == first);
                let i0 = max(i32(ceil(uk.x - 0.5 - outer)), 0);
                let i1 = min(i32(floor(uk.x - 0.5 + outer)), dim - 1);
                let hole = vec2<i32>(vec2<f32>(ceil(uk.x - 0.5 - inner), floor(uk.x - 0.5 + inner)));
                for (var i = i0; i <= i1; i++) {
                    // Past the map's edge the hole may begin before i0: test the range.
                    if (inner > 0.0 && i >= hole.x && i <= hole.y) {
                        i = hole.y;
                        continue;
                    }
                    let pos = textureLoad(flux_position, vec2<i32>(i, j), layer, k);
                    if (pos.w <= 0.0) {
                        continue;
                    }
                    let x = pos.xyz / pos.w;
                    let off = p - x;
                    let d2 = dot(off, off);
                    if (d2 <= 0.0) {
                        continue;
                    }
                    let w = off * inverseSqrt(d2);
                    let cos_p = -dot(n, w);
                    if (cos_p <= 0.0) {
                        continue;
                    }
                    let nrm = textureLoad(flux_normal, vec2<i32>(i, j), layer, k);
                    let rel = x - light.position;
                    let spread_sq = textureLoad(flux_spread, vec2<i32>(i, j), layer, k).r / pos.w - dot(rel, rel);
                    let spread = max(2.0 * spread_sq, flat);
                    let cos_d = max(dot(nrm.xyz, w), 0.0);
                    let n_s = nrm.xyz * inverseSqrt(max(dot(nrm.xyz, nrm.xyz), 1e-30));
                    let l_s = light_direction(light.kind, light.position, light.direction, x);
                    let reflected = nrm.w * boundary_specular(n_s, l_s, w, object.roughness, object.specular)
                        * max(dot(n_s, w), 0.0);
                    e += (object.albedo * cos_d + vec3<f32>(reflected)) * (cos_p / (PI * (d2 + spread)));
                }
            }
            if (last) {
                break;
            }
        }
        sum += colour * e;
    }
    return sum;
}

// The bounce at the lighting pass's pixel, interpolated from the transmitted map's bounce layer
// (fs_bounce): the bilinear 2 x 2 where all four texels lie on the pixel's surface (within
// the tolerance of its plane, transmitted_from_map's test). Elsewhere the 4 x 4 texels around the
// pixel, weighted by a tent two texels wide, where their surface lies within a quarter of the
// medium's decay length (at most 2.5 mm) of the pixel's own, extended as a plane, or within
// four times that of the pixel's depth; else the one nearest in depth (below). Wider than the
// bilinear 2 x 2 (the bounce changes over centimetres), so that a pixel beside a depth edge
// (the neck under the jaw, a finger's outline), whose nearest texels show the nearer
// surface, still finds its own: with 2 x 2 alone the jaw's outline drew a dark seam.
fn bounce_from_map(layer: u32, screen: ScreenSample) -> vec3<f32> {
    let size = vec2<i32>(textureDimensions(transmitted_map));
    let scale = vec2<f32>(size) / vec2<f32>(camera.viewport_x, camera.viewport_y);
    let pos = screen.xy * scale - 0.5;
    let base = vec2<i32>(floor(pos)) - vec2<i32>(1);
    let tolerance = LATERAL_DEPTH_TOLERANCE / max(object.lateral_decay, 0.1) * object.world_per_mm;
    // Inside a surface the four texels around the pixel all lie on it: their bilinear blend
    // serves, and the other twelve loads are left to the pixels that need them (on an H200 the
    // sixteen were a fifth of the lighting pass at 1920x1080; docs/lab/performance.md).
    let f = pos - floor(pos);
    var inner = vec3<f32>(0.0);
    var inside = true;
    for (var j = 1; j < 3; j++) {
        for (var i = 1; i < 3; i++) {
            let texel = base + vec2<i32>(i, j);
            let t = textureLoad(transmitted_map, clamp(texel, vec2<i32>(0), size - 1), layer, 0);
            let w = select(1.0 - f.x, f.x, i == 2) * select(1.0 - f.y, f.y, j == 2);
            inside = inside && all(texel >= vec2<i32>(0)) && all(texel < size) && t.w > 0.0
                && abs(t.w - plane_depth(screen, texel, scale)) <= tolerance;
            inner += t.rgb * w;
        }
    }
    if (inside) {
        return inner;
    }
    var sum = vec3<f32>(0.0);
    var weight = 0.0;
    var nearest = vec4<f32>(0.0, 0.0, 0.0, 16.0 * tolerance);
    for (var j = 0; j < 4; j++) {
        for (var i = 0; i < 4; i++) {
            let texel = base + vec2<i32>(i, j);
            if (any(texel < vec2<i32>(0)) || any(texel >= size)) {
                continue;
            }
            let t = textureLoad(transmitted_map, texel, layer, 0);
            let expected = plane_depth(screen, texel, scale);
            let gap = abs(t.w - screen.depth);
            if (t.w > 0.0 && gap < nearest.w) {
                nearest = vec4<f32>(t.rgb, gap);
            }
            if (t.w <= 0.0 || (abs(t.w - expected) > tolerance && gap > 4.0 * tolerance)) {
                continue;
            }
            let tent = max(vec2<f32>(0.0), vec2<f32>(1.0) - abs(vec2<f32>(texel) - pos) * 0.5);
            let w = tent.x * tent.y;
            sum += t.rgb * w;
            weight += w;
        }
    }
    if (weight > 1e-4) {
        return sum / weight;
    }
    // A grazing rim (the jaw's underside seen edge on) changes depth by more than that within
    // a texel: it takes the texel nearest its depth, up to 16 tolerances (14 mm for skin1),
    // less than a finger lies in front of a palm.
    return select(vec3<f32>(0.0), nearest.rgb, nearest.w < 16.0 * tolerance);
}

// The bounce pass (passes::bounce): the light the lit surfaces send each texel's surface
// across the air, gathered from the flux pyramid once per texel of the transmitted map's reduced
// grid, as the lateral taps are: it changes over millimetres. a = the texel's view depth.
@fragment
fn fs_bounce(in: LitVarying, @builtin(front_facing) front: bool) -> @location(0) vec4<f32> {
    let depth = dot(in.world - camera.position, camera.forward);
    return vec4<f32>(bounce_irradiance(in.world, oriented_normal(in, front)), depth);
}

// The bounce at the pixel: interpolated from the transmitted map's bounce layer on the pixel's own
// surface; gathered here only where there is no map (the skin too small on screen for one).
// Where the map has no texel of the pixel's surface (an outline, a depth edge) the pixel takes
// none: gathering there per pixel, like the lateral taps, doubled the lighting pass on
// lavapipe, which runs a loop's body for every pixel once some pixel enters it.
// Each source has its own pipeline (frame_plan.rs, `LightingVariant::bounce`): 0 none, 1 the map, 2 a
// gather per pixel; the default (the texture-space pass, which never calls this) keeps all.
override BOUNCE_SOURCE: u32 = FOLLOW_UNIFORM;

fn pixel_bounce(world: vec3<f32>, n_vertex: vec3<f32>, screen: ScreenSample) -> vec3<f32> {
    if (BOUNCE_SOURCE == BOUNCE_NONE || lights.bounce_ring == 0u) {
        return vec3<f32>(0.0);
    }
    if (BOUNCE_SOURCE == BOUNCE_MAP || (BOUNCE_SOURCE == FOLLOW_UNIFORM && lights.map_downsample > 1u)) {
        return bounce_from_map(lights.bounce_layer, screen);
    }
    return bounce_irradiance(world, n_vertex);
}
