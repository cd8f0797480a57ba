//! The transmitted map: `diffusion`'s transmitted light, every light summed, and the bounce,
//! evaluated at a reduced resolution on the meshes' front faces so that the lighting pass
//! reads them once per pixel (transmittance.wgsl, `transmitted_from_map`; lighting.wgsl,
//! `bounce_from_map`). The frame plan decides its shape ([`crate::frame_plan::TransmittedMapShape`]).
//!
//! By default (`MapEvaluation::Compute`) a raster pass only records each texel's surface
//! (`fs_surface`) and compute shaders evaluate it, once per object over the object's box on
//! screen (`cs_transmitted`, `cs_bounce`, transmitted_map.wgsl); otherwise the map's fragment shaders
//! do (`fs_transmitted`, `fs_bounce`). Its pipelines are built on the lighting shader and bind
//! the lighting pass's groups 0 to 2.

mod targets;

use targets::{MapSurface, ObjectRects, dispatch_origin_layout, map_compute_layout};
pub use targets::{TRANSMITTED_MAP_FORMAT, TransmittedMapTargets};

use crate::frame_plan::{FramePlan, TRANSMITTED_LAYERS};
use crate::gpu::object::GpuObject;
use crate::passes::overrides::{Terms, diffusion_whole, lateral};
use crate::passes::util;
use crate::timing::TimedPass;

/// One raster pass at the transmitted map's resolution: `pipeline` into `targets` (layers of the
/// map, or the texels' surfaces), timed as `timed`, the first of a frame clearing the map's
/// z-buffer (the later ones shade only the surfaces it kept).
struct MapPass<'a> {
    timed: &'static str,
    targets: Vec<&'a wgpu::TextureView>,
    first: bool,
    pipeline: &'a wgpu::RenderPipeline,
}

/// One compute pass of [`TransmittedMapPass::encode_compute`]: `pipeline` (spread over lanes, a
/// workgroup per [`SPREAD_BLOCK`]) once per object, after `clear` over the whole map where
/// given.
struct Compute<'a> {
    timed: &'a str,
    clear: Option<&'a wgpu::ComputePipeline>,
    pipeline: &'a wgpu::ComputePipeline,
    /// The texels' surfaces it evaluates, and the map it writes.
    surface: &'a MapSurface,
}

/// `LATERAL_SOURCE` of the raster passes and `cs_bounce`: `diffusion` whole, the taps
/// included; and of `cs_transmitted`, whose taps' sum is gathered over the texel's lanes before
/// `transmittance`.
const WHOLE: f64 = lateral::TAPS as f64;
const SPREAD: f64 = lateral::GIVEN as f64;

/// `cs_transmitted`'s and `cs_bounce`'s invocations per texel (transmitted_map.wgsl, `TEXEL_LANES`),
/// and the block of texels (across, down) a workgroup of 64 takes. Each texel waits out a
/// chain of dependent shadow-map and LUT loads and a map has too few texels to hide it: lanes
/// that share a texel's light and taps halve that wait (measured in docs/lab/performance.md).
const TEXEL_LANES: u32 = 8;
const SPREAD_BLOCK: [u32; 2] = [4, 2];
// Each light needs a lane of its own for its entry and the rest of its transmittance.
const _: () = assert!(TEXEL_LANES as usize >= crate::uniforms::MAX_LIGHTS);
/// Texels per workgroup of `cs_clear`, across and down: 8 x 8, one invocation each.
const TEXEL_BLOCK: u32 = 8;

