#!/usr/bin/env python3
"""How much light a backlit curved part lets through, against a slab as thick as its chord.

    python3 tools/reference/confinement_mc.py [--media skin1,skin2] [--radii 3,5,8]
        [--shapes cylinder,sphere] [--channels 0,1] [--photons 500000] [--out FILE.json]
    python3 tools/reference/confinement_mc.py --against references/confinement_mc.json [--out FILE.json]
    python3 tools/reference/confinement_mc.py --tilts 15,35 [--renderer] [--media ...] [--out FILE.json]
    python3 tools/reference/confinement_mc.py --windows 90@0.5,120@0.8 [--renderer] [--media ...] [--out FILE.json]
    python3 tools/reference/confinement_mc.py --against references/confinement_windows.json

A Monte Carlo random walk (numpy) in a homogeneous medium with a smooth dielectric boundary
and an isotropic phase function, sigma_s' used as sigma_s as the exporter does (similarity
relation). A collimated beam lights the part from behind along +u; the score is the radiance
leaving the front pole toward +u (directions within `--cone` of it, through a window of
`--window` mm), per unit of the beam's cross-section. The same is done for a slab whose
thickness is the part's diameter. Their ratio is the part's confinement against the chord's
slab: what the renderer's chord term, which reads a slab table, would have to be multiplied
by at the middle of a backlit rod or ball.

Why it exists (docs/lab/suite.md, session 32): the path tracer's references of backlit rods
(the calibration set) showed the chord's slab too bright by 1.35-1.65x in skin2 and by about
1.0-1.17x in skin1 at the same 10 mm; a quantity that predicts that difference had not been
found. This walk reproduces it in seconds per point, for any sigma_a, sigma_s' and radius,
without the path tracer's hours, so a correction can be fitted against physics rather than
against the suite it is tested on.
"""

import argparse
import functools
import json
import os
import subprocess
import sys
import tempfile
from concurrent.futures import ProcessPoolExecutor

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.normpath(os.path.join(HERE, "..", ".."))

# sigma_s', sigma_a per mm (Jensen et al. 2001; materials.rs) and the boundary's index.
MEDIA = {
    "skin1": ([0.74, 0.88, 1.01], [0.032, 0.17, 0.48], 1.3),
    "skin2": ([1.09, 1.59, 1.79], [0.013, 0.070, 0.145], 1.3),
    "marble": ([2.19, 2.62, 3.00], [0.0021, 0.0041, 0.0071], 1.3),
    "chicken1": ([0.15, 0.21, 0.38], [0.015, 0.077, 0.19], 1.3),
    "custom": ([0.6, 0.9, 0.7], [0.12, 0.025, 0.08], 1.5),
}


def fresnel_out(cos_i, eta):
    """Reflectance and cos of the transmitted angle leaving a medium of index eta."""
    sin_t2 = eta * eta * (1.0 - cos_i * cos_i)
    cos_t = np.sqrt(np.maximum(1.0 - sin_t2, 0.0))
    rs = (eta * cos_i - cos_t) / (eta * cos_i + cos_t + 1e-12)
    rp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t + 1e-12)
    r = 0.5 * (rs * rs + rp * rp)
    r[sin_t2 >= 1.0] = 1.0
    return r, cos_t


