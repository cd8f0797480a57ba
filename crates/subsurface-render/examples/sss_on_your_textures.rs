//! Using the screen-space SSS pass from your own wgpu application, on your own textures.
//!
//! This program does not use `Renderer`: it draws an analytic "skin ball" with its own small
//! WGSL pipeline into three render targets (diffuse radiance, linear depth, SSS strength and
//! scale), then hands them to `SssPass`, which only needs a `&wgpu::Device` and a
//! `&wgpu::Queue`. It writes the image before and after scattering as PNGs.
//!
//! ```text
//! cargo run -p subsurface-render --example sss_on_your_textures -- [METHOD] [OUT_DIR]
//! ```
//! METHOD is separable (default), gaussian6 or hable13; OUT_DIR defaults to the current one.

use std::error::Error;
use std::path::PathBuf;

use subsurface_profile::{KernelParams, ScreenKernels};
use subsurface_render::passes::sss::{self, SssInputs, SssPass};
use subsurface_render::passes::{fullscreen, util};
use subsurface_render::{GpuContext, RenderError, SssMethod, SssSettings, readback};

const WIDTH: u32 = 640;
const HEIGHT: u32 = 480;
const FOV_Y_DEG: f32 = 35.0;
/// Close-up: left and top of the source rectangle, and the size of each zoomed half.
const ZOOM: (u32, u32, u32, u32) = (245, 215, 480, 360);

/// Camera at the origin looking down -z (y up). A ball of radius 0.1 m, 0.4 m away, lit by a
/// directional light; an occluder outside the frame casts a hard-edged shadow on it, so
/// the terminator, the shadow edge and the freckles show what scattering does.
const SCENE_WGSL: &str = r#"
const CENTRE = vec3<f32>(0.0, 0.0, -0.4);
const RADIUS: f32 = 0.1;
const LIGHT_DIR = vec3<f32>(-0.62, 0.45, 0.64); // towards the light, normalised below
const OCCLUDER_RADIUS: f32 = 0.02;

struct Targets {
    @location(0) diffuse: vec4<f32>, // linear HDR radiance
    @location(1) depth: f32,         // linear view depth in scene units
    @location(2) sss: vec4<f32>,     // SSS strength, scene units per millimetre, profile row
};

// Distance along the ray (origin o, unit direction d) to a sphere, or -1 on a miss.
fn hit_sphere(o: vec3<f32>, d: vec3<f32>, c: vec3<f32>, r: f32) -> f32 {
    let oc = o - c;
    let b = dot(oc, d);
    let disc = b * b - (dot(oc, oc) - r * r);
    if (disc < 0.0) {
        return -1.0;
    }
    return -b - sqrt(disc);
}

fn hash3(p: vec3<f32>) -> vec3<f32> {
    let q = vec3<f32>(dot(p, vec3<f32>(127.1, 311.7, 74.7)), dot(p, vec3<f32>(269.5, 183.3, 246.1)),
                      dot(p, vec3<f32>(113.5, 271.9, 124.6)));
    return fract(sin(q) * 43758.5453);
}

@fragment
fn fs_main(@builtin(position) frag: vec4<f32>) -> Targets {
    let ndc = vec2<f32>(2.0 * frag.x / SIZE.x - 1.0, 1.0 - 2.0 * frag.y / SIZE.y);
    let scale = TAN_HALF_FOV * vec2<f32>(SIZE.x / SIZE.y, 1.0);
    let dir = normalize(vec3<f32>(ndc * scale, -1.0));
    var out: Targets;
    let t = hit_sphere(vec3<f32>(0.0), dir, CENTRE, RADIUS);
    if (t < 0.0) {
        // Background: a checkerboard that is not skin (strength 0) and far away.
        let check = (u32(frag.x / 32.0) + u32(frag.y / 32.0)) % 2u;
        out.diffuse = vec4<f32>(vec3<f32>(0.12, 0.16, 0.22) * (1.0 + f32(check)), 1.0);
        out.depth = 1000.0;
        out.sss = vec4<f32>(0.0);
        return out;
    }
    let p = t * dir;
    let n = normalize(p - CENTRE);
    let l = normalize(LIGHT_DIR);
    // Hard shadow: does the ray towards the light hit an occluder (not drawn, out of frame)
    // placed so that its shadow falls on the front of the ball, just right of centre?
    let occluder = CENTRE + RADIUS * normalize(vec3<f32>(0.25, -0.1, 1.0)) + 0.5 * l;
    let shadow = select(1.0, 0.0, hit_sphere(p, l, occluder, OCCLUDER_RADIUS) > 0.0);
    // Freckles: one jittered dot per cell of a 3-D grid on the unit sphere (isotropic).
    let q = n * 14.0;
    let cell = floor(q);
    let h = hash3(cell);
    let spot = cell + 0.3 + 0.4 * h;
    let freckle = select(0.0, 1.0, h.x > 0.45 && length(q - spot) < 0.12 + 0.1 * h.y);
    let albedo = mix(vec3<f32>(0.78, 0.52, 0.42), vec3<f32>(0.42, 0.2, 0.13), freckle);
    let light = 1.6 * max(dot(n, l), 0.0) * shadow + 0.04;
    out.diffuse = vec4<f32>(albedo * light, 1.0);
    out.depth = -p.z;
    // The ball is modelled in metres, so one profile millimetre is 0.001 scene units.
    // Profile row 0 of the table given to the pass (skin).
    out.sss = vec4<f32>(1.0, 0.001, 0.0, 0.0);
    return out;
}
"#;

