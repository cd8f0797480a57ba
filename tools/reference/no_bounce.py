# The sample() below is adapted from Mitsuba 3.9.1's python/ad/integrators/prbvolpath.py,
# distributed under this license:
#
# Copyright (c) 2017 Wenzel Jakob <wenzel.jakob@epfl.ch>, All rights reserved.
#
# Redistribution and use in source and binary forms, with or without
# modification, are permitted provided that the following conditions are met:
#
# 1. Redistributions of source code must retain the above copyright notice, this
#    list of conditions and the following disclaimer.
#
# 2. Redistributions in binary form must reproduce the above copyright notice,
#    this list of conditions and the following disclaimer in the documentation
#    and/or other materials provided with the distribution.
#
# 3. Neither the name of the copyright holder nor the names of its contributors
#    may be used to endorse or promote products derived from this software
#    without specific prior written permission.
#
# THIS SOFTWARE IS PROVIDED BY THE COPYRIGHT HOLDERS AND CONTRIBUTORS "AS IS" AND
# ANY EXPRESS OR IMPLIED WARRANTIES, INCLUDING, BUT NOT LIMITED TO, THE IMPLIED
# WARRANTIES OF MERCHANTABILITY AND FITNESS FOR A PARTICULAR PURPOSE ARE
# DISCLAIMED. IN NO EVENT SHALL THE COPYRIGHT HOLDER OR CONTRIBUTORS BE LIABLE
# FOR ANY DIRECT, INDIRECT, INCIDENTAL, SPECIAL, EXEMPLARY, OR CONSEQUENTIAL
# DAMAGES (INCLUDING, BUT NOT LIMITED TO, PROCUREMENT OF SUBSTITUTE GOODS OR
# SERVICES; LOSS OF USE, DATA, OR PROFITS; OR BUSINESS INTERRUPTION) HOWEVER
# CAUSED AND ON ANY THEORY OF LIABILITY, WHETHER IN CONTRACT, STRICT LIABILITY,
# OR TORT (INCLUDING NEGLIGENCE OR OTHERWISE) ARISING IN ANY WAY OUT OF THE USE
# OF THIS SOFTWARE, EVEN IF ADVISED OF THE POSSIBILITY OF SUCH DAMAGE.

"""A volumetric path tracer without light between parts: a path ends where, after leaving a
surface into the air, it reaches another surface. What is left is what a real-time renderer
without global illumination computes: light that reaches the surface point the camera sees
directly from a light, or through the medium behind it, after any number of scattering
events inside. Light that one part of the skin sends another across the air (a finger's
glow on its neighbour, a reflection off a cheek into the nose's shadow) is left out, and
light that leaves the medium and enters it again elsewhere, even on the same mesh, with it.

`render_reference.py --no-bounce` renders with it (docs/lab/fidelity.md, finding 9). It is the
primal part of Mitsuba 3.9.1's `prbvolpath` integrator (its license above), with that one
rule added; on a scene where no path can leave one surface and reach another (a single convex
part) it renders what `volpath` does.
"""

import drjit as dr
import mitsuba as mi
from mitsuba.ad.integrators.common import mis_weight
from mitsuba.ad.integrators.prbvolpath import PRBVolpathIntegrator, index_spectrum