def walk(shape, radius, sigma_s, sigma_a, eta, photons, window, cone, seed, tilt_deg=0.0, at=0.0):
    """Radiance toward +u at the front pole, per unit of beam cross-section (arbitrary units,
    the same for every shape). `tilt_deg`: the beam turned that far off +u toward +v (a
    cylinder's or a sphere's light off the axis; the slab is lit head-on only). `at`: the
    window's middle along v, in radii (0: the pole)."""
    rng = np.random.default_rng(seed)
    n = photons
    sigma_t = sigma_s + sigma_a
    albedo = sigma_s / sigma_t
    # Where the beam enters, and the outward normal there. Coordinates: u toward the front pole
    # (the camera), v across, w along a cylinder's axis.
    if shape == "slab":
        half = 8.0 * radius
        v = rng.uniform(-half, half, n)
        pos = np.stack([np.full(n, -radius), v, np.zeros(n)], 1)
        beam_area, window_area = 2.0 * half, 2.0 * window
        normal = np.tile([-1.0, 0.0, 0.0], (n, 1))
        beam = np.array([1.0, 0.0, 0.0])
    else:
        a = np.radians(tilt_deg)
        beam = np.array([np.cos(a), np.sin(a), 0.0])
        across = np.array([-np.sin(a), np.cos(a), 0.0])
        if shape == "cylinder":
            x, w = rng.uniform(-radius, radius, n), np.zeros(n)
            beam_area, window_area = 2.0 * radius, 2.0 * window
        else:
            rr = radius * np.sqrt(rng.random(n))
            ph = rng.uniform(0.0, 2.0 * np.pi, n)
            x, w = rr * np.cos(ph), rr * np.sin(ph)
            beam_area, window_area = np.pi * radius * radius, (2.0 * window) ** 2
        # The beam's line through (x across, w) meets the part first where it enters.
        q = x[:, None] * across[None, :] + w[:, None] * np.array([0.0, 0.0, 1.0])[None, :]
        axes = 2 if shape == "cylinder" else 3
        c = np.sum(q[:, :axes] ** 2, 1) - radius * radius
        pos = q - np.sqrt(np.maximum(-c, 0.0))[:, None] * beam[None, :]
        normal = pos.copy()
        normal[:, axes:] = 0.0
        normal /= radius
    incident = np.tile(beam, (n, 1))
    cos_i = -np.sum(incident * normal, 1)
    sin_t = np.sqrt(np.maximum(1.0 - cos_i * cos_i, 0.0)) / eta
    cos_t = np.sqrt(1.0 - sin_t * sin_t)
    rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t)
    rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t)
    weight = 1.0 - 0.5 * (rs * rs + rp * rp)
    d = incident / eta + (cos_i / eta - cos_t)[:, None] * normal
    d /= np.linalg.norm(d, axis=1)[:, None]
    alive = np.ones(n, bool)
    # Light that leaves unscattered is not the diffusion this measures: the renderer's
    # unscattered lobe is a term of its own (and a delta beam has no radiance to compare).
    scattered = np.zeros(n, bool)
    # Ten interleaved batches give the estimate's standard error.
    score = np.zeros(10)
    while True:
        idx = np.nonzero(alive)[0]
        if idx.size == 0:
            break
        p, dd = pos[idx], d[idx]
        t = -np.log(rng.random(idx.size)) / sigma_t
        if shape == "slab":
            t_b = np.where(dd[:, 0] > 0, (radius - p[:, 0]) / np.maximum(dd[:, 0], 1e-30),
                           (-radius - p[:, 0]) / np.minimum(dd[:, 0], -1e-30))
        else:
            axes = 2 if shape == "cylinder" else 3
            a = np.sum(dd[:, :axes] ** 2, 1)
            b = 2.0 * np.sum(p[:, :axes] * dd[:, :axes], 1)
            c = np.sum(p[:, :axes] ** 2, 1) - radius * radius
            t_b = (-b + np.sqrt(np.maximum(b * b - 4 * a * c, 0.0))) / (2 * a + 1e-30)
        hit = t_b < t
        sc = idx[~hit]
        pos[sc] += d[sc] * t[~hit][:, None]
        weight[sc] *= albedo
        scattered[sc] = True
        mu = rng.uniform(-1.0, 1.0, sc.size)
        ph = rng.uniform(0.0, 2.0 * np.pi, sc.size)
        s = np.sqrt(1.0 - mu * mu)
        d[sc] = np.stack([mu, s * np.cos(ph), s * np.sin(ph)], 1)
        low = sc[weight[sc] < 1e-3]
        if low.size:
            keep = rng.random(low.size) < 0.1
            weight[low[keep]] *= 10.0
            alive[low[~keep]] = False
        hb = idx[hit]
        pos[hb] += d[hb] * t_b[hit][:, None]
        pb = pos[hb]
        if shape == "slab":
            nb = np.zeros_like(pb)
            nb[:, 0] = np.sign(pb[:, 0])
        elif shape == "cylinder":
            nb = pb.copy()
            nb[:, 2] = 0.0
            nb /= radius
        else:
            nb = pb / radius
        ci = np.clip(np.sum(d[hb] * nb, 1), 0.0, 1.0)
        refl_p, ct = fresnel_out(ci, eta)
        refl = rng.random(hb.size) < refl_p
        r = hb[refl]
        d[r] -= 2.0 * ci[refl][:, None] * nb[refl]
        pos[r] -= nb[refl] * 1e-7
        out = hb[~refl]
        d_out = eta * d[out] + (ct[~refl] - eta * ci[~refl])[:, None] * nb[~refl]
        seen = (d_out[:, 0] > cone) & (pos[out, 0] > 0.0) & scattered[out]
        if shape == "slab":
            # Any point of the slab's front face sees the same light: score all of them.
            window_area = beam_area
        else:
            seen &= np.abs(pos[out, 1] - at * radius) < window
        if shape == "sphere":
            seen &= np.abs(pos[out, 2]) < window
        score += np.bincount(out[seen] % 10, weights=weight[out[seen]], minlength=10)
        alive[out] = False
    per_batch = score / (n / 10) * beam_area / window_area
    return per_batch.mean(), per_batch.std(ddof=1) / np.sqrt(10)


