//! The window and the frame loop (winit's `ApplicationHandler`); what lives on the GPU device
//! is in `gfx`.
//!
//! Errors never panic: while a device exists they go to the panel; when there is none (it
//! was lost) the viewer retries every two seconds. In scripted mode (`--frames`) any error
//! ends the run with a non-zero exit instead.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use subsurface_render::Renderer;
use wgpu::CurrentSurfaceTexture;
use winit::application::ApplicationHandler;
use winit::dpi::PhysicalSize;
use winit::event::WindowEvent;
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop, OwnedDisplayHandle};
use winit::window::{Window, WindowId};

use super::gfx::{Gfx, color_pass, free_textures, split_px};
use super::model::{Level, Model};
use super::panel::{self, Action, Viewport};
use crate::output::PendingFile;

/// `--frames N` and what to write after the last frame.
pub struct Script {
    pub frames: u32,
    pub screenshot: Option<PendingFile>,
    pub save_scene: Option<PathBuf>,
    pub lose_device_at: Option<u32>,
    /// `--soak`: edits every frame and measures growth (`soak.rs`).
    pub soak: Option<super::soak::Soak>,
}

pub struct App {
    model: Model,
    display: OwnedDisplayHandle,
    initial_size: winit::dpi::Size,
    vsync: bool,
    script: Option<Script>,
    window: Option<Arc<Window>>,
    egui: Option<(egui::Context, egui_winit::State)>,
    gfx: Option<Gfx>,
    /// When to try creating a device again after a failure.
    retry_at: Option<Instant>,
    /// A device loss we caused (--lose-device-at, the diagnostics button): not an error.
    simulated_loss: bool,
    last_frame: Instant,
    presented: u32,
    frames_since_check: u32,
    failure: Option<anyhow::Error>,
    /// `--soak`'s minimised window: the redraws skipped while winit would report 0x0. X11
    /// cannot make a window 0x0 (Windows and Wayland report a minimised one so), so the soak
    /// stands in for it at the one place the viewer reads the window's size.
    minimised: Option<u32>,
    /// Loaded once: egui contexts are recreated with the device.
    fonts: Option<egui::FontDefinitions>,
}

impl App {
    pub fn new(
        model: Model,
        event_loop: &EventLoop<()>,
        initial_size: winit::dpi::Size,
        vsync: bool,
        script: Option<Script>,
    ) -> Self {
        let mut model = model;
        let fonts = match super::fonts::definitions() {
            Ok(f) => Some(f),
            Err(e) => {
                log::warn!("{e}");
                model.error(e);
                None
            }
        };
        Self {
            model,
            display: event_loop.owned_display_handle(),
            initial_size,
            vsync,
            script,
            window: None,
            egui: None,
            gfx: None,
            retry_at: None,
            simulated_loss: false,
            last_frame: Instant::now(),
            presented: 0,
            frames_since_check: 0,
            failure: None,
            minimised: None,
            fonts,
        }
    }

    /// After the event loop: the scripted run's outcome (interactive runs end with Ok).
    pub fn finish(mut self) -> Result<()> {
        if let Some(e) = self.failure.take() {
            return Err(e);
        }
        if let Some(s) = &self.script {
            anyhow::ensure!(
                self.presented >= s.frames,
                "the window closed after {} of {} frames",
                self.presented,
                s.frames
            );
        }
        Ok(())
    }

    /// The window's drawable size: 0x0 while the soak holds it minimised.
    fn window_size(&self, window: &Window) -> PhysicalSize<u32> {
        match self.minimised {
            Some(_) => PhysicalSize::new(0, 0),
            None => window.inner_size(),
        }
    }

    /// Tells egui the window's size changed, as winit's `Resized` does.
    fn resized(&mut self, window: &Window, size: PhysicalSize<u32>) {
        if let Some((_, state)) = self.egui.as_mut() {
            let _ = state.on_window_event(window, &WindowEvent::Resized(size));
        }
    }

    fn scripted(&self) -> bool {
        self.script.is_some()
    }

