#!/usr/bin/env python3
"""One bounce of each light between the skin's parts, integrated exactly: what a real-time
renderer without global illumination leaves out (docs/lab/fidelity.md, finding 9).

    subsurface export-mitsuba SCENE.toml --out DIR
    subsurface compare REF.exr SCENE.toml --linear OURS.exr
    python3 tools/reference/bounce_integral.py SCENE.toml DIR/scene.xml \
        [--ours OURS.exr --reference REF.exr] [--stride 2] [--reflection-only] \
        [--no-visibility | --cluster MM [--ring N]]

For every camera pixel on the skin (every `--stride`-th row and column) it sums the light that
the lit surface sends it across the air: each light is traced onto the scene on a fine grid of
directions, and every lit point sends the shaded point what entered it and came back out
(`albedo x E cos`, the renderer's diffuse radiance) and its rough boundary's reflection of the
light (Cook-Torrance with Beckmann facets, Smith masking, Schlick's Fresnel: the renderer's
specular term, `subsurface_profile::specular`). The shaded point takes that in as irradiance
(its diffuse light: albedo x irradiance) and reflects it toward the camera with the same
boundary. Both points must face each other and see each other (a ray test through the
exported meshes). Every surface is taken to be the skin of `--albedo` / `--roughness` /
`--eta` (skin1's by default); `--reflection-only` keeps the lit points' reflection and drops
their diffuse light, for a neighbour of black medium behind the same boundary. The light that
crosses a part and leaves its unlit side (its glow) is not in it.

Two options measure what a real-time gather from the shadow map would get of it:
`--no-visibility` drops the ray test (a shadow map cannot make it), and `--cluster MM` sums
the lit points into a flux pyramid (cells MM wide across the light, each level twice as wide)
and gathers each shaded point from cells `--ring` to 2 `--ring` cells away at every level, as
a few hundred texel reads per point would.

Prints, per region of SCENE.regions.json (and the whole skin), the bounce's mean radiance (over
the picked pixels) and, with --ours and --reference, the region's relative error in luminance
with and without it (over every pixel: the reference's noise needs them all).
Needs Mitsuba 3 with a vectorised variant (llvm_ad_rgb, picked as render_reference.py does, or
cuda_ad_rgb with --variant) and numpy. Spot and directional lights only.
"""

import argparse
import json
import math
import os
import sys
import tomllib

try:
    import numpy as np
except ImportError:
    sys.exit("error: bounce_integral.py needs numpy (python3 -m pip install numpy)")


def parse_args(argv):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("toml", help="the scene file (lights, camera size, regions beside it)")
    p.add_argument("xml", help="its export: scene.xml written by `subsurface export-mitsuba`")
    p.add_argument("--ours", help="our linear radiance (`subsurface compare --linear`)")
    p.add_argument("--reference", help="the path-traced reference EXR")
    p.add_argument("--stride", type=int, default=2, help="every N-th row and column (default 2)")
    p.add_argument("--grid", type=float, default=0.4,
                   help="spacing of the lit points on the scene, mm (default 0.4)")
    p.add_argument("--albedo", default="0.432,0.2096,0.1135",
                   help="diffuse albedo R,G,B of every surface (default skin1's R_d)")
    p.add_argument("--roughness", type=float, default=0.3, help="Beckmann alpha (default 0.3)")
    p.add_argument("--eta", type=float, default=1.3, help="index of refraction (default 1.3)")
    p.add_argument("--variant", default="auto",
                   help="Mitsuba variant: auto (llvm_ad_rgb when libLLVM is found), llvm_ad_rgb, cuda_ad_rgb")
    p.add_argument("--reflection-only", action="store_true",
                   help="lit points only reflect (a black medium behind the same boundary)")
    p.add_argument("--no-visibility", action="store_true",
                   help="skip the ray test between the points (what a gather from a reflective "
                        "shadow map, which cannot test it, would add up)")
    p.add_argument("--cluster", type=float, default=0.0, metavar="MM",
                   help="gather from clusters of lit points MM wide across the light instead of "
                        "from every point, as a real-time gather from a flux pyramid of the "
                        "shadow map would (implies --no-visibility; see --ring)")
    p.add_argument("--ring", type=float, default=4.0,
                   help="with --cluster: each level of the pyramid (cells twice as wide as the "
                        "level below) serves the shaded points from `ring` to 2 `ring` of its "
                        "cells away, the first level every cell nearer; 0 gathers every cluster "
                        "at the finest level (default 4)")
    a = p.parse_args(argv)
    if a.cluster > 0:
        a.no_visibility = True
    for path in [a.toml, a.xml] + [x for x in (a.ours, a.reference) if x]:
        if not os.path.isfile(path):
            p.error(f"{path}: no such file")
    if a.stride < 1:
        p.error("--stride: must be at least 1")
    if not a.grid > 0:
        p.error("--grid: must be positive")
    if not a.cluster >= 0 or not a.ring >= 0:
        p.error("--cluster, --ring: must not be negative")
    try:
        a.albedo = np.array([float(x) for x in a.albedo.split(",")])
        assert a.albedo.shape == (3,)
    except (ValueError, AssertionError):
        p.error("--albedo: three numbers R,G,B")
    return a