SCENE = """[camera]
position = [0.0, 0.0, 0.2]
target = [0.0, 0.0, 0.0]
fov_y_deg = {fov}
near = 0.05
far = 2.0

[render]
width = 128
height = 128
ambient = [0.0, 0.0, 0.0]
background = [0.0, 0.0, 0.0]
transmittance = {{ normal_shrink = 0.0005 }}

[[lights]]
kind = "spot"
position = [{light_x}, 0.0, {light_z}]
target = [0.0, 0.0, 0.0]
intensity = 3.675
inner_angle_deg = 9.0
outer_angle_deg = 14.0
shadow_map_size = 2048
shadow_bias = 0.0005

[[objects]]
name = "part"
mesh = {mesh}
mm_per_unit = 1000.0

[objects.material]
medium = {{ sigma_a = {sa}, sigma_s = {ss}, eta = {eta} }}
use_gltf_color = false
roughness = 0.3
specular = 1.0
"""


@functools.lru_cache(maxsize=None)
def renderer_centre(medium, shape, radius, extra, tilt_deg=0.0, at=0.0, window=None):
    """The renderer's linear radiance (R, G, B) at the middle of the part, seen from the
    front with the light straight behind it: `subsurface compare --linear` on a 128 x 128
    frame 4 R wide, read over the pixels whose chord is within 1 % of the diameter (a
    cylinder's axis runs up the frame)."""
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    ss, sa, eta = MEDIA[medium]
    m = radius / 1000.0
    mesh = {"slab": f'{{ shape = "slab", width = {16 * m}, height = {16 * m}, thickness = {2 * m} }}',
            "cylinder": f'{{ shape = "cylinder", radius = {m}, length = {24 * m}, segments = 256 }}',
            "sphere": f'{{ shape = "sphere", radius = {m}, segments = 192 }}'}[shape]
    fov = 2.0 * np.degrees(np.arctan(2.0 * m / 0.2))
    exe = os.environ.get("SUBSURFACE_BIN") or os.path.join(ROOT, "target", "release", "subsurface")
    with tempfile.TemporaryDirectory() as tmp:
        scene = os.path.join(tmp, "part.toml")
        with open(scene, "w") as f:
            # The light behind, turned off the axis about the cylinder's axis (the middle's
            # light is the same either way round).
            a = np.radians(tilt_deg)
            f.write(SCENE.format(fov=fov, mesh=mesh, sa=list(sa), ss=list(ss), eta=eta,
                                 light_x=-0.35 * np.sin(a), light_z=-0.35 * np.cos(a)))
        # compare wants a reference of the frame's size; any one does, its figures are unused.
        ref = os.path.join(tmp, "ref.exr")
        mi.Bitmap(np.zeros((128, 128, 3), dtype=np.float32)).write(ref)
        out = os.path.join(tmp, "linear.exr")
        # The diffuse light alone: the unscattered and once-scattered terms are the renderer's
        # own, apart from the diffusion the walk scores.
        r = subprocess.run([exe, "compare", ref, scene, "--linear", out, "--out", os.path.join(tmp, "x.png"),
                            "--sss", "none", "--set", "transmittance.ballistic=false",
                            "--set", "transmittance.single_scattering=false"] + list(extra),
                           capture_output=True, text=True)
        if r.returncode != 0:
            sys.exit(f"error: {exe} compare: {r.stderr.strip()}")
        img = np.array(mi.Bitmap(out))[..., :3]
    # The frame spans 4 R: pixel x sees x' = (x + 0.5 - 64) R / 32; |x'| <= 0.14 R keeps the
    # chord within 1 % of the diameter.
    half = 4
    rows = slice(32, 96) if shape == "cylinder" else slice(64 - half, 64 + half)
    if window is None:
        return img[rows, 64 - half:64 + half].reshape(-1, 3).mean(0)
    # The walk's window (`at` radii across, `window` mm either side) in pixels: 32 a radius.
    x = 64.0 + 32.0 * at
    w = max(32.0 * window / radius, 0.5)
    cols = slice(int(round(x - w)), int(round(x + w)))
    return img[rows, cols].reshape(-1, 3).mean(0)


