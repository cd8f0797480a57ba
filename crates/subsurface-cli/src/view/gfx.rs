//! The viewer's GPU side ([`Gfx`]): choosing an adapter that can present to the window, the
//! surface's format and configuration, and the small pieces of the frame loop that only touch
//! the device (split-screen scissors, egui texture frees, a colour-only render pass).

use std::sync::{Arc, Mutex};

use anyhow::{Context, Result};
use subsurface_render::{GpuContext, Renderer};
use winit::event_loop::OwnedDisplayHandle;
use winit::window::Window;

/// Everything that lives on one device; dropped and rebuilt when the device is lost.
pub struct Gfx {
    pub ctx: GpuContext,
    pub surface: wgpu::Surface<'static>,
    pub config: wgpu::SurfaceConfiguration,
    /// Format of the swapchain view the renderers draw through (sRGB).
    pub scene_format: wgpu::TextureFormat,
    pub egui: egui_wgpu::Renderer,
    /// The main settings (the whole view, or left of the divider).
    pub a: Option<Renderer>,
    /// The comparison (right of the divider).
    pub b: Option<Renderer>,
    pub lost: Arc<Mutex<Option<String>>>,
}

async fn select_adapter(
    instance: &wgpu::Instance,
    surface: &wgpu::Surface<'_>,
) -> Result<wgpu::Adapter> {
    // The same environment variables as `render` (see GpuContext::new_headless), but the
    // adapter must also be able to present to this window.
    let wanted = std::env::var("WGPU_ADAPTER_NAME")
        .unwrap_or_default()
        .to_lowercase();
    if !wanted.is_empty() {
        for a in instance.enumerate_adapters(wgpu::Backends::all()).await {
            if a.get_info().name.to_lowercase().contains(&wanted) && a.is_surface_supported(surface)
            {
                return Ok(a);
            }
        }
        anyhow::bail!("no adapter named like WGPU_ADAPTER_NAME={wanted:?} can present to a window");
    }
    instance
        .request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::from_env()
                .unwrap_or(wgpu::PowerPreference::HighPerformance),
            force_fallback_adapter: false,
            compatible_surface: Some(surface),
            apply_limit_buckets: false,
        })
        .await
        .map_err(|e| anyhow::anyhow!("no GPU adapter can present to the window: {e}"))
}

impl Gfx {
    pub fn new(display: &OwnedDisplayHandle, window: Arc<Window>, vsync: bool) -> Result<Self> {
        let instance = wgpu::Instance::new(
            wgpu::InstanceDescriptor::new_with_display_handle_from_env(Box::new(display.clone())),
        );
        let surface = instance
            .create_surface(window.clone())
            .context("cannot create a surface for the window")?;
        let adapter = pollster::block_on(select_adapter(&instance, &surface))?;
        let ctx = GpuContext::from_adapter(instance, adapter)?;
        let caps = surface.get_capabilities(&ctx.adapter);
        // The tone map writes linear values and relies on an sRGB view to encode them (as the
        // PNG path does); egui wants a gamma-space target. Where the surface allows views of
        // another format, the swapchain is plain 8-bit and the 3D view draws through an sRGB
        // view of it; otherwise everything draws to an sRGB swapchain (egui copes, with a
        // warning).
        let view_formats_ok = ctx
            .adapter
            .get_downlevel_capabilities()
            .flags
            .contains(wgpu::DownlevelFlags::SURFACE_VIEW_FORMATS);
        let paired = caps
            .formats
            .iter()
            .copied()
            .find(|f| !f.is_srgb() && f.add_srgb_suffix() != *f)
            .filter(|_| view_formats_ok);
        let srgb = caps
            .formats
            .iter()
            .copied()
            .find(wgpu::TextureFormat::is_srgb);
        let (format, scene_format) = match (paired, srgb) {
            (Some(f), _) => (f, f.add_srgb_suffix()),
            (None, Some(f)) => (f, f),
            (None, None) => {
                let f = caps
                    .formats
                    .first()
                    .copied()
                    .context("the window's surface supports no format on this adapter")?;
                log::warn!("surface format {f:?} is not sRGB: the view will look too dark");
                (f, f)
            }
        };
        let size = window.inner_size();
        let config = wgpu::SurfaceConfiguration {
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
            format,
            width: size.width.max(1),
            height: size.height.max(1),
            present_mode: if vsync {
                wgpu::PresentMode::AutoVsync
            } else {
                wgpu::PresentMode::AutoNoVsync
            },
            desired_maximum_frame_latency: 2,
            alpha_mode: caps
                .alpha_modes
                .first()
                .copied()
                .unwrap_or(wgpu::CompositeAlphaMode::Auto),
            view_formats: if scene_format != format {
                vec![scene_format]
            } else {
                vec![]
            },
            color_space: Default::default(),
        };
        surface.configure(&ctx.device, &config);
        let lost = Arc::new(Mutex::new(None));
        let sink = lost.clone();
        ctx.device.set_device_lost_callback(move |reason, msg| {
            if let Ok(mut l) = sink.lock() {
                *l = Some(if msg.is_empty() {
                    format!("{reason:?}")
                } else {
                    format!("{reason:?}: {msg}")
                });
            }
        });
        let egui = egui_wgpu::Renderer::new(&ctx.device, format, Default::default());
        ctx.check()?;
        Ok(Self {
            ctx,
            surface,
            config,
            scene_format,
            egui,
            a: None,
            b: None,
            lost,
        })
    }

    pub fn configure(&mut self, width: u32, height: u32) {
        self.config.width = width;
        self.config.height = height;
        self.surface.configure(&self.ctx.device, &self.config);
    }

    /// Left/right scissors for the split screen; an empty side is `None`.
    pub fn split(&self, split: f32) -> (Option<[u32; 4]>, Option<[u32; 4]>) {
        let (w, h) = (self.config.width, self.config.height);
        let xs = split_px(split, w);
        (
            (xs > 0).then_some([0, 0, xs, h]),
            (xs < w).then_some([xs, 0, w - xs, h]),
        )
    }
}

/// The divider's column for a split at fraction `split` of `width` pixels.
pub fn split_px(split: f32, width: u32) -> u32 {
    ((split.clamp(0.0, 1.0) * width as f32).round() as u32).min(width)
}

/// Frees egui's textures that a frame's output released.
pub fn free_textures<'a>(g: &mut Gfx, free: impl IntoIterator<Item = &'a egui::TextureId>) {
    for id in free {
        g.egui.free_texture(id);
    }
}

/// A render pass drawing into `view` alone, which it first loads or clears as `load` says.
pub fn color_pass<'e>(
    encoder: &'e mut wgpu::CommandEncoder,
    label: &str,
    view: &wgpu::TextureView,
    load: wgpu::LoadOp<wgpu::Color>,
) -> wgpu::RenderPass<'e> {
    encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some(label),
        color_attachments: &[subsurface_render::passes::util::color_attachment(
            view, load,
        )],
        depth_stencil_attachment: None,
        timestamp_writes: None,
        occlusion_query_set: None,
        multiview_mask: None,
    })
}