/// `base` with the overrides that spread a texel over lanes (`cs_transmitted`, `cs_bounce`).
fn spread_constants(base: &[(&'static str, f64)]) -> Vec<(&'static str, f64)> {
    let [width, height] = SPREAD_BLOCK;
    [
        base,
        &[
            ("TEXEL_LANES", f64::from(TEXEL_LANES)),
            ("BLOCK_WIDTH", f64::from(width)),
            ("BLOCK_HEIGHT", f64::from(height)),
        ],
    ]
    .concat()
}

/// The transmitted map's passes: the raster and compute evaluations of the transmitted light and
/// the bounce.
pub struct TransmittedMapPass {
    module: wgpu::ShaderModule,
    raster_layout: wgpu::PipelineLayout,
    /// The terms every pipeline below is built with (the plan's).
    terms: Terms,
    /// `fs_transmitted` into the transmitted light's two layers of the transmitted map, keeping
    /// the nearest surface in the map's z-buffer (the bounce pass after it shades only that).
    transmitted: wgpu::RenderPipeline,
    /// `fs_surface` into the texels' surfaces, keeping the nearest surface as `transmitted`
    /// does; `cs_transmitted` and `cs_bounce` then evaluate the transmitted light and the
    /// bounce there, once per object (each built the first time a plan asks for it).
    surface: wgpu::RenderPipeline,
    transmitted_compute: Option<wgpu::ComputePipeline>,
    bounce_compute: Option<wgpu::ComputePipeline>,
    /// `cs_clear`: every layer of the map to nothing, first in the frame's first compute pass.
    clear_compute: Option<wgpu::ComputePipeline>,
    /// `cs_transmitted`'s layout: the frame's group, the object's, [`map_compute_layout`],
    /// [`dispatch_origin_layout`].
    compute_layout: wgpu::PipelineLayout,
    /// Each object's box for its dispatch (the plan's `object_rects`).
    object_rects: ObjectRects,
    /// `[first pass, later passes]`: `fs_bounce` into the map's bounce layer.
    bounce: [wgpu::RenderPipeline; 2],
    /// The plan's: the map holds the transmitted light, and the bounce's layer.
    map_holds_transmitted: bool,
    bounce_layer: Option<u32>,
}

impl TransmittedMapPass {
    /// On the lighting shader `module`, with the lighting pass's group layouts 0 to 2.
    pub fn new(
        device: &wgpu::Device,
        module: &wgpu::ShaderModule,
        layouts: [&wgpu::BindGroupLayout; 3],
        plan: &FramePlan,
    ) -> Self {
        let [frame_layout, object_layout, _] = layouts;
        let raster_layout = util::pipeline_layout(device, "transmitted", &layouts);
        let compute_layout = util::pipeline_layout(
            device,
            "transmitted map compute",
            &[
                frame_layout,
                object_layout,
                &map_compute_layout(device),
                &dispatch_origin_layout(device),
            ],
        );
        let terms = plan.lighting.terms;
        let [transmitted, surface, first, later] =
            raster_pipelines(device, module, &raster_layout, terms);
        let mut pass = Self {
            module: module.clone(),
            raster_layout,
            terms,
            transmitted,
            surface,
            transmitted_compute: None,
            bounce_compute: None,
            clear_compute: None,
            compute_layout,
            object_rects: ObjectRects::new(device, &[], 1),
            bounce: [first, later],
            map_holds_transmitted: false,
            bounce_layer: None,
        };
        pass.prepare(device, plan);
        pass
    }

    /// Takes `plan`'s map (what it holds, each object's box) and builds the compute
    /// evaluations it asks for that the pass does not hold yet; other terms than the pass's
    /// build every pipeline again.
    pub fn prepare(&mut self, device: &wgpu::Device, plan: &FramePlan) {
        self.map_holds_transmitted = plan.map_holds_transmitted;
        self.bounce_layer = plan.bounce_layer;
        self.object_rects = ObjectRects::new(device, &plan.object_rects, plan.map_downsample);
        if plan.lighting.terms != self.terms {
            self.terms = plan.lighting.terms;
            let [transmitted, surface, first, later] =
                raster_pipelines(device, &self.module, &self.raster_layout, self.terms);
            (self.transmitted, self.surface, self.bounce) = (transmitted, surface, [first, later]);
            (
                self.transmitted_compute,
                self.bounce_compute,
                self.clear_compute,
            ) = (None, None, None);
        }
        if !plan.map.compute {
            return;
        }
        let whole = diffusion_whole(self.terms, WHOLE);
        if plan.map_holds_transmitted && self.transmitted_compute.is_none() {
            let constants = spread_constants(&diffusion_whole(self.terms, SPREAD));
            self.transmitted_compute =
                Some(self.build_compute(device, "cs_transmitted", &constants));
        }
        if plan.bounce_layer.is_some() && self.bounce_compute.is_none() {
            let constants = spread_constants(&whole);
            self.bounce_compute = Some(self.build_compute(device, "cs_bounce", &constants));
        }
        if self.clear_compute.is_none()
            && (self.transmitted_compute.is_some() || self.bounce_compute.is_some())
        {
            self.clear_compute = Some(self.build_compute(device, "cs_clear", &whole));
        }
    }

    /// Whether the plan last given to [`Self::prepare`] has the map filled at all.
    pub fn runs(&self) -> bool {
        self.map_holds_transmitted || self.bounce_layer.is_some()
    }

    /// The compute evaluation `entry` of transmitted_map.wgsl with the overrides `constants`:
    /// `diffusion` whole, the lateral taps included, as the map pass's fragment shader
    /// evaluates it (LATERAL_SOURCE 2, or 3 where the taps are spread over lanes).
    fn build_compute(
        &self,
        device: &wgpu::Device,
        entry: &str,
        constants: &[(&str, f64)],
    ) -> wgpu::ComputePipeline {
        device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some(entry),
            layout: Some(&self.compute_layout),
            module: &self.module,
            entry_point: Some(entry),
            compilation_options: wgpu::PipelineCompilationOptions {
                constants,
                ..Default::default()
            },
            cache: None,
        })
    }

    /// The transmitted map's pass (timed "transmitted"): the transmitted light into its layers where
    /// the plan has the map hold it, writing the map's z-buffer; then the bounce pass (timed "bounce") into the
    /// bounce layer, testing against it. Where the targets hold the texels' surfaces (and the
    /// pipelines are built), the first raster pass records them (`fs_surface`) and compute
    /// dispatches evaluate both (`cs_transmitted`, `cs_bounce`); otherwise the fragment shaders
    /// do (`fs_transmitted`, `fs_bounce`).
    #[allow(clippy::too_many_arguments)]
    pub fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        map: &TransmittedMapTargets,
        frame: &wgpu::BindGroup,
        objects: &[GpuObject],
        maps: &[wgpu::BindGroup],
        default_maps: &wgpu::BindGroup,
        profiler: Option<&wgpu_profiler::GpuProfiler>,
    ) {
        let groups = Groups {
            frame,
            maps,
            default_maps,
        };
        let transmitted = self.map_holds_transmitted && map.layer_count >= TRANSMITTED_LAYERS;
        let bounce = self.bounce_layer.filter(|&l| l < map.layer_count);
        let transmitted_compute = self.transmitted_compute.as_ref().filter(|_| transmitted);
        let bounce_compute = self.bounce_compute.as_ref().filter(|_| bounce.is_some());
        let computed = map.surface.as_ref().filter(|_| {
            self.clear_compute.is_some()
                && (!transmitted || transmitted_compute.is_some())
                && (bounce.is_none() || bounce_compute.is_some())
        });
        if let Some(surface) = computed {
            // The surfaces' raster pass is timed with the first pass it serves.
            let pass = MapPass {
                timed: if transmitted { "transmitted" } else { "bounce" },
                targets: surface.targets.iter().collect(),
                first: true,
                pipeline: &self.surface,
            };
            self.encode_map_pass(encoder, map, &pass, objects, &groups, profiler);
            // Each object's dispatch writes only its own texels, within its box: the rest of
            // the map must read as nothing (depth 0), which the first compute pass clears.
            // A dispatch clears it for less than render passes that only clear its layers.
            let mut clear = self.clear_compute.as_ref();
            for (timed, pipeline) in [
                ("transmitted", transmitted_compute),
                ("bounce", bounce_compute),
            ] {
                if let Some(pipeline) = pipeline {
                    let compute = Compute {
                        timed,
                        clear: clear.take(),
                        pipeline,
                        surface,
                    };
                    self.encode_compute(encoder, &compute, map, &groups, objects, profiler);
                }
            }
            return;
        }
        let mut first = true;
        if transmitted {
            let pass = MapPass {
                timed: "transmitted",
                targets: map.layers[..TRANSMITTED_LAYERS as usize].iter().collect(),
                first,
                pipeline: &self.transmitted,
            };
            self.encode_map_pass(encoder, map, &pass, objects, &groups, profiler);
            first = false;
        }
        if let Some(layer) = bounce {
            let pass = MapPass {
                timed: "bounce",
                targets: vec![&map.layers[layer as usize]],
                first,
                pipeline: &self.bounce[usize::from(!first)],
            };
            self.encode_map_pass(encoder, map, &pass, objects, &groups, profiler);
        }
    }

    /// A compute evaluation of transmitted_map.wgsl once per object (timed as `compute.timed`, summed
    /// with the surfaces' raster pass where that is timed alike): each dispatch covers its
    /// object's box and evaluates the texels whose surface is its object's.
    fn encode_compute(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        compute: &Compute<'_>,
        map: &TransmittedMapTargets,
        groups: &Groups<'_>,
        objects: &[GpuObject],
        profiler: Option<&wgpu_profiler::GpuProfiler>,
    ) {
        let timed = compute.timed;
        let timer = TimedPass::begin(profiler, timed, encoder);
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some(timed),
                timestamp_writes: timer.compute_writes(),
            });
            pass.set_bind_group(0, groups.frame, &[]);
            pass.set_bind_group(2, &compute.surface.bind_group, &[]);
            if let (Some(clear), Some(o)) = (compute.clear, objects.first()) {
                pass.set_pipeline(clear);
                pass.set_bind_group(1, &o.bind_group, &[]);
                pass.set_bind_group(
                    3,
                    &self.object_rects.bind_group,
                    &[self.object_rects.whole_offset()],
                );
                pass.dispatch_workgroups(
                    map.width.div_ceil(TEXEL_BLOCK),
                    map.height.div_ceil(TEXEL_BLOCK),
                    1,
                );
            }
            pass.set_pipeline(compute.pipeline);
            for (k, o) in objects.iter().enumerate() {
                let Some((offset, w, h)) =
                    self.object_rects
                        .dispatch(k, map.downsample, map.width, map.height)
                else {
                    continue;
                };
                pass.set_bind_group(1, &o.bind_group, &[]);
                pass.set_bind_group(3, &self.object_rects.bind_group, &[offset]);
                pass.dispatch_workgroups(
                    w.div_ceil(SPREAD_BLOCK[0]),
                    h.div_ceil(SPREAD_BLOCK[1]),
                    1,
                );
            }
        }
        timer.end(profiler, encoder);
    }

    /// One pass of [`MapPass`] over the transmitted map.
    fn encode_map_pass(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        map: &TransmittedMapTargets,
        map_pass: &MapPass<'_>,
        objects: &[GpuObject],
        groups: &Groups<'_>,
        profiler: Option<&wgpu_profiler::GpuProfiler>,
    ) {
        let timer = TimedPass::begin(profiler, map_pass.timed, encoder);
        {
            let attachments: Vec<_> = map_pass
                .targets
                .iter()
                .map(|view| {
                    util::color_attachment(view, wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT))
                })
                .collect();
            let mut pass = util::render_pass(
                encoder,
                map_pass.timed,
                &attachments,
                // Kept: the next pass shades the surfaces this one found nearest.
                util::depth_attachment(
                    &map.zbuffer,
                    if map_pass.first {
                        wgpu::LoadOp::Clear(1.0)
                    } else {
                        wgpu::LoadOp::Load
                    },
                    wgpu::StoreOp::Store,
                ),
                timer.writes(),
            );
            util::draw_objects(
                &mut pass,
                map_pass.pipeline,
                groups.frame,
                objects,
                groups.maps,
                groups.default_maps,
            );
        }
        timer.end(profiler, encoder);
    }
}