fn main() -> Result<(), Box<dyn Error>> {
    let mut method = SssMethod::Separable;
    let mut out_dir = PathBuf::from(".");
    for arg in std::env::args().skip(1) {
        match arg.as_str() {
            "separable" => method = SssMethod::Separable,
            "gaussian6" => method = SssMethod::Gaussian6,
            "hable13" => method = SssMethod::Hable13,
            _ => out_dir = PathBuf::from(arg),
        }
    }
    std::fs::create_dir_all(&out_dir)?;

    // Any device will do; this helper just picks an adapter from WGPU_BACKEND etc. and turns
    // validation errors into `check()` failures. From here on only `device` and `queue` are
    // used, as they would be in an application that made its own.
    let ctx = GpuContext::new_headless()?;
    let (device, queue) = (&ctx.device, &ctx.queue);
    println!("adapter: {}", ctx.adapter_name());

    // The application's own targets. The diffuse texture is the one SssPass blurs in place,
    // so it needs TEXTURE_BINDING and RENDER_ATTACHMENT (and COPY_SRC for some methods).
    let target = |label, format| {
        util::texture_2d(
            device,
            label,
            WIDTH,
            HEIGHT,
            1,
            format,
            wgpu::TextureUsages::RENDER_ATTACHMENT
                | wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::COPY_SRC,
        )
    };
    let diffuse = target("diffuse", sss::FORMAT); // Rgba16Float
    let depth = target("linear depth", wgpu::TextureFormat::R32Float);
    let sss_params = target(
        "sss strength/scale/profile",
        wgpu::TextureFormat::Rgba16Float,
    );
    let view = |t: &wgpu::Texture| t.create_view(&Default::default());
    let (diffuse_view, depth_view, sss_view) = (view(&diffuse), view(&depth), view(&sss_params));

    // Our own pipeline: a full-screen triangle whose fragment shader ray-casts the scene. The
    // image size and field of view are baked in as WGSL constants to avoid a uniform buffer;
    // the library's `vs_fullscreen` draws the triangle.
    let tan_half_fov = (0.5 * FOV_Y_DEG.to_radians()).tan();
    let source = format!(
        "const SIZE = vec2<f32>({WIDTH}.0, {HEIGHT}.0);\n\
         const TAN_HALF_FOV: f32 = {tan_half_fov:?};\n{}{SCENE_WGSL}",
        fullscreen::VERTEX_WGSL
    );
    let module = util::wgsl_module(device, "skin ball", &source);
    let pipeline = fullscreen::pipeline(
        device,
        &module,
        None, // no bindings: the derived layout is empty
        "fs_main",
        &[
            Some(diffuse.format().into()),
            Some(depth.format().into()),
            Some(sss_params.format().into()),
        ],
    );

    let mut encoder = device.create_command_encoder(&Default::default());
    {
        // The triangle writes every pixel; Clear only says the old contents are not needed.
        let attach = |v| util::color_attachment(v, wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT));
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("skin ball"),
            color_attachments: &[
                attach(&diffuse_view),
                attach(&depth_view),
                attach(&sss_view),
            ],
            depth_stencil_attachment: None,
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(&pipeline);
        pass.draw(0..3, 0..1);
    }
    queue.submit([encoder.finish()]);
    ctx.check()?;
    let (before, _) = readback::read_float(&ctx, &diffuse)?;

    // The library part (below): SssPass needs only the device, the queue and our textures.
    let focal_px = 0.5 * HEIGHT as f32 / tan_half_fov;
    scatter(
        device,
        queue,
        method,
        &diffuse,
        &depth_view,
        &sss_view,
        focal_px,
    )?;
    ctx.check()?;
    let (after, _) = readback::read_float(&ctx, &diffuse)?;

    // Only skin (strength > 0) may change: the background must come back bit for bit.
    let (strength, channels) = readback::read_float(&ctx, &sss_params)?;
    let change = |i: usize| -> f32 {
        (0..3)
            .map(|c| (after[4 * i + c] - before[4 * i + c]).abs())
            .sum()
    };
    let (skin, background): (Vec<usize>, Vec<usize>) =
        (0..strength.len() / channels).partition(|&i| strength[channels * i] > 0.0);
    let skin_mean = skin.iter().map(|&i| change(i)).sum::<f32>() / (3 * skin.len()) as f32;
    let background_max = background.iter().map(|&i| change(i)).fold(0.0, f32::max);
    println!(
        "{}: ball mean |change| {skin_mean:.4} ({} px), background max |change| {background_max}",
        method.name(),
        skin.len()
    );
    if background_max != 0.0 {
        return Err("the pass changed pixels that are not skin".into());
    }

    // The blur is a few millimetres, a few pixels here: also write a 4x close-up of the
    // shadow edge and freckles, before on the left and after on the right.
    let (before, after) = (to_srgb8(&before), to_srgb8(&after));
    let mut zoom = image::RgbImage::new(2 * ZOOM.2, ZOOM.3);
    for (x, image) in [(0, &before), (ZOOM.2, &after)] {
        let crop = image::imageops::crop_imm(image, ZOOM.0, ZOOM.1, ZOOM.2 / 4, ZOOM.3 / 4);
        let big = image::imageops::resize(&*crop, ZOOM.2, ZOOM.3, image::imageops::Nearest);
        image::imageops::replace(&mut zoom, &big, x as i64, 0);
    }
    for (name, image) in [
        ("sss_before.png".to_string(), &before),
        (format!("sss_after_{}.png", method.name()), &after),
        (format!("sss_zoom_{}.png", method.name()), &zoom),
    ] {
        let path = out_dir.join(name);
        image.save(&path)?;
        println!("wrote {}", path.display());
    }
    Ok(())
}