class NoBounceIntegrator(PRBVolpathIntegrator):
    @dr.syntax
    def sample(self, mode, scene, sampler, ray, δL, state_in, active, **kwargs):
        if mode != dr.ADMode.Primal:
            raise RuntimeError("volpath_nobounce renders only (no derivatives)")
        self.prepare_scene(scene)

        ray = mi.Ray3f(ray)
        L = mi.Spectrum(0)
        throughput = mi.Spectrum(1)
        η = mi.Float(1)
        active = mi.Bool(active)

        si = dr.zeros(mi.SurfaceInteraction3f)
        needs_intersection = mi.Bool(True)
        last_scatter_event = dr.zeros(mi.Interaction3f)
        last_scatter_direction_pdf = mi.Float(1.0)
        medium = dr.zeros(mi.MediumPtr)
        channel = 0
        depth = mi.UInt32(0)
        valid_ray = mi.Bool(False)
        specular_chain = mi.Bool(True)
        # The rule: true once the path has left a surface into the air. Its next surface is
        # another part's (or the same mesh's elsewhere): the path ends there.
        in_air = mi.Bool(False)

        if mi.is_rgb:
            n_channels = dr.size_v(mi.Spectrum)
            channel = mi.UInt32(dr.minimum(n_channels * sampler.next_1d(active), n_channels - 1))

        while dr.hint(active, label="volpath_nobounce"):
            active &= dr.any(throughput != 0.0)

            q = dr.minimum(dr.max(throughput) * dr.square(η), 0.99)
            perform_rr = depth > self.rr_depth
            active &= (sampler.next_1d(active) < q) | ~perform_rr
            throughput[perform_rr] = throughput * dr.rcp(q)

            active_medium = active & (medium != None)  # noqa: E711 (a Dr.Jit pointer compare)
            active_surface = active & ~active_medium

            u = sampler.next_1d(active_medium)
            mei = medium.sample_interaction(ray, u, channel, active_medium)
            mei.t = dr.detach(mei.t)
            ray.maxt[active_medium & medium.is_homogeneous() & mei.is_valid()] = mei.t
            intersect = needs_intersection & active_medium
            si[intersect] = scene.ray_intersect(ray, intersect)
            needs_intersection &= ~active_medium
            mei.t[active_medium & (si.t < mei.t)] = dr.inf

            tr, free_flight_pdf = medium.transmittance_eval_pdf(mei, si, active_medium)
            tr_pdf = index_spectrum(free_flight_pdf, channel)
            weight = mi.Spectrum(1.0)
            weight[active_medium] *= dr.select(tr_pdf > 0.0, tr / dr.detach(tr_pdf), 0.0)

            escaped_medium = active_medium & ~mei.is_valid()
            active_medium &= mei.is_valid()

            if dr.hint(self.handle_null_scattering, mode="scalar"):
                scatter_prob = dr.mean(mei.sigma_t / mei.combined_extinction)
                act_null_scatter = (sampler.next_1d(active_medium) >= scatter_prob) & active_medium
                act_medium_scatter = ~act_null_scatter & active_medium
                weight[act_null_scatter] *= mei.sigma_n / dr.detach(1 - scatter_prob)
            else:
                scatter_prob = mi.Float(1.0)
                act_medium_scatter = active_medium

            depth[act_medium_scatter] += 1
            last_scatter_event[act_medium_scatter] = dr.detach(mei)
            active &= depth < self.max_depth
            act_medium_scatter &= active
            if dr.hint(self.handle_null_scattering, mode="scalar"):
                ray.o[act_null_scatter] = dr.detach(mei.p)
                si.t[act_null_scatter] = si.t - dr.detach(mei.t)

            weight[act_medium_scatter] *= mei.sigma_s / dr.detach(scatter_prob)
            throughput *= dr.detach(weight)

            mei = dr.detach(mei)
            phase_ctx = mi.PhaseFunctionContext(sampler)
            phase = mei.medium.phase_function()
            phase[~act_medium_scatter] = dr.zeros(mi.PhaseFunctionPtr)

            active_surface |= escaped_medium
            intersect = active_surface & needs_intersection
            si[intersect] = scene.ray_intersect(ray, intersect)

            count_direct = (active_surface & (depth == 0)) | specular_chain
            emitter = si.emitter(scene)
            active_e = active_surface & (emitter != None) & ~((depth == 0) & self.hide_emitters)  # noqa: E711
            ds = mi.DirectionSample3f(scene, si, last_scatter_event)
            emitter_pdf = scene.pdf_emitter_direction(last_scatter_event, ds, active_e)
            emitted = emitter.eval(si, active_e)
            contrib = dr.select(count_direct, throughput * emitted,
                                throughput * mis_weight(last_scatter_direction_pdf, emitter_pdf) * emitted)
            L[active_e] += dr.detach(contrib)

            active_surface &= si.is_valid()
            # The rule: a surface reached through the air after a surface event is another
            # part's; nothing from it (its direct light included) reaches the camera here.
            active_surface &= ~in_air
            ctx = mi.BSDFContext()
            bsdf = si.bsdf(ray)

            active_e_surface = active_surface & mi.has_flag(bsdf.flags(), mi.BSDFFlags.Smooth) & (depth + 1 < self.max_depth)
            sample_emitters = mei.medium.use_emitter_sampling()
            specular_chain &= ~act_medium_scatter
            specular_chain |= act_medium_scatter & ~sample_emitters
            active_e_medium = act_medium_scatter & sample_emitters
            active_e = active_e_surface | active_e_medium
            emitted, ds = self.sample_emitter(mei, si, active_e_medium, active_e_surface,
                                              scene, sampler, medium, channel, active_e, mode=dr.ADMode.Primal)
            bsdf_val, bsdf_pdf = bsdf.eval_pdf(ctx, si, si.to_local(ds.d), active_e_surface)
            phase_val, phase_pdf = phase.eval_pdf(phase_ctx, mei, ds.d, active_e_medium)
            nee_weight = dr.select(active_e_surface, bsdf_val, phase_val)
            nee_directional_pdf = dr.select(ds.delta, 0.0, dr.select(active_e_surface, bsdf_pdf, phase_pdf))
            contrib = throughput * nee_weight * mis_weight(ds.pdf, nee_directional_pdf) * emitted
            L[active_e] += dr.detach(contrib)

            valid_ray |= act_medium_scatter
            wo, phase_weight, phase_pdf = phase.sample(phase_ctx, mei,
                                                       sampler.next_1d(act_medium_scatter),
                                                       sampler.next_2d(act_medium_scatter),
                                                       act_medium_scatter)
            act_medium_scatter &= phase_pdf > 0.0
            throughput[act_medium_scatter] *= phase_weight
            ray[act_medium_scatter] = mei.spawn_ray(wo)
            needs_intersection |= act_medium_scatter
            last_scatter_direction_pdf[act_medium_scatter] = phase_pdf

            bs, bsdf_weight = bsdf.sample(ctx, si,
                                          sampler.next_1d(active_surface),
                                          sampler.next_2d(active_surface),
                                          active_surface)
            active_surface &= bs.pdf > 0
            throughput[active_surface] *= bsdf_weight
            η[active_surface] *= bs.eta
            ray[active_surface] = si.spawn_ray(si.to_world(bs.wo))
            needs_intersection |= active_surface
            non_null_bsdf = active_surface & ~mi.has_flag(bs.sampled_type, mi.BSDFFlags.Null)
            depth[non_null_bsdf] += 1
            last_scatter_event[non_null_bsdf] = si
            last_scatter_direction_pdf[non_null_bsdf] = bs.pdf
            valid_ray |= non_null_bsdf
            specular_chain |= non_null_bsdf & mi.has_flag(bs.sampled_type, mi.BSDFFlags.Delta)
            specular_chain &= ~(active_surface & mi.has_flag(bs.sampled_type, mi.BSDFFlags.Smooth))
            has_medium_trans = active_surface & si.is_medium_transition()
            medium[has_medium_trans] = si.target_medium(ray.d)
            # Leaving a surface with no medium ahead: the path is in the air. (A null event,
            # a surface with no BSDF of its own, keeps the path where it was.)
            in_air[non_null_bsdf] = medium == None  # noqa: E711
            active &= active_surface | active_medium

        return L, valid_ray, [], L

    def to_string(self):
        return f"NoBounceIntegrator[max_depth = {self.max_depth}]"


def register():
    mi.register_integrator("volpath_nobounce", lambda props: NoBounceIntegrator(props))