/// The lighting pass's groups the map's passes bind: 0 (`frame`) and each object's 2.
struct Groups<'a> {
    frame: &'a wgpu::BindGroup,
    maps: &'a [wgpu::BindGroup],
    default_maps: &'a wgpu::BindGroup,
}

/// The map's raster pipelines with `terms`: `fs_transmitted` and `fs_surface` (each keeping
/// the nearest surface in the map's z-buffer), and `fs_bounce` as the first pass of a frame
/// and after another.
fn raster_pipelines(
    device: &wgpu::Device,
    module: &wgpu::ShaderModule,
    layout: &wgpu::PipelineLayout,
    terms: Terms,
) -> [wgpu::RenderPipeline; 4] {
    let constants = diffusion_whole(terms, WHOLE);
    // Back faces culled, so no depth pre-pass is needed to run the taps about once a texel
    // (the lighting pass draws both sides, for open meshes: a pixel whose back face shows
    // finds no texel of its surface and takes the chord's slab alone; mesh transforms keep
    // mirrored objects' winding, `Mesh::transform`).
    let raster = |fragment, targets, depth| {
        util::MeshPipeline {
            label: "transmitted",
            layout,
            module,
            vertex: "vs_main",
            fragment,
            targets,
            cull_mode: Some(wgpu::Face::Back),
            depth,
            stencil: None,
            constants: &constants,
            blend: None,
        }
        .create(device)
    };
    let pair: &[wgpu::TextureFormat] = &[TRANSMITTED_MAP_FORMAT, TRANSMITTED_MAP_FORMAT];
    let single: &[wgpu::TextureFormat] = &[TRANSMITTED_MAP_FORMAT];
    [
        raster("fs_transmitted", pair, util::DepthTest::Nearest),
        raster("fs_surface", pair, util::DepthTest::Nearest),
        raster("fs_bounce", single, util::DepthTest::Nearest),
        raster("fs_bounce", single, util::DepthTest::Prepassed),
    ]
}