def renderer_args(a):
    """--renderer-args as a tuple (renderer_centre's cache key)."""
    return tuple(a.renderer_args.split()) if a.renderer_args else ()


def renderer_ratio(medium, shape, radius, channel, extra):
    """The renderer's middle of the part over that of the slab as thick as its diameter."""
    q = renderer_centre(medium, "slab", radius, extra)[channel]
    return float(renderer_centre(medium, shape, radius, extra)[channel] / q) if q > 0 else None


def point(job):
    medium, shape, radius, channel, a, seed = job
    ss, sa, eta = MEDIA[medium]
    part, part_se = walk(shape, radius, ss[channel], sa[channel], eta, a.photons, a.window, a.cone, seed)
    slab, slab_se = walk("slab", radius, ss[channel], sa[channel], eta, a.photons, a.window, a.cone, seed + 1)
    ratio = part / slab if slab > 0 else None
    ratio_se = ratio * np.hypot(part_se / part, slab_se / slab) if ratio and part > 0 else None
    ours = None
    if a.renderer:
        ours = renderer_ratio(medium, shape, radius, channel, renderer_args(a))
    return {"medium": medium, "shape": shape, "radius_mm": radius, "channel": "RGB"[channel],
            "sigma_s_prime": ss[channel], "sigma_a": sa[channel],
            "sigma_tr": float(np.sqrt(3 * sa[channel] * (sa[channel] + ss[channel]))),
            "part": part, "slab": slab, "ratio": ratio, "ratio_stderr": ratio_se, "renderer_ratio": ours}


def tilt_point(job):
    medium, shape, radius, channel, tilts, a, seed = job
    ss, sa, eta = MEDIA[medium]
    # (tilt, window) pairs: the pole lit on the axis first, then each tilt at each window.
    cases = [(0.0, 0.0)] + [(t, x) for t in tilts[1:] for x in a.at]
    walks = [walk(shape, radius, ss[channel], sa[channel], eta, a.photons, a.window, a.cone, seed, t, x)
             for t, x in cases]
    ours = None
    if a.renderer:
        extra = renderer_args(a)
        ours = [renderer_centre(medium, shape, radius, extra, t, x, a.window)[channel] for t, x in cases]
    return medium, shape, radius, channel, cases, walks, ours


def tilts(a):
    """Each part's middle (or the windows `--at` across it) lit off the axis over its middle lit
    on it, the walk's and the renderer's."""
    angles = [0.0] + [t for t in a.tilts if t != 0.0]
    jobs = [(m, sh, r, c, angles, a, seed) for m, sh, r, c, seed in grid(a, a.shapes)]
    points = []
    with ProcessPoolExecutor(a.jobs) as ex:
        for medium, shape, radius, channel, cases, walks, ours in ex.map(tilt_point, jobs):
            w0, s0 = walks[0]
            for k, (t, x) in enumerate(cases[1:], 1):
                wk, sk = walks[k]
                ratio = wk / w0
                se = ratio * np.hypot(sk / wk, s0 / w0) if wk > 0 else 0.0
                pt = {"medium": medium, "shape": shape, "radius_mm": radius, "channel": "RGB"[channel],
                      "tilt_deg": t, "at_radii": x, "walk_ratio": ratio, "walk_stderr": se,
                      "renderer_ratio": None if ours is None or ours[0] <= 0 else float(ours[k] / ours[0])}
                points.append(pt)
                line = (f"{medium:9} {shape:8} R {radius:4.1f} mm {pt['channel']}  {t:4.0f} deg  at {x:+.2f} R  "
                        f"walk {ratio:.3f} +- {se:.3f}")
                if pt["renderer_ratio"] is not None:
                    line += f"  renderer {pt['renderer_ratio']:.3f}  ({pt['renderer_ratio'] / ratio:.2f}x)"
                print(line, flush=True)
    if a.out:
        with open(a.out, "w") as f:
            json.dump({"photons": a.photons, "window_mm": a.window, "cone": a.cone, "tilts": points}, f, indent=1)


