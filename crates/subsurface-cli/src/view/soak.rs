//! `view --frames N --soak` (hidden): the viewer's long-run check. Every frame edits what a
//! user edits: the SSS and transmittance methods, the exposure, a light's place and strength,
//! a light added and removed, and the window size (1x1 included) and minimised. A minimised
//! window is 0x0 on Windows and Wayland; X11 cannot make one, so the soak makes the viewer
//! read 0x0 where it reads the window's size and sends egui the `Resized(0x0)` winit would,
//! until one redraw has been skipped, then restores it. The edits repeat every
//! [`CYCLE`] frames, so two cycles hold the same states; the process's resident memory, the
//! GPU allocator's bytes and wgpu's live handles are taken every frame, and the largest of
//! the last cycle is held against the largest of the cycle half way through the run (the
//! first half lets caches and pools reach their size). Growth past the limits ends the run with an
//! error; the figures go to stderr either way.

use anyhow::Result;
use subsurface_render::{GpuContext, SssMethod, TransmittanceMethod};
use winit::dpi::PhysicalSize;
use winit::window::Window;

use super::model::Model;

/// Frames per cycle of edits.
pub const CYCLE: u32 = 12;
/// Cycles before the reference cycle, at the least: the first half of the run is warm-up
/// (lavapipe's resident memory keeps creeping up, ever slower, for a few hundred frames).
pub const WARM_UP: u32 = 2;
/// Window sizes, one per frame of a cycle.
const SIZES: [(u32, u32); CYCLE as usize] = [
    (320, 240),
    (1, 1),
    (200, 120),
    (480, 320),
    (64, 48),
    (320, 240),
    (17, 301),
    (256, 256),
    MINIMISED,
    (320, 240),
    (400, 90),
    (320, 240),
];
/// The entry of [`SIZES`] that minimises the window.
const MINIMISED: (u32, u32) = (0, 0);
/// Resident memory may grow this much (allocator noise), GPU bytes this much (the panel's
/// vertex buffers follow its text, which changes every frame); live objects not at all.
const RSS_GROWTH: f64 = 0.01;
const GPU_GROWTH: f64 = 0.001;

/// What is measured: resident memory (KiB), GPU allocator bytes, live wgpu objects.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Sample {
    rss_kib: u64,
    gpu_bytes: u64,
    handles: usize,
}

impl Sample {
    fn max(self, o: Sample) -> Sample {
        Sample {
            rss_kib: self.rss_kib.max(o.rss_kib),
            gpu_bytes: self.gpu_bytes.max(o.gpu_bytes),
            handles: self.handles.max(o.handles),
        }
    }
}

pub struct Soak {
    /// The cycle measured as the reference.
    reference_cycle: u32,
    /// The largest sample of the cycle in progress, of the reference cycle and of the last
    /// complete cycle after it.
    current: Sample,
    reference: Option<Sample>,
    last: Option<Sample>,
    /// The window sizes the frames were drawn at: proof that the resizes happened.
    sizes: std::collections::BTreeSet<(u32, u32)>,
    /// Redraws skipped while minimised.
    skipped: u32,
}

fn rss_kib() -> u64 {
    // statm: size resident ... in pages.
    std::fs::read_to_string("/proc/self/statm")
        .ok()
        .and_then(|s| s.split_whitespace().nth(1)?.parse::<u64>().ok())
        .map_or(0, |pages| pages * 4)
}

fn handles(ctx: &GpuContext) -> usize {
    let Some(r) = ctx.instance.generate_report() else {
        return 0;
    };
    let h = r.hub_report();
    [
        &h.buffers,
        &h.textures,
        &h.texture_views,
        &h.samplers,
        &h.bind_groups,
        &h.bind_group_layouts,
        &h.pipeline_layouts,
        &h.render_pipelines,
        &h.compute_pipelines,
        &h.shader_modules,
        &h.query_sets,
    ]
    .iter()
    .map(|r| r.num_allocated)
    .sum()
}

impl Soak {
    /// A soak of `frames` frames.
    pub fn new(frames: u32) -> Self {
        Self {
            reference_cycle: (frames / CYCLE / 2).max(WARM_UP + 1),
            current: Sample::default(),
            reference: None,
            last: None,
            sizes: Default::default(),
            skipped: 0,
        }
    }

