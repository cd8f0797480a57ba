// Transmitted light pass: the light that crosses thin parts (transmittance.wgsl), evaluated per
// pixel from a caller's G-buffer rather than inside our lighting pass, and added to the
// caller's diffuse target before the SSS blur (000_*: transmitted light joins the reflected
// light and is blurred with it) and, for `diffusion`'s unscattered part, to its specular target.
// With BOUNCE_SOURCE = BOUNCE_GATHER, also the bounce (bounce.wgsl): light from the lit
// surfaces around, which enters and diffuses as the lights' own does.
// Drawn once per medium: group 1 is the medium's (`object`), and each draw keeps the pixels of
// its own profile row.

struct SkinView {
    inverse_view_proj: mat4x4<f32>,
};

// Group 2: the caller's G-buffer. Bindings from 16 up, apart from the texture-space maps the
// lighting shader declares in the same group (lighting.wgsl), which this entry point never reads.
@group(2) @binding(16) var<uniform> skin_view: SkinView;
// Linear view depth in scene units, along camera.forward (as the SSS pass reads it).
@group(2) @binding(17) var gbuffer_depth: texture_2d<f32>;
// xyz: the surface's interpolated vertex normal in world space, turned toward the camera.
@group(2) @binding(18) var gbuffer_normal: texture_2d<f32>;
// rgb: the linear albedo the caller multiplies its diffuse light by.
@group(2) @binding(19) var gbuffer_albedo: texture_2d<f32>;
// The SSS pass's input: strength (0 = not skin), scene units per profile mm, profile row.
@group(2) @binding(20) var gbuffer_medium: texture_2d<f32>;

struct TransmittedOut {
    @location(0) diffuse: vec4<f32>,
    @location(1) specular: vec4<f32>,
};

@fragment
fn fs_deferred_transmitted(@builtin(position) frag: vec4<f32>) -> TransmittedOut {
    let texel = vec2<i32>(frag.xy);
    let medium = textureLoad(gbuffer_medium, texel, 0);
    if (!(medium.x > 0.0) || u32(medium.z + 0.5) != object.profile) {
        discard;
    }
    // The pixel's centre on the far plane gives its ray; the depth is measured along
    // camera.forward, as the lighting pass writes it.
    let ndc = vec2<f32>(frag.x / camera.viewport_x * 2.0 - 1.0, 1.0 - frag.y / camera.viewport_y * 2.0);
    let far = skin_view.inverse_view_proj * vec4<f32>(ndc, 1.0, 1.0);
    let ray = far.xyz / far.w - camera.position;
    let depth = textureLoad(gbuffer_depth, texel, 0).r;
    let world = camera.position + ray * (depth / dot(ray, camera.forward));
    let n_vertex = normalize(textureLoad(gbuffer_normal, texel, 0).xyz);
    let albedo = textureLoad(gbuffer_albedo, texel, 0).rgb;
    let v = normalize(camera.position - world);
    var diffuse = vec3<f32>(0.0);
    var specular = vec3<f32>(0.0);
    // Without a method that transmits here, the pass draws for the bounce alone.
    let transmits = TRANSMITTANCE_METHOD != TRANSMITTANCE_OFF && TRANSMITTANCE_METHOD != TRANSMITTANCE_TSM;
    let count = select(0u, min(lights.count, MAX_LIGHTS), transmits);
    for (var i = 0u; i < count; i++) {
        let t = radiant_transmittance(i, world, n_vertex, v, -1.0);
        diffuse += t.diffuse;
        specular += t.ballistic;
    }
    if (BOUNCE_SOURCE == BOUNCE_GATHER) {
        diffuse += bounce_irradiance(world, n_vertex);
    }
    var out: TransmittedOut;
    out.diffuse = vec4<f32>(min(albedo * diffuse, vec3<f32>(HALF_MAX)), 1.0);
    out.specular = vec4<f32>(min(specular, vec3<f32>(HALF_MAX)), 1.0);
    return out;
}