def window_job(job):
    medium, radius, channel, cases, a, seed = job
    ss, sa, eta = MEDIA[medium]
    slab = walk("slab", radius, ss[channel], sa[channel], eta, a.photons, a.window, a.cone, seed)
    walks = [walk("cylinder", radius, ss[channel], sa[channel], eta, a.photons, a.window, a.cone,
                  seed + k + 1, t, x) for k, (t, x) in enumerate(cases)]
    ours = renderer_windows(medium, radius, channel, cases, renderer_args(a), a.window) if a.renderer else None
    return medium, radius, channel, cases, slab, walks, ours


def renderer_windows(medium, radius, channel, cases, extra, window):
    """The renderer's windows (tilt, at; `window` mm either side) of a cylinder, each over the
    slab as thick as its diameter lit head-on; None where the slab is black."""
    q = renderer_centre(medium, "slab", radius, extra)[channel]
    if q <= 0:
        return None
    return [float(renderer_centre(medium, "cylinder", radius, extra, t, x, window)[channel] / q)
            for t, x in cases]


def print_window(w):
    line = (f"{w['medium']:7} {w['channel']} {2 * w['radius_mm']:4.0f} mm  {w['tilt_deg']:4.0f} deg "
            f"at {w['at_radii']:+.2f} R  walk {w['walk_ratio']:.3g} +- {w['walk_stderr']:.2g}")
    if w.get("renderer_ratio") is not None and w["walk_ratio"] > 0:
        line += f"  renderer {w['renderer_ratio']:.3g}  ({w['renderer_ratio'] / w['walk_ratio']:.2f}x)"
    print(line, flush=True)


def mean_log_off(ws):
    """Mean |log(renderer / walk)| over the windows the walk knows to 10 %."""
    off = [abs(np.log(w["renderer_ratio"] / w["walk_ratio"])) for w in ws
           if w.get("renderer_ratio") and w["walk_ratio"] > 0 and w["walk_stderr"] < 0.1 * w["walk_ratio"]]
    if off:
        print(f"mean |log(renderer / walk)| over the {len(off)} windows the walk knows to 10 %: "
              f"{sum(off) / len(off):.3f}")


def windows(a):
    """Windows across cylinders lit from any side (`--windows TILT@AT`: the beam turned TILT
    degrees off the axis behind the part about its axis, past 90 from the camera's side; the
    window AT radii across, + away from the light), each over a slab as thick as the diameter
    lit head-on: absolute, so that the middle, the rims and the band past a side-lit
    terminator are all checked, for the walk and (with --renderer) the renderer."""
    jobs = [(m, r, c, a.windows, a, seed) for m, _, r, c, seed in grid(a, ["cylinder"])]
    out = []
    with ProcessPoolExecutor(a.jobs) as ex:
        for medium, radius, channel, cases, (s0, e0), walks, ours in ex.map(window_job, jobs):
            for k, ((t, x), (wk, ek)) in enumerate(zip(cases, walks)):
                ratio = wk / s0 if s0 > 0 else 0.0
                se = ratio * np.hypot(ek / wk, e0 / s0) if wk > 0 and s0 > 0 else 0.0
                w = {"medium": medium, "shape": "cylinder", "radius_mm": radius, "channel": "RGB"[channel],
                     "tilt_deg": t, "at_radii": x, "walk_ratio": ratio, "walk_stderr": se,
                     "renderer_ratio": None if ours is None else ours[k]}
                out.append(w)
                print_window(w)
    mean_log_off(out)
    if a.out:
        with open(a.out, "w") as f:
            json.dump({"photons": a.photons, "window_mm": a.window, "cone": a.cone, "windows": out}, f, indent=1)


