// The example renderer's own shaders (skin_in_your_renderer.rs): a depth-only shadow pass, a
// G-buffer pre-pass and a forward pass (Lambert diffuse, a Beckmann specular lobe, 3x3
// percentage-closer shadows). Nothing here is the library's.

struct View {
    view_proj: mat4x4<f32>,
    position: vec4<f32>,
    forward: vec4<f32>,
};

struct Light {
    position: vec4<f32>,  // xyz, w = kind (0 point, 1 spot, 2 directional)
    direction: vec4<f32>, // xyz light -> target, w = first shadow layer (-1: none)
    color: vec4<f32>,     // rgb, w = shadow bias
    cone: vec4<f32>,      // cos outer, cos inner, shadow map texels, atlas texels
    view_proj: mat4x4<f32>,
};

struct Lights {
    count: vec4<u32>,
    ambient: vec4<f32>,
    lights: array<Light, 8>,
};

struct Material {
    model: mat4x4<f32>,
    normal_matrix: mat4x4<f32>,
    albedo: vec4<f32>,
    params: vec4<f32>, // roughness, specular, eta, SSS strength
    sss: vec4<f32>,    // scene units per profile mm, profile row
};

@group(0) @binding(0) var<uniform> view: View;
@group(0) @binding(1) var<uniform> lights: Lights;
@group(0) @binding(2) var shadow_maps: texture_depth_2d_array;
@group(0) @binding(3) var shadow_sampler: sampler_comparison;
@group(1) @binding(0) var<uniform> material: Material;

struct VertexIn {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
};

struct Varying {
    @builtin(position) @invariant clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
};

@vertex
fn vs_main(v: VertexIn) -> Varying {
    var out: Varying;
    let world = material.model * vec4<f32>(v.position, 1.0);
    out.world = world.xyz;
    out.clip = view.view_proj * world;
    out.normal = (material.normal_matrix * vec4<f32>(v.normal, 0.0)).xyz;
    return out;
}

@vertex
fn vs_shadow(v: VertexIn) -> @builtin(position) vec4<f32> {
    return view.view_proj * material.model * vec4<f32>(v.position, 1.0);
}

struct GBuffer {
    @location(0) normal: vec4<f32>,
    @location(1) albedo: vec4<f32>,
};

fn facing_normal(in: Varying, front: bool) -> vec3<f32> {
    let n = normalize(in.normal);
    return select(-n, n, front);
}

@fragment
fn fs_gbuffer(in: Varying, @builtin(front_facing) front: bool) -> GBuffer {
    var out: GBuffer;
    out.normal = vec4<f32>(facing_normal(in, front), 0.0);
    out.albedo = material.albedo;
    return out;
}

fn shadow(light: Light, p: vec3<f32>, l: vec3<f32>) -> f32 {
    if (light.direction.w < 0.0) {
        return 1.0;
    }
    let clip = light.view_proj * vec4<f32>(p + l * light.color.w, 1.0);
    let ndc = clip.xyz / clip.w;
    let share = light.cone.z / light.cone.w;
    let uv = (ndc.xy * vec2<f32>(0.5, -0.5) + vec2<f32>(0.5)) * share;
    let texel = 1.0 / light.cone.w;
    var lit = 0.0;
    for (var j = -1; j <= 1; j++) {
        for (var i = -1; i <= 1; i++) {
            let at = uv + vec2<f32>(f32(i), f32(j)) * texel;
            lit += textureSampleCompareLevel(shadow_maps, shadow_sampler, at, i32(light.direction.w), min(ndc.z, 1.0));
        }
    }
    return lit / 9.0;
}

fn beckmann(ndoth: f32, m: f32) -> f32 {
    let c2 = max(ndoth * ndoth, 1e-4);
    return exp(-(1.0 - c2) / (c2 * m * m)) / (m * m * c2 * c2);
}

fn smith_g1(c: f32, m: f32) -> f32 {
    let a = c / (m * sqrt(max(1.0 - c * c, 1e-8)));
    return select((3.535 * a + 2.181 * a * a) / (1.0 + 2.276 * a + 2.577 * a * a), 1.0, a >= 1.6);
}

fn specular(n: vec3<f32>, l: vec3<f32>, v: vec3<f32>) -> f32 {
    let m = material.params.x;
    let ndotl = dot(n, l);
    let ndotv = dot(n, v);
    if (ndotl <= 0.0 || ndotv <= 0.0) {
        return 0.0;
    }
    let h = normalize(l + v);
    let r = (material.params.z - 1.0) / (material.params.z + 1.0);
    let e = pow(1.0 - clamp(dot(v, h), 0.0, 1.0), 5.0);
    let fresnel = e + r * r * (1.0 - e);
    let g = smith_g1(clamp(ndotv, 1e-4, 1.0), m) * smith_g1(clamp(ndotl, 1e-4, 1.0), m);
    return material.params.y * beckmann(max(dot(n, h), 0.0), m) * fresnel * g / (4.0 * ndotv);
}

struct Lit {
    @location(0) diffuse: vec4<f32>,
    @location(1) specular: vec4<f32>,
    @location(2) depth: f32,
    @location(3) sss: vec4<f32>,
};

@fragment
fn fs_forward(in: Varying, @builtin(front_facing) front: bool) -> Lit {
    let n = facing_normal(in, front);
    let v = normalize(view.position.xyz - in.world);
    var irradiance = lights.ambient.rgb;
    var spec = vec3<f32>(0.0);
    for (var i = 0u; i < lights.count.x; i++) {
        let light = lights.lights[i];
        var l = -light.direction.xyz;
        var radiance = light.color.rgb;
        if (light.position.w != 2.0) {
            let to_light = light.position.xyz - in.world;
            l = normalize(to_light);
            radiance /= max(dot(to_light, to_light), 1e-8);
        }
        if (light.position.w == 1.0) {
            radiance *= smoothstep(light.cone.x, light.cone.y, dot(-l, light.direction.xyz));
        }
        let s = shadow(light, in.world, l);
        irradiance += radiance * s * max(dot(n, l), 0.0);
        spec += radiance * s * specular(n, l, v);
    }
    var out: Lit;
    out.diffuse = vec4<f32>(material.albedo.rgb * irradiance, 1.0);
    out.specular = vec4<f32>(spec, 1.0);
    out.depth = dot(in.world - view.position.xyz, view.forward.xyz);
    out.sss = vec4<f32>(material.params.w, material.sss.x, material.sss.y, 0.0);
    return out;
}