    /// The edits of frame `frame`, before it is drawn; true when the window is to be
    /// minimised after it.
    pub fn edit(frame: u32, model: &mut Model, window: &Window) -> bool {
        let k = (frame % CYCLE) as usize;
        let a = &mut model.state.a;
        a.sss.method = SssMethod::ALL[k % SssMethod::ALL.len()];
        a.sss.texture_size = 64;
        a.transmittance.method = TransmittanceMethod::ALL[k % TransmittanceMethod::ALL.len()];
        model.state.desc.render.exposure_ev = k as f32 * 0.25 - 1.0;
        if let Some(l) = model.state.desc.lights.first_mut() {
            l.intensity = 1.0 + k as f32 * 0.5;
        }
        let (_, el, dist) = model.light_spherical(0);
        model.set_light_spherical(0, 30.0 * k as f32, el, dist);
        match k {
            3 => model.add_light(),
            9 => model.remove_light(model.state.desc.lights.len() - 1),
            _ => {}
        }
        model.dirty.update = true;
        if SIZES[k] == MINIMISED {
            return true;
        }
        let (w, h) = SIZES[k];
        let _ = window.request_inner_size(PhysicalSize::new(w, h));
        false
    }

    /// The window was restored after `redraws` redraws skipped at 0x0.
    pub fn skipped_at_zero(&mut self, redraws: u32) {
        self.sizes.insert(MINIMISED);
        self.skipped += redraws;
    }

    /// Measures after frame `frame` (1-based) was presented at `size`.
    pub fn sample(&mut self, frame: u32, size: (u32, u32), ctx: &GpuContext) {
        self.sizes.insert(size);
        // Let the device release what the frame dropped, or it counts as growth.
        let _ = ctx.device.poll(wgpu::PollType::wait_indefinitely());
        let s = Sample {
            rss_kib: rss_kib(),
            gpu_bytes: ctx
                .device
                .generate_allocator_report()
                .map_or(0, |r| r.total_allocated_bytes),
            handles: handles(ctx),
        };
        self.current = self.current.max(s);
        if frame.is_multiple_of(CYCLE) {
            let done = std::mem::take(&mut self.current);
            // Per cycle, for the long runs' figures (a trend shows here before the verdict).
            eprintln!("soak: cycle {}: {done:?}", frame / CYCLE);
            match (frame / CYCLE).cmp(&self.reference_cycle) {
                std::cmp::Ordering::Less => {}
                std::cmp::Ordering::Equal => self.reference = Some(done),
                std::cmp::Ordering::Greater => self.last = Some(done),
            }
        }
    }

    /// The figures on one line, and an error if anything grew past its limit.
    pub fn verdict(&self) -> Result<String> {
        let (Some(r), Some(l)) = (self.reference, self.last) else {
            anyhow::bail!(
                "--soak: needs --frames of at least {} ({} cycles of {CYCLE})",
                (WARM_UP + 2) * CYCLE,
                WARM_UP + 2
            );
        };
        let growth = l.rss_kib as f64 / r.rss_kib.max(1) as f64 - 1.0;
        let gpu_growth = l.gpu_bytes as f64 / r.gpu_bytes.max(1) as f64 - 1.0;
        let line = format!(
            "soak: resident {} -> {} KiB ({:+.2} %), GPU allocated {} -> {} bytes, live wgpu \
             objects {} -> {} (largest of cycle {} vs of the last cycle of {CYCLE} frames; {} \
             window sizes; {} redraws skipped minimised)",
            r.rss_kib,
            l.rss_kib,
            100.0 * growth,
            r.gpu_bytes,
            l.gpu_bytes,
            r.handles,
            l.handles,
            self.reference_cycle,
            self.sizes.len(),
            self.skipped
        );
        anyhow::ensure!(
            growth <= RSS_GROWTH && gpu_growth <= GPU_GROWTH && l.handles <= r.handles,
            "{line}: grew"
        );
        anyhow::ensure!(
            self.sizes.contains(&MINIMISED),
            "{line}: the window was never minimised"
        );
        Ok(line)
    }
}
