//! GPU timestamp queries per pass (through wgpu-profiler), summed by pass name.

use wgpu_profiler::{GpuProfiler, GpuProfilerQuery, GpuProfilerSettings};

use crate::error::RenderError;

/// A pass's GPU time in one frame. Passes run several times a frame (one shadow pass per
/// shadow-map layer, two blur passes) are summed under one name.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct PassTiming {
    /// The pass's label (`lighting`, `sss`, ...).
    pub name: String,
    /// GPU milliseconds, summed over the pass's runs in the frame.
    pub ms: f64,
}

/// An open timestamp query; give its `writes()` to the render or compute pass, then `end` it.
pub struct TimedPass(Option<GpuProfilerQuery>);

impl TimedPass {
    /// Opens a query named `label`; none without a profiler.
    pub fn begin(
        profiler: Option<&GpuProfiler>,
        label: &str,
        encoder: &mut wgpu::CommandEncoder,
    ) -> Self {
        Self(profiler.map(|p| p.begin_pass_query(label, encoder)))
    }
    /// Timestamp writes for a render pass (`None` without timestamp queries).
    pub fn writes(&self) -> Option<wgpu::RenderPassTimestampWrites<'_>> {
        self.0
            .as_ref()
            .and_then(|q| q.render_pass_timestamp_writes())
    }
    /// Timestamp writes for a compute pass (`None` without timestamp queries).
    pub fn compute_writes(&self) -> Option<wgpu::ComputePassTimestampWrites<'_>> {
        self.0
            .as_ref()
            .and_then(|q| q.compute_pass_timestamp_writes())
    }
    /// Closes the query.
    pub fn end(self, profiler: Option<&GpuProfiler>, encoder: &mut wgpu::CommandEncoder) {
        if let (Some(p), Some(q)) = (profiler, self.0) {
            p.end_query(encoder, q);
        }
    }
}

/// A profiler for [`TimedPass`]; it records no times on a device without timestamp queries.
pub fn new_profiler(device: &wgpu::Device) -> Result<GpuProfiler, RenderError> {
    let settings = GpuProfilerSettings {
        enable_timer_queries: device.features().contains(wgpu::Features::TIMESTAMP_QUERY),
        enable_debug_groups: false,
        max_num_pending_frames: 4,
    };
    GpuProfiler::new(device, settings)
        .map_err(|e| RenderError::Validation(format!("profiler: {e}")))
}

/// Sums the finished frame's queries by label, in first-seen order.
pub fn collect(results: &[wgpu_profiler::GpuTimerQueryResult]) -> Vec<PassTiming> {
    let mut out: Vec<PassTiming> = Vec::new();
    for r in results {
        let Some(t) = &r.time else { continue };
        let ms = (t.end - t.start) * 1e3;
        match out.iter_mut().find(|p| p.name == r.label) {
            Some(p) => p.ms += ms,
            None => out.push(PassTiming {
                name: r.label.clone(),
                ms,
            }),
        }
    }
    out
}