/// Applies SSS in place on `diffuse`. In an application, build the pass once with a profile
/// table (one row per material; each pixel's SSS texture names its row), `resize` it after a
/// resize, `prepare` it when the projection changes, and `encode` every frame.
fn scatter(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    method: SssMethod,
    diffuse: &wgpu::Texture,
    depth: &wgpu::TextureView,
    sss: &wgpu::TextureView,
    focal_px: f32,
) -> Result<(), RenderError> {
    let settings = SssSettings {
        method,
        ..Default::default()
    };
    let skin = ScreenKernels::skin(&KernelParams {
        samples: settings.samples,
        ..Default::default()
    })?;
    let mut pass = SssPass::new(device, &settings, &[skin])?;
    pass.resize(
        device,
        &SssInputs {
            diffuse,
            depth,
            sss,
        },
    );
    pass.prepare(queue, focal_px); // 0.5 * height / tan(fov_y / 2)
    let mut encoder = device.create_command_encoder(&Default::default());
    pass.encode(&mut encoder, None); // `diffuse` now holds the scattered radiance
    queue.submit([encoder.finish()]);
    Ok(())
}

/// Reinhard tone map then the sRGB transfer curve; enough to look at HDR radiance.
fn to_srgb8(rgba: &[f32]) -> image::RgbImage {
    let encode = |x: f32| {
        let v = (x / (1.0 + x)).clamp(0.0, 1.0);
        let s = if v <= 0.003_130_8 {
            12.92 * v
        } else {
            1.055 * v.powf(1.0 / 2.4) - 0.055
        };
        (s * 255.0 + 0.5) as u8
    };
    let pixels = rgba
        .chunks_exact(4)
        .flat_map(|p| [encode(p[0]), encode(p[1]), encode(p[2])])
        .collect();
    image::RgbImage::from_raw(WIDTH, HEIGHT, pixels).expect("buffer matches the image size")
}