    /// Ends a scripted run with `e`; interactive runs show it in the panel.
    fn report(&mut self, event_loop: &ActiveEventLoop, e: anyhow::Error) {
        if self.scripted() {
            if self.failure.is_none() {
                self.failure = Some(e);
            }
            event_loop.exit();
        } else {
            self.model.error(format!("{e:#}"));
        }
    }

    fn new_egui(
        window: &Window,
        max_texture_side: usize,
        fonts: Option<&egui::FontDefinitions>,
    ) -> (egui::Context, egui_winit::State) {
        let ctx = egui::Context::default();
        if let Some(f) = fonts {
            ctx.set_fonts(f.clone());
        }
        let state = egui_winit::State::new(
            ctx.clone(),
            egui::ViewportId::ROOT,
            window,
            Some(window.scale_factor() as f32),
            window.theme(),
            Some(max_texture_side),
        );
        (ctx, state)
    }

    /// Creates the device, surface and egui renderer (again, after a loss).
    fn ensure_gfx(&mut self, event_loop: &ActiveEventLoop, window: &Arc<Window>) -> bool {
        if let Some(g) = &self.gfx {
            let lost = g.lost.lock().ok().and_then(|mut l| l.take());
            let Some(reason) = lost else {
                return true;
            };
            let msg = format!("GPU device lost ({reason}); recreating it");
            if std::mem::take(&mut self.simulated_loss) {
                self.model.info(msg);
            } else {
                self.model.error(msg);
            }
            self.gfx = None;
        }
        if self.retry_at.is_some_and(|t| Instant::now() < t) {
            return false;
        }
        match Gfx::new(&self.display, window.clone(), self.vsync) {
            Ok(g) => {
                self.model.stats.adapter = g.ctx.adapter_name();
                // A new device has none of egui's textures: a new context sends them all.
                self.egui = Some(Self::new_egui(
                    window,
                    g.ctx.max_texture_size() as usize,
                    self.fonts.as_ref(),
                ));
                self.gfx = Some(g);
                self.model.dirty.rebuild = true;
                self.retry_at = None;
                true
            }
            Err(e) => {
                let first = self.presented == 0;
                if first || self.scripted() {
                    // Nothing can show an error without a device: end with it.
                    self.failure = Some(e);
                    event_loop.exit();
                } else {
                    eprintln!("subsurface view: {e:#}; retrying");
                    self.model.error(format!("{e:#}"));
                    self.retry_at = Some(Instant::now() + Duration::from_secs(2));
                }
                false
            }
        }
    }

    /// Brings the renderers up to date with the model: edits, size, comparison.
    fn apply_edits(&mut self) -> Result<()> {
        let m = &mut self.model;
        let Some(g) = self.gfx.as_mut() else {
            return Ok(());
        };
        let want_b = m.state.compare;
        if !(m.dirty.update || m.dirty.rebuild) && g.a.is_some() && want_b == g.b.is_some() {
            return Ok(());
        }
        let rebuild = m.dirty.rebuild || g.a.is_none();
        // An edit that fails leaves the renderers on the last good state; the panel shows
        // the error until the next edit.
        m.dirty = Default::default();
        m.sync_scene()?;
        let oa = m.state.options(&m.state.a)?;
        let ob = want_b.then(|| m.state.options(&m.state.b)).transpose()?;
        if rebuild {
            g.a = None;
            g.b = None;
            g.a = Some(Renderer::new(&g.ctx, &m.scene, oa).context("creating the renderer")?);
        } else if let Some(a) = g.a.as_mut() {
            a.update(&m.scene, &oa)?;
        }
        match (ob, g.b.as_mut()) {
            (Some(o), Some(b)) if !rebuild => b.update(&m.scene, &o)?,
            (Some(o), _) => {
                g.b = Some(
                    Renderer::new(&g.ctx, &m.scene, o)
                        .context("creating the comparison renderer")?,
                )
            }
            (None, _) => g.b = None,
        }
        m.error = None;
        Ok(())
    }