def beckmann(c, a):
    c2 = np.maximum(c * c, 1e-4)
    return np.exp(-(1 - c2) / c2 / (a * a)) / (a * a * c2 * c2)


def smith_g1(c, a):
    c = np.clip(c, 1e-4, 1.0)
    x = c / (a * np.sqrt(np.maximum(1 - c * c, 1e-8)))
    return np.where(x >= 1.6, 1.0, (3.535 * x + 2.181 * x * x) / (1 + 2.276 * x + 2.577 * x * x))


def reflection(n, l, v, alpha, eta):
    """pi f_r N.L of the rough boundary (subsurface_profile::specular::boundary_reflection)."""
    nl, nv = (n * l).sum(-1), (n * v).sum(-1)
    h = l + v
    hl = np.linalg.norm(h, axis=-1)
    h = h / np.maximum(hl, 1e-9)[..., None]
    e = (1 - np.clip((v * h).sum(-1), 0, 1)) ** 5
    r0 = ((eta - 1) / (eta + 1)) ** 2
    f = e + r0 * (1 - e)
    val = beckmann(np.maximum((n * h).sum(-1), 0), alpha) * f * smith_g1(nv, alpha) * smith_g1(nl, alpha) \
        / (4 * np.maximum(nv, 1e-6))
    return np.where((nl > 0) & (nv > 0) & (hl > 1e-6), val, 0.0)