def against_windows(a, doc):
    """`--against` for a table of `--windows`: each rod's slab rendered once, then its windows."""
    extra = renderer_args(a)
    groups = {}
    try:
        for w in doc["windows"]:
            if w["medium"] not in MEDIA or w["channel"] not in ("R", "G", "B"):
                raise ValueError(f"unknown medium or channel {w['medium']!r} {w['channel']!r}")
            float(w["radius_mm"]), float(w["tilt_deg"]), float(w["at_radii"]), float(w["walk_ratio"]), float(w["walk_stderr"])
            groups.setdefault((w["medium"], w["radius_mm"], w["channel"]), []).append(w)
    except (KeyError, TypeError, ValueError) as e:
        sys.exit(f"error: {a.against}: a window without its medium, channel, radius, tilt, place or walk ({e})")
    for (medium, radius, ch), ws in groups.items():
        cases = [(w["tilt_deg"], w["at_radii"]) for w in ws]
        ours = renderer_windows(medium, radius, "RGB".index(ch), cases, extra, doc.get("window_mm", 0.5))
        for k, w in enumerate(ws):
            w["renderer_ratio"] = None if ours is None else ours[k]
            print_window(w)
    mean_log_off(doc["windows"])
    if a.out:
        with open(a.out, "w") as f:
            json.dump(doc, f, indent=1)


def against(a):
    """The renderer's part / slab at each point of a walk's table, without walking again: what a
    change to the renderer does to its agreement with the walk, in seconds."""
    try:
        with open(a.against) as f:
            doc = json.load(f)
    except (OSError, ValueError) as e:
        sys.exit(f"error: {a.against}: {e}")
    if isinstance(doc, dict) and isinstance(doc.get("windows"), list):
        return against_windows(a, doc)
    if not isinstance(doc, dict) or not isinstance(doc.get("points"), list):
        sys.exit(f"error: {a.against}: not a table of this tool's --out (no points or windows)")
    extra = renderer_args(a)
    off = []
    for pt in doc["points"]:
        c = "RGB".index(pt["channel"])
        ours = renderer_ratio(pt["medium"], pt["shape"], pt["radius_mm"], c, extra)
        pt["renderer_ratio"] = ours
        walk_ratio, se = pt["ratio"], pt["ratio_stderr"]
        line = f"{pt['medium']:9} {pt['shape']:8} R {pt['radius_mm']:4.1f} mm {pt['channel']}  walk "
        line += "-" if walk_ratio is None else f"{walk_ratio:.3f} +- {se:.3f}"
        line += "  renderer -" if ours is None else f"  renderer {ours:.3f}"
        if ours is not None and walk_ratio:
            line += f"  ({ours / walk_ratio:.2f}x)"
            if se is not None and se < 0.1 * walk_ratio:
                off.append(abs(ours / walk_ratio - 1.0))
        print(line, flush=True)
    if off:
        print(f"mean |renderer / walk - 1| over the {len(off)} points the walk knows to 10 %: "
              f"{sum(off) / len(off):.3f}")
    if a.out:
        with open(a.out, "w") as f:
            json.dump(doc, f, indent=1)


def parse_lists(a):
    """The comma-separated options as lists, each bad value a one-line error naming its option."""
    def numbers(option, text, kind=float):
        try:
            return [kind(x) for x in text.split(",")]
        except ValueError:
            sys.exit(f"error: --{option}: expected comma-separated numbers (got {text!r})")
    a.media = a.media.split(",")
    for m in a.media:
        if m not in MEDIA:
            sys.exit(f"error: --media: unknown medium {m!r} (known: {', '.join(MEDIA)})")
    a.shapes = a.shapes.split(",")
    for sh in a.shapes:
        if sh not in ("slab", "cylinder", "sphere"):
            sys.exit(f"error: --shapes: unknown shape {sh!r} (known: slab, cylinder, sphere)")
    a.radii = numbers("radii", a.radii)
    if any(not r > 0 for r in a.radii):
        sys.exit(f"error: --radii: every radius must be above 0 mm (got {a.radii})")
    a.channels = numbers("channels", a.channels, int)
    if any(c not in (0, 1, 2) for c in a.channels):
        sys.exit(f"error: --channels: 0 (red), 1 (green) or 2 (blue) (got {a.channels})")
    a.at = numbers("at", a.at)
    if a.tilts:
        a.tilts = numbers("tilts", a.tilts)
    if a.windows:
        try:
            a.windows = [(float(t), float(x)) for t, x in (c.split("@") for c in a.windows.split(","))]
        except ValueError:
            sys.exit(f"error: --windows: expected TILT@AT pairs, e.g. 90@0.5,120@0.8 (got {a.windows!r})")


