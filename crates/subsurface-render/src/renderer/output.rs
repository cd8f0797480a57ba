//! The renderer's outputs: the tone-mapped image (one tone-map pass per output format: PNGs,
//! a window's swapchain) and the debug views that show a target in its place.

use super::Renderer;
use crate::gpu::GpuContext;
use crate::passes::lighting::LightingTargets;
use crate::passes::tonemap::{self, DebugView, ToneMapInputs, ToneMapPass};
use crate::settings::SssMethod;

pub(super) fn output_texture(ctx: &GpuContext, w: u32, h: u32) -> wgpu::Texture {
    ctx.device.create_texture(&wgpu::TextureDescriptor {
        label: Some("output"),
        size: wgpu::Extent3d {
            width: w,
            height: h,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: tonemap::OUTPUT_FORMAT,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
        view_formats: &[],
    })
}

/// A tone-map pass for one output format and what it draws from.
pub(super) struct ToneMapTarget {
    pub(super) format: wgpu::TextureFormat,
    pass: ToneMapPass,
    /// The lighting targets.
    frame: wgpu::BindGroup,
    /// The UV-space irradiance map in place of diffuse: only with `DebugView::Irradiance` and
    /// texture-space diffusion, rebuilt by `update` (the maps may have been recreated).
    irradiance: Option<wgpu::BindGroup>,
}

fn tonemap_inputs<'a>(views: &'a [wgpu::TextureView; 4]) -> ToneMapInputs<'a> {
    ToneMapInputs {
        diffuse: &views[0],
        specular: &views[1],
        depth: &views[2],
        sss: &views[3],
    }
}

pub(super) fn target_views(t: &LightingTargets) -> [wgpu::TextureView; 4] {
    let view = |t: &wgpu::Texture| t.create_view(&Default::default());
    [
        view(&t.diffuse),
        view(&t.specular),
        view(&t.depth),
        view(&t.sss),
    ]
}

impl Renderer {
    /// The UV-space irradiance map that `DebugView::Irradiance` shows: the first skin
    /// object's, with texture-space diffusion; None otherwise (the view then shows the lit
    /// image before the screen-space blur).
    fn irradiance_map(&self) -> Option<&wgpu::Texture> {
        if self.options.view != DebugView::Irradiance
            || self.options.settings.sss.method != SssMethod::Texture
        {
            return None;
        }
        (0..self.objects.len()).find_map(|i| self.texture_space.object_maps(i).map(|m| m.0))
    }

    /// What a tone-map pass normally draws from: the lighting targets.
    fn frame_bind_group(&self, pass: &ToneMapPass) -> wgpu::BindGroup {
        pass.bind(
            &self.ctx.device,
            &tonemap_inputs(&target_views(&self.targets)),
        )
    }

    /// The irradiance map in place of diffuse, when the irradiance view shows one.
    fn irradiance_bind_group(&self, pass: &ToneMapPass) -> Option<wgpu::BindGroup> {
        let map_view = self.irradiance_map()?.create_view(&Default::default());
        let views = target_views(&self.targets);
        Some(pass.bind(
            &self.ctx.device,
            &ToneMapInputs {
                diffuse: &map_view,
                ..tonemap_inputs(&views)
            },
        ))
    }

    pub(super) fn add_tonemap(&mut self, format: wgpu::TextureFormat) {
        let pass = ToneMapPass::new(&self.ctx.device, format);
        self.tonemaps.push(ToneMapTarget {
            format,
            frame: self.frame_bind_group(&pass),
            irradiance: self.irradiance_bind_group(&pass),
            pass,
        });
    }

    /// Records the scene and then `target`'s tone map into `view`.
    fn encode_with(
        &self,
        target: &ToneMapTarget,
        encoder: &mut wgpu::CommandEncoder,
        view: &wgpu::TextureView,
        scissor: Option<[u32; 4]>,
    ) {
        let o = &self.options;
        target.pass.set_params_with(
            &self.ctx.queue,
            o.settings.exposure_ev,
            o.view,
            self.far,
            target.irradiance.is_some(),
        );
        self.encode_scene(encoder);
        let bind_group = target.irradiance.as_ref().unwrap_or(&target.frame);
        target
            .pass
            .encode_scissored(encoder, bind_group, view, scissor, Some(&self.profiler));
    }

    /// Records one whole frame into `encoder`, ending with the tone-mapped `output` texture.
    pub fn encode_frame(&self, encoder: &mut wgpu::CommandEncoder) {
        let out = self.output.create_view(&Default::default());
        self.encode_with(&self.tonemaps[0], encoder, &out, None);
    }

    /// Records a whole frame tone-mapped into `view` (e.g. a window's swapchain texture of
    /// `format`, the same size as the renderer). With `scissor` = [x, y, w, h] only that
    /// rectangle of `view` is written and the rest is kept: two renderers with different
    /// settings can share one view for a split-screen comparison.
    pub fn encode_to_view(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        view: &wgpu::TextureView,
        format: wgpu::TextureFormat,
        scissor: Option<[u32; 4]>,
    ) {
        if !self.tonemaps.iter().any(|t| t.format == format) {
            self.add_tonemap(format);
        }
        let target = self
            .tonemaps
            .iter()
            .find(|t| t.format == format)
            .expect("added above");
        self.encode_with(target, encoder, view, scissor);
    }

    /// Binds each tone-map pass to the targets again: the frame's after a resize (new
    /// textures), the irradiance map's always (the maps may have been recreated).
    pub(super) fn rebind_tonemaps(&mut self, resized: bool) {
        for i in 0..self.tonemaps.len() {
            if resized {
                self.tonemaps[i].frame = self.frame_bind_group(&self.tonemaps[i].pass);
            }
            self.tonemaps[i].irradiance = self.irradiance_bind_group(&self.tonemaps[i].pass);
        }
    }
}
