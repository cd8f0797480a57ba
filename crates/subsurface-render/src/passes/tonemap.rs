//! Composite (diffuse after subsurface scattering + specular) and filmic tone mapping into an
//! sRGB target. Usable on its own: give it your own radiance textures.

use wgpu::util::DeviceExt;

use crate::passes::util;
use crate::timing::TimedPass;

/// The tone-map pass's WGSL: the full-screen triangle and tonemap.wgsl.
pub const SHADER: &str = concat!(
    include_str!("fullscreen.wgsl"),
    include_str!("tonemap.wgsl")
);
/// The output format the renderer uses for PNGs.
pub const OUTPUT_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;

/// What the final image shows: the composite, or one of the SSS inputs for debugging.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum DebugView {
    /// The tone-mapped composite: diffuse after SSS plus specular, in sRGB.
    #[default]
    Final,
    /// SSS strength mask (white = skin)
    Mask,
    /// Linear depth, divided by the camera's far plane
    Depth,
    /// Diffuse radiance after SSS
    Diffuse,
    /// Diffuse radiance before SSS (the SSS passes are skipped)
    DiffuseBeforeSss,
    /// Specular radiance only
    Specular,
    /// Thickness the transmittance sees (000_*): distance from where each shadowed light
    /// behind the surface enters the object to the shaded point, in millimetres of the
    /// profile, the thinnest over those lights; a colour ramp from white (0 mm) through yellow
    /// and red to black (`THICKNESS_RANGE_MM` and beyond). Grey: skin that no shadowed light
    /// behind it reaches. The SSS passes are skipped.
    Thickness,
    /// The irradiance that is blurred: with texture-space diffusion, the UV-space irradiance
    /// map of the first skin object (d'Eon 2007), letterboxed; with screen-space methods, the
    /// lit image before the blur (as `DiffuseBeforeSss`).
    Irradiance,
}

/// Thickness shown as black by `DebugView::Thickness`, in profile millimetres: skin's
/// transmittance is negligible beyond it (T(8 mm) < 1e-3 for every channel).
pub const THICKNESS_RANGE_MM: f32 = 8.0;

impl DebugView {
    fn code(self) -> f32 {
        match self {
            DebugView::Final => 0.0,
            DebugView::Mask => 1.0,
            DebugView::Depth => 2.0,
            DebugView::Diffuse | DebugView::DiffuseBeforeSss => 3.0,
            DebugView::Specular => 4.0,
            DebugView::Thickness => 5.0,
            DebugView::Irradiance => 3.0,
        }
    }

    /// Whether the SSS passes run for this view (they would blur what it shows).
    pub fn blurs(self) -> bool {
        !matches!(
            self,
            DebugView::DiffuseBeforeSss | DebugView::Thickness | DebugView::Irradiance
        )
    }
}

/// Texture views the tone-map pass reads (all the same size as the output).
pub struct ToneMapInputs<'a> {
    /// Linear diffuse radiance, any float format.
    pub diffuse: &'a wgpu::TextureView,
    /// Linear specular radiance, any float format.
    pub specular: &'a wgpu::TextureView,
    /// Linear depth (R32Float), only read by the depth debug view.
    pub depth: &'a wgpu::TextureView,
    /// SSS strength (R of an R/Rg float texture), only read by the mask debug view.
    pub sss: &'a wgpu::TextureView,
}

/// Composites diffuse (after SSS) and specular radiance, applies exposure and Hable's filmic curve,
/// and writes sRGB (or a debug view).
pub struct ToneMapPass {
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
    params: wgpu::Buffer,
}

impl ToneMapPass {
    /// `output_format` is the format of the view given to `encode` (e.g. a swapchain format).
    pub fn new(device: &wgpu::Device, output_format: wgpu::TextureFormat) -> Self {
        let module = util::wgsl_module(device, "tonemap.wgsl", SHADER);
        let (layout, pipeline_layout) =
            util::image_pass_layouts(device, "tonemap", 0, &[1, 2, 3, 4]);
        let pipeline = super::fullscreen::pipeline(
            device,
            &module,
            Some(&pipeline_layout),
            "fs_main",
            &[Some(output_format.into())],
        );
        let params = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("tonemap params"),
            contents: bytemuck::cast_slice(&[1.0f32, 0.0, 1.0, 0.0]),
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        });
        Self {
            pipeline,
            layout,
            params,
        }
    }

    /// Builds the bind group for a set of inputs; keep it while the inputs live.
    pub fn bind(&self, device: &wgpu::Device, inputs: &ToneMapInputs<'_>) -> wgpu::BindGroup {
        util::image_pass_bind_group(
            device,
            "tonemap",
            &self.layout,
            (0, &self.params),
            &[
                (1, inputs.diffuse),
                (2, inputs.specular),
                (3, inputs.depth),
                (4, inputs.sss),
            ],
        )
    }

    /// Sets exposure (in EV), the debug view and the far plane (for the depth view).
    pub fn set_params(&self, queue: &wgpu::Queue, exposure_ev: f32, view: DebugView, far: f32) {
        self.set_params_with(queue, exposure_ev, view, far, false);
    }

    /// As `set_params`; with `letterbox`, the bound `diffuse` may be any size (a UV-space
    /// map) and is shown as a centred square, the rest black, whatever the view.
    pub fn set_params_with(
        &self,
        queue: &wgpu::Queue,
        exposure_ev: f32,
        view: DebugView,
        far: f32,
        letterbox: bool,
    ) {
        let flags = if letterbox { 1.0 } else { 0.0 };
        queue.write_buffer(
            &self.params,
            0,
            bytemuck::cast_slice(&[exposure_ev.exp2(), view.code(), far, flags]),
        );
    }

    /// Draws the whole of `output` from the inputs of `bind_group`, timed as "tonemap".
    pub fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        bind_group: &wgpu::BindGroup,
        output: &wgpu::TextureView,
        profiler: Option<&wgpu_profiler::GpuProfiler>,
    ) {
        self.encode_scissored(encoder, bind_group, output, None, profiler);
    }

    /// As `encode`, writing only the `scissor` rectangle [x, y, w, h] (the rest of `output`
    /// is kept) when one is given.
    pub fn encode_scissored(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        bind_group: &wgpu::BindGroup,
        output: &wgpu::TextureView,
        scissor: Option<[u32; 4]>,
        profiler: Option<&wgpu_profiler::GpuProfiler>,
    ) {
        let timer = TimedPass::begin(profiler, "tonemap", encoder);
        {
            let load = if scissor.is_some() {
                wgpu::LoadOp::Load
            } else {
                wgpu::LoadOp::Clear(wgpu::Color::BLACK)
            };
            let mut pass = util::color_pass(
                encoder,
                "tonemap",
                &[util::color_attachment(output, load)],
                timer.writes(),
            );
            pass.set_pipeline(&self.pipeline);
            pass.set_bind_group(0, bind_group, &[]);
            if let Some([x, y, w, h]) = scissor {
                pass.set_scissor_rect(x, y, w, h);
            }
            pass.draw(0..3, 0..1);
        }
        timer.end(profiler, encoder);
    }
}