def grid(a, shapes):
    """(medium, shape, radius, channel, seed) over the options' grid, each job its own seed."""
    return [(m, sh, r, c, 1000 * i) for i, (m, sh, r, c) in
            enumerate((m, sh, r, c) for m in a.media for sh in shapes for r in a.radii for c in a.channels)]


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--media", default="skin1,skin2")
    p.add_argument("--radii", default="3,5,8", help="mm, comma-separated")
    p.add_argument("--shapes", default="cylinder,sphere")
    p.add_argument("--channels", default="0,1", help="0 red, 1 green, 2 blue")
    p.add_argument("--photons", type=int, default=500000)
    p.add_argument("--window", type=float, default=0.5, help="half-width of the scored window, mm")
    p.add_argument("--cone", type=float, default=0.97, help="cos of the scored cone around +u")
    p.add_argument("--jobs", type=int, default=2)
    p.add_argument("--renderer", action="store_true",
                   help="also render the part and the slab with the renderer (SUBSURFACE_BIN or "
                        "target/release/subsurface, --sss none) and give its ratio beside the walk's")
    p.add_argument("--renderer-args", default="", help="extra arguments to the renderer, e.g. '--quality high'")
    p.add_argument("--out", default="", help="write the points as JSON here")
    p.add_argument("--against", metavar="JSON",
                   help="walk nothing: render the points of this table (e.g. references/confinement_mc.json) "
                        "with the renderer and print its ratio beside the walk's, with the ratio of the two; "
                        "--out then writes the table with the renderer's column refreshed")
    p.add_argument("--tilts", metavar="DEG,DEG",
                   help="instead of part / slab: the part's middle with the beam turned this far off the "
                        "axis (about a cylinder's axis), over its middle lit on the axis, for the walk and "
                        "(with --renderer) the renderer: how the light through a part falls as the light "
                        "moves off the axis behind it")
    p.add_argument("--at", default="0", help="with --tilts: where the window lies across the part, in radii "
                   "(comma-separated; 0 the pole, + away from the light)")
    p.add_argument("--windows", metavar="TILT@AT,..",
                   help="instead of part / slab at the pole: windows across cylinders lit from any side, "
                        "the beam TILT degrees off the axis behind the part (past 90 from the camera's side), "
                        "the window AT radii across (+ away from the light), each over the slab as thick as "
                        "the diameter lit head-on, for the walk and (with --renderer) the renderer")
    a = p.parse_args()
    parse_lists(a)
    if a.against:
        return against(a)
    if a.windows:
        return windows(a)
    if a.tilts:
        return tilts(a)
    jobs = [(m, sh, r, c, a, seed) for m, sh, r, c, seed in grid(a, a.shapes)]
    points = []
    with ProcessPoolExecutor(a.jobs) as ex:
        for pt in ex.map(point, jobs):
            points.append(pt)
            ratio = "-" if pt["ratio"] is None else f"{pt['ratio']:.2f} +- {pt['ratio_stderr']:.2f}"
            if pt["renderer_ratio"] is not None:
                ratio += f"  renderer {pt['renderer_ratio']:.2f}"
            print(f"{pt['medium']:9} {pt['shape']:8} R {pt['radius_mm']:4.1f} mm {pt['channel']}  "
                  f"sigma_tr R {pt['sigma_tr'] * pt['radius_mm']:5.2f}  part {pt['part']:.3g}  "
                  f"slab {pt['slab']:.3g}  ratio {ratio}", flush=True)
    if a.out:
        with open(a.out, "w") as f:
            json.dump({"photons": a.photons, "window_mm": a.window, "cone": a.cone, "points": points}, f, indent=1)


if __name__ == "__main__":
    main()