    /// The 3D view as an image: the renderers draw the current frame again into their own
    /// offscreen targets (`Renderer::render`, the PNG path of `subsurface render`), so the
    /// screenshot has no panel and matches `render` of the saved scene. Split screen is
    /// composed at the divider.
    fn screenshot(&mut self) -> Result<image::RgbaImage> {
        let g = self.gfx.as_mut().context("no GPU device")?;
        let a = g.a.as_mut().context("nothing rendered yet")?;
        let mut img = a.render().context("rendering the screenshot failed")?.image;
        if let (true, Some(b)) = (self.model.state.compare, g.b.as_mut()) {
            let right = b.render().context("rendering the screenshot failed")?.image;
            let xs = split_px(self.model.state.split, img.width());
            for (x, y, p) in img.enumerate_pixels_mut() {
                if x >= xs {
                    *p = *right.get_pixel(x, y);
                }
            }
        }
        Ok(img)
    }

    fn save_screenshot(&mut self, path: &Path) -> Result<()> {
        let pending = PendingFile::create(path)?;
        let img = self.screenshot()?;
        pending.write_png(&img)
    }

    fn run_action(&mut self, action: Action) {
        match action {
            Action::Screenshot(p) => match self.save_screenshot(&p) {
                Ok(()) => self.model.info(format!("saved {}", p.display())),
                Err(e) => self.model.error(format!("{e:#}")),
            },
            Action::LoseDevice => {
                if let Some(g) = &self.gfx {
                    self.simulated_loss = true;
                    g.ctx.device.destroy();
                    // The lost callback runs from device maintenance.
                    let _ = g.ctx.device.poll(wgpu::PollType::Poll);
                }
            }
        }
    }

    /// After the last scripted frame: the requested files, then exit.
    fn finish_script(&mut self, event_loop: &ActiveEventLoop) {
        let Some(script) = self.script.as_mut() else {
            return;
        };
        let screenshot = script.screenshot.take();
        let save = script.save_scene.take();
        let soak = script.soak.take();
        let result = (|| -> Result<()> {
            if let Some(soak) = soak {
                eprintln!("{}", soak.verdict()?);
            }
            if let Some(g) = &self.gfx {
                g.ctx.check().context("GPU error")?;
            }
            if let Some(e) = self.model.log.iter().find(|(l, _)| *l == Level::Error) {
                anyhow::bail!("{}", e.1);
            }
            if let Some(p) = screenshot {
                let img = self.screenshot()?;
                p.write_png(&img)?;
            }
            if let Some(p) = save {
                self.model.state.save(&p)?;
            }
            Ok(())
        })();
        if let Err(e) = result {
            self.failure = Some(e);
        }
        event_loop.exit();
    }