class Senders:
    """The lit points as a flux pyramid: level k groups the points of cells `base` x 2^k grid
    steps wide, and keeps per cell its flux (`wd`: what the light delivers, which it sends on
    diffusely), the flux-weighted position and normal sum (a cell's cosines toward a direction
    add up linearly while none is negative), and for the boundary's reflection the points'
    flux over their cosine (`ws`) with their mean normal and light direction."""

    def __init__(self, x, n, l, wd, ws, ij, base, ring):
        self.levels, self.ring = [], ring
        span = int(ij.max()) + 2
        k = 0
        while True:
            size = base << k
            key = (ij[:, 0] // size) * (span // size + 2) + ij[:, 1] // size
            cells, inv = np.unique(key, return_inverse=True)

            def total(v):
                out = np.zeros((len(cells),) + v.shape[1:])
                np.add.at(out, inv, v)
                return out

            def unit(v):
                return v / np.maximum(np.linalg.norm(v, axis=-1), 1e-30)[:, None]

            w = total(wd)
            self.levels.append(dict(
                size=size, wd=w, ws=total(ws), nd=total(n * wd[:, None]),
                x=total(x * wd[:, None]) / np.maximum(w, 1e-30)[:, None],
                ij=total(ij * wd[:, None]) / np.maximum(w, 1e-30)[:, None],
                n=unit(total(n * ws[:, None])), l=unit(total(l * ws[:, None]))))
            if ring == 0 or len(cells) == 1:
                break
            k += 1

    def gather(self, p, np_, v, at, diffuse, a):
        """The bounce at shaded points p (normals np_, views v; `at`: their places on the
        grid), per unit of the light's colour."""
        out = np.zeros((len(p), 3))
        last = len(self.levels) - 1
        for k, c in enumerate(self.levels):
            r = np.linalg.norm(at[:, None, :] - c["ij"][None], axis=-1) / c["size"]
            near = np.ones(r.shape, bool) if k == last else r < 2 * self.ring
            far = np.ones(r.shape, bool) if k == 0 else r >= self.ring
            off = p[:, None, :] - c["x"][None]
            d2 = (off * off).sum(-1)
            wv = off / np.sqrt(np.maximum(d2, 1e-30))[..., None]
            cos_p = -(np_[:, None] * wv).sum(-1)
            i, j = np.nonzero(near & far & (cos_p > 0) & (d2 > 0))
            if len(i) == 0:
                continue
            wij = wv[i, j]
            cos_d = np.maximum((c["nd"][j] * wij).sum(-1), 0.0)
            cos_s = np.maximum((c["n"][j] * wij).sum(-1), 0.0)
            sent = diffuse[None] * cos_d[:, None] \
                + (c["ws"][j] * reflection(c["n"][j], c["l"][j], wij, a.roughness, a.eta) * cos_s)[:, None]
            taken = a.albedo[None] * cos_p[i, j][:, None] / math.pi \
                + reflection(np_[i], -wij, v[i], a.roughness, a.eta)[:, None] / math.pi
            np.add.at(out, i, sent * taken / d2[i, j][:, None])
        return out


def rows(a):
    a = np.array(a)
    return a.T if a.ndim == 2 and a.shape[0] == 3 else a


def main(argv):
    a = parse_args(argv)
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from render_reference import pick_variant

    variant = pick_variant(a.variant)
    if variant.startswith("scalar"):
        sys.exit("error: --variant: the integral traces millions of rays at once and needs "
                 "llvm_ad_rgb (install libllvm19) or cuda_ad_rgb")
    import mitsuba as mi

    mi.set_variant(variant)
    try:
        with open(a.toml, "rb") as f:
            desc = tomllib.load(f)
    except tomllib.TOMLDecodeError as e:
        sys.exit(f"error: {a.toml}: {e}")
    regions_path = os.path.splitext(a.toml)[0] + ".regions.json"
    regions = [{"name": "skin", "rect": [0, 0, 1, 1]}]
    if os.path.exists(regions_path):
        with open(regions_path) as f:
            regions += json.load(f)["regions"]
    scene = mi.load_file(a.xml, spp=1)
    sensor = scene.sensors()[0]
    w, h = sensor.film().crop_size()
    # Scene units per millimetre, for the lit points' spacing and the ray offsets: the first
    # object's scale (every canonical and experiment scene is in metres throughout).
    mm = 1.0 / desc.get("objects", [{}])[0].get("mm_per_unit", 1000.0)

    ys, xs = np.mgrid[0:h, 0:w]
    picked = ((ys % a.stride) == 0) & ((xs % a.stride) == 0)
    uv = np.stack([(xs.ravel() + 0.5) / w, (ys.ravel() + 0.5) / h], -1)
    rays, _ = sensor.sample_ray(0.0, 0.5, mi.Point2f(uv[:, 0], uv[:, 1]), mi.Point2f(0.5, 0.5))
    si = scene.ray_intersect(rays)
    on_skin = np.array(si.is_valid())
    points, normals, views = rows(si.p), rows(si.sh_frame.n), -rows(rays.d)
    back = (normals * views).sum(-1) < 0
    normals[back] *= -1
    shaded = np.nonzero(on_skin & picked.ravel())[0]
    bounce = np.zeros((w * h, 3))

    for light in desc.get("lights", []):
        kind = light.get("kind", "point")
        if kind not in ("spot", "directional"):
            sys.exit(f"error: {a.toml}: light kind {kind!r}: only spot and directional lights")
        pos = np.array(light.get("position", [0, 0, 0]), float)
        target = np.array(light.get("target", [0, 0, 0]), float)
        colour = np.array(light.get("color", [1, 1, 1]), float) * light.get("intensity", 1.0)
        axis = (target - pos) / np.linalg.norm(target - pos)
        side = np.cross(axis, [0.0, 1.0, 0.0] if abs(axis[1]) < 0.9 else [1.0, 0.0, 0.0])
        side /= np.linalg.norm(side)
        up = np.cross(side, axis)
        # The lit points: the light traced onto the scene on a grid across its beam at the
        # target's distance, `--grid` mm apart.
        reach = np.linalg.norm(target - pos)
        half = reach * math.tan(math.radians(light.get("outer_angle_deg", 30.0))) if kind == "spot" else \
            np.linalg.norm(np.array(scene.bbox().extents()))
        n = int(2 * half / (a.grid * mm)) + 1
        gx, gy = np.meshgrid(np.linspace(-half, half, n), np.linspace(-half, half, n))
        gij = np.stack(np.meshgrid(np.arange(n), np.arange(n)), -1).reshape(-1, 2)
        across = gx.ravel()[:, None] * side + gy.ravel()[:, None] * up
        if kind == "spot":
            d = axis + across / reach
            dl = np.linalg.norm(d, axis=-1)
            d /= dl[:, None]
            origins = np.repeat(pos[None], len(d), 0)
            cell = (2 * half / (n - 1)) ** 2 / reach ** 2 / dl ** 3  # solid angle per ray
        else:
            d = np.repeat(axis[None], len(across), 0)
            origins = target - axis * 2 * half + across
            cell = np.full(len(d), (2 * half / (n - 1)) ** 2)  # area across the beam
        hit = scene.ray_intersect(mi.Ray3f(mi.Point3f(*origins.T), mi.Vector3f(*d.T)))
        ok = np.array(hit.is_valid())
        x, nx, t = rows(hit.p)[ok], rows(hit.sh_frame.n)[ok], np.array(hit.t)[ok]
        to_light = -d[ok]
        flip = (nx * to_light).sum(-1) < 0
        nx[flip] *= -1
        cos_i = (nx * to_light).sum(-1)
        if kind == "spot":
            cos_outer = math.cos(math.radians(light.get("outer_angle_deg", 30.0)))
            cos_inner = math.cos(math.radians(light.get("inner_angle_deg", 20.0)))
            s = np.clip(((d[ok] * axis).sum(-1) - cos_outer) / (cos_inner - cos_outer), 0, 1)
            fall = s * s * (3 - 2 * s) / (t * t)  # radiance x 1/d^2, per unit area across
            area = cell[ok] * t * t / np.maximum(cos_i, 1e-3)
        else:
            fall = np.ones(len(x))
            area = cell[ok] / np.maximum(cos_i, 1e-3)
        keep = cos_i > 1e-3
        x, nx, to_light, cos_i, fall, area = x[keep], nx[keep], to_light[keep], cos_i[keep], fall[keep], area[keep]
        irr = fall[:, None] * colour
        diffuse = np.zeros(3) if a.reflection_only else a.albedo
        print(f"{light.get('kind')} light: {len(x)} lit points", file=sys.stderr)
        if a.cluster > 0:
            def grid_of(q):
                # The shaded points' places on the light's grid, in grid steps.
                if kind == "spot":
                    rel = q - pos
                    q = rel / (rel @ axis)[:, None] * reach
                else:
                    q = q - target
                return np.stack([q @ side, q @ up], -1) / (2 * half) * (n - 1) + (n - 1) / 2
            senders = Senders(x, nx, to_light, fall * cos_i * area, fall * area, gij[ok][keep],
                              max(int(round(a.cluster / a.grid)), 1), a.ring)
            for k in range(0, len(shaded), 64):
                px = shaded[k:k + 64]
                bounce[px] += colour[None] * senders.gather(points[px], normals[px], views[px],
                                                            grid_of(points[px]), diffuse, a)
            continue
        for k in range(0, len(shaded), 64):
            px = shaded[k:k + 64]
            p, np_, v = points[px], normals[px], views[px]
            off = p[:, None, :] - x[None]  # lit point -> shaded point
            d2 = (off * off).sum(-1)
            wv = off / np.sqrt(np.maximum(d2, 1e-30))[..., None]
            cos_x = (nx[None] * wv).sum(-1)
            cos_p = -(np_[:, None] * wv).sum(-1)
            i, j = np.nonzero((cos_x > 0) & (cos_p > 0) & (d2 > 0))
            if len(i) == 0:
                continue
            wij = wv[i, j]
            # Seen from each other: a ray from the lit point stopping a millimetre short (the
            # meshes' facets would otherwise hide grazing pairs from themselves).
            o = x[j] + nx[j] * 1e-3 * mm
            dist = np.sqrt(d2[i, j])
            test = mi.Ray3f(mi.Ray3f(mi.Point3f(*o.T), mi.Vector3f(*wij.T)), mi.Float(np.maximum(dist - mm, 1e-9)))
            seen = np.ones(len(i), bool) if a.no_visibility else ~np.array(scene.ray_test(test))
            i, j, wij = i[seen], j[seen], wij[seen]
            solid = cos_x[i, j] * area[j] / d2[i, j]
            sent = irr[j] * (reflection(nx[j], to_light[j], wij, a.roughness, a.eta)[:, None]
                             + diffuse[None] * cos_i[j][:, None])
            taken = a.albedo[None] * cos_p[i, j][:, None] / math.pi \
                + reflection(np_[i], -wij, v[i], a.roughness, a.eta)[:, None] / math.pi
            np.add.at(bounce, px[i], sent * taken * solid[:, None])

    def image(path):
        try:
            pixels = np.array(mi.Bitmap(path).convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32))
        except Exception as e:  # Mitsuba raises RuntimeError for unreadable files
            sys.exit(f"error: {path}: {str(e).splitlines()[0] if str(e) else 'cannot read'}")
        if pixels.shape[:2] != (h, w):
            sys.exit(f"error: {path}: {pixels.shape[1]}x{pixels.shape[0]}, the scene renders {w}x{h}")
        return pixels.reshape(h * w, 3)

    ours = image(a.ours) if a.ours else None
    ref = image(a.reference) if a.reference else None
    lum = np.array([0.2126, 0.7152, 0.0722])
    for r in regions:
        x0, y0, x1, y1 = r["rect"]
        m = np.zeros((h, w), bool)
        m[int(y0 * h):int(math.ceil(y1 * h)), int(x0 * w):int(math.ceil(x1 * w))] = True
        m = m.ravel() & on_skin
        # The bounce is smooth and deterministic: the picked pixels estimate its mean. The
        # reference is not (a few very bright paths a pixel): its mean takes every pixel.
        b = bounce[m & picked.ravel()].mean(0)
        line = f"{r['name']:<34} pixels {m.sum():5}  bounce {b[0]:.4f} {b[1]:.4f} {b[2]:.4f}"
        if ours is not None and ref is not None:
            o, f = ours[m].mean(0), ref[m].mean(0)
            line += f"  ours {o @ lum / (f @ lum) - 1:+.1%}  ours + bounce {(o + b) @ lum / (f @ lum) - 1:+.1%}"
        print(line)


if __name__ == "__main__":
    main(sys.argv[1:])