    fn frame(&mut self, event_loop: &ActiveEventLoop) {
        let Some(window) = self.window.clone() else {
            return;
        };
        let size = self.window_size(&window);
        // Minimised or zero-sized: there is nothing to draw and a surface cannot be
        // configured at 0 px; the next Resized event brings us back.
        if size.width == 0 || size.height == 0 {
            if let Some(skipped) = self.minimised.as_mut() {
                *skipped += 1;
            }
            return;
        }
        if !self.ensure_gfx(event_loop, &window) {
            return;
        }
        let now = Instant::now();
        let dt = now.duration_since(self.last_frame).as_secs_f32();
        self.last_frame = now;
        let stats = &mut self.model.stats;
        let ms = f64::from(dt) * 1e3;
        stats.frame_ms = if stats.frame_ms == 0.0 {
            ms
        } else {
            0.9 * stats.frame_ms + 0.1 * ms
        };

        // UI first: its edits are applied before this frame renders.
        let Some((ectx, estate)) = self.egui.as_mut() else {
            return;
        };
        let raw = estate.take_egui_input(&window);
        let vp = Viewport {
            width: size.width,
            height: size.height,
            pixels_per_point: egui_winit::pixels_per_point(ectx, &window),
            dt,
        };
        let mut actions = Vec::new();
        let model = &mut self.model;
        let mut full = ectx.run_ui(raw, |ui| actions = panel::show(ui, model, &vp));
        estate.handle_platform_output(&window, full.platform_output);
        let paint = ectx.tessellate(std::mem::take(&mut full.shapes), full.pixels_per_point);
        // egui insists that every texture delta is applied: uploads now, frees after this
        // frame's paint whether or not it is presented.
        let texture_set = std::mem::take(&mut full.textures_delta.set);
        let to_free: Vec<egui::TextureId> = full.textures_delta.free.drain().collect();
        let ppp = full.pixels_per_point;

        {
            let Some(g) = self.gfx.as_mut() else { return };
            // Texture uploads do not need the swapchain: done even if this frame is skipped,
            // or egui would lose its font atlas.
            for (id, deltas) in &texture_set {
                for delta in deltas {
                    g.egui
                        .update_texture(&g.ctx.device, &g.ctx.queue, *id, delta);
                }
            }
            if (g.config.width, g.config.height) != (size.width, size.height) {
                g.configure(size.width, size.height);
            }
            let r = &mut self.model.state.desc.render;
            if (r.width, r.height) != (size.width, size.height) {
                r.width = size.width;
                r.height = size.height;
                self.model.dirty.update = true;
            }
        }
        for a in actions {
            self.run_action(a);
        }
        if self.script.as_ref().is_some_and(|s| s.soak.is_some())
            && super::soak::Soak::edit(self.presented, &mut self.model, &window)
        {
            self.minimised = Some(0);
            self.resized(&window, PhysicalSize::new(0, 0));
        }
        if let Err(e) = self.apply_edits() {
            let msg = format!("{e:#}");
            self.model.error = Some(msg.clone());
            self.report(event_loop, e);
        }

        let Some(g) = self.gfx.as_mut() else { return };
        let frame = match g.surface.get_current_texture() {
            CurrentSurfaceTexture::Success(t) | CurrentSurfaceTexture::Suboptimal(t) => t,
            CurrentSurfaceTexture::Timeout | CurrentSurfaceTexture::Occluded => {
                free_textures(g, &to_free);
                return;
            }
            CurrentSurfaceTexture::Outdated => {
                g.surface.configure(&g.ctx.device, &g.config);
                free_textures(g, &to_free);
                return;
            }
            CurrentSurfaceTexture::Lost => {
                match g.ctx.instance.create_surface(window.clone()) {
                    Ok(s) => {
                        g.surface = s;
                        g.surface.configure(&g.ctx.device, &g.config);
                    }
                    Err(e) => self
                        .model
                        .error(format!("the window's surface was lost: {e}")),
                }
                free_textures(g, &to_free);
                return;
            }
            CurrentSurfaceTexture::Validation => {
                free_textures(g, &to_free);
                self.model
                    .error("the window's surface reported a validation error");
                return;
            }
        };
        let view = frame.texture.create_view(&Default::default());
        let format = g.scene_format;
        let scene_view = frame.texture.create_view(&wgpu::TextureViewDescriptor {
            format: Some(format),
            ..Default::default()
        });
        let mut encoder = g.ctx.device.create_command_encoder(&Default::default());
        let (left, right) = g.split(self.model.state.split);
        let compare = self.model.state.compare && g.b.is_some();
        match (g.a.as_mut(), g.b.as_mut()) {
            (Some(a), Some(b)) if compare => {
                if let Some(s) = left {
                    a.encode_to_view(&mut encoder, &scene_view, format, Some(s));
                }
                if let Some(s) = right {
                    b.encode_to_view(&mut encoder, &scene_view, format, Some(s));
                }
                a.resolve_timings(&mut encoder);
                b.resolve_timings(&mut encoder);
            }
            (Some(a), _) => {
                a.encode_to_view(&mut encoder, &scene_view, format, None);
                a.resolve_timings(&mut encoder);
            }
            // No renderer (its creation failed): a plain background under the panel.
            (None, _) => {
                color_pass(
                    &mut encoder,
                    "clear",
                    &view,
                    wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                );
            }
        }
        let screen = egui_wgpu::ScreenDescriptor {
            size_in_pixels: [g.config.width, g.config.height],
            pixels_per_point: ppp,
        };
        let extra =
            g.egui
                .update_buffers(&g.ctx.device, &g.ctx.queue, &mut encoder, &paint, &screen);
        {
            let mut pass =
                color_pass(&mut encoder, "egui", &view, wgpu::LoadOp::Load).forget_lifetime();
            g.egui.render(&mut pass, &paint, &screen);
        }
        g.ctx
            .queue
            .submit(extra.into_iter().chain([encoder.finish()]));
        window.pre_present_notify();
        g.ctx.queue.present(frame);
        free_textures(g, &to_free);

        let mut errors = Vec::new();
        for (r, out) in [
            (g.a.as_mut(), &mut self.model.stats.timings_a),
            (
                g.b.as_mut().filter(|_| compare),
                &mut self.model.stats.timings_b,
            ),
        ] {
            if let Some(r) = r {
                match r.finish_frame() {
                    Ok(Some(t)) => *out = t,
                    Ok(None) => {}
                    Err(e) => errors.push(e.to_string()),
                }
            }
        }
        // Validation errors are collected by the device's error handler; reading them waits
        // for the GPU, so only now and then (and always in scripted runs).
        self.frames_since_check += 1;
        if self.frames_since_check >= 60 || self.script.is_some() {
            self.frames_since_check = 0;
            if let Err(e) = g.ctx.check() {
                errors.push(e.to_string());
            }
        }
        for e in errors {
            self.report(event_loop, anyhow::anyhow!("GPU: {e}"));
        }
        self.presented += 1;
        self.model.stats.frames += 1;

        let (lose_at, frames) = match &mut self.script {
            Some(s) => {
                if let (Some(soak), Some(g)) = (&mut s.soak, &self.gfx) {
                    soak.sample(self.presented, (size.width, size.height), &g.ctx);
                }
                (s.lose_device_at, s.frames)
            }
            None => return,
        };
        if lose_at == Some(self.presented) {
            self.run_action(Action::LoseDevice);
        }
        if self.presented >= frames {
            self.finish_script(event_loop);
        }
    }
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.window.is_some() {
            return;
        }
        let attrs = Window::default_attributes()
            .with_title("subsurface view")
            .with_inner_size(self.initial_size);
        match event_loop.create_window(attrs) {
            Ok(w) => {
                let w = Arc::new(w);
                w.request_redraw();
                self.window = Some(w);
            }
            Err(e) => {
                self.failure = Some(anyhow::anyhow!("cannot open a window: {e}"));
                event_loop.exit();
            }
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        let Some(window) = self.window.clone() else {
            return;
        };
        if let Some((_, state)) = self.egui.as_mut() {
            let _ = state.on_window_event(&window, &event);
        }
        match event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::Resized(_) | WindowEvent::ScaleFactorChanged { .. } => {
                window.request_redraw()
            }
            WindowEvent::RedrawRequested => self.frame(event_loop),
            WindowEvent::DroppedFile(path) => {
                self.model.open(&path);
                window.request_redraw();
            }
            _ => {}
        }
    }

    fn about_to_wait(&mut self, event_loop: &ActiveEventLoop) {
        let Some(window) = self.window.clone() else {
            return;
        };
        let size = self.window_size(&window);
        if let Some(skipped) = self.minimised {
            // The soak restores the window once a redraw has been skipped at 0x0.
            if skipped > 0 {
                self.minimised = None;
                self.resized(&window, window.inner_size());
                if let Some(soak) = self.script.as_mut().and_then(|s| s.soak.as_mut()) {
                    soak.skipped_at_zero(skipped);
                }
            }
            window.request_redraw();
        } else if size.width == 0 || size.height == 0 {
            event_loop.set_control_flow(ControlFlow::Wait);
        } else if let Some(t) = self.retry_at.filter(|_| self.gfx.is_none()) {
            event_loop.set_control_flow(ControlFlow::WaitUntil(t));
            if Instant::now() >= t {
                window.request_redraw();
            }
        } else {
            // Continuous redraw: timings stay live; vsync paces it.
            event_loop.set_control_flow(ControlFlow::Wait);
            window.request_redraw();
        }
    }

    fn exiting(&mut self, _event_loop: &ActiveEventLoop) {
        // The surface refers to the window: release the GPU side first.
        self.gfx = None;
        self.egui = None;
    }
}
