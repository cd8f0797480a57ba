#!/usr/bin/env python3
"""The generated fidelity suite (issue 39): scenes over media x shapes x light directions, a
held-out third, and their path-traced references.

    python3 tools/reference/suite.py generate            # scenes/suite/*.toml, *.regions.json, suite.json
    python3 tools/reference/suite.py holdout             # scenes/suite/holdout.json (before any render)
    python3 tools/reference/suite.py render [NAME ...] [--spp N] [--max-depth D] [--rr-depth R]
    python3 tools/reference/suite.py depth-sweep NAME --depths 64,256,1024 [--spp N] [--size S]
    python3 tools/reference/suite.py check [NAME ...]
    python3 tools/reference/suite.py queue               # the render order
    python3 tools/reference/suite.py report [NAME ...]   # real-time errors: references/suite/report.json,
                                                         # a Markdown table, docs/images/generalization.png
    python3 tools/reference/suite.py explain [NAME ...]  # each miss rendered with one part changed at a time
    python3 tools/reference/suite.py --set calibration ...  # the same on the calibration set of curved parts

Run from the repository root with a `subsurface` binary (SUBSURFACE_BIN, else target/release or
target/debug) and Mitsuba 3 (`python3 -m pip install mitsuba==3.9.1`; libllvm19 for the fast
variant). The head scenes need ../shared/assets (the Lee Perry-Smith head).

The grid is not the full cross product: `DESIGN` below lists the scenes, chosen so that every
medium, shape and light direction appears, and so that the classes the canonical set missed
(thick parts lit from behind off the axis, in several media; outlines the light grazes) are
crossed with several media each.

Regions are computed from the geometry, not drawn: each scene is exported with
`subsurface export-mitsuba`, and a ray is cast through every pixel centre of the exported
camera into the exported meshes (Mitsuba, scalar variant). Each hit pixel gets its surface
normal, the thickness the view ray crosses, whether each light sees it, and its distance to the
silhouette; each region is the largest rectangle of pixels of one class (lit side, terminator
band, far side, centre, light-side outline, far outline, thick part, thin part) lying at least
`INSET_PX` pixels inside the silhouette. Classes that cover most of the object (the lit side of
a front-lit slab) or repeat another region are dropped.

References (`render`) reuse render_reference.py: each channel of a chromatic medium rendered
grey, passes giving the standard-error image. One change to the exported scene: the exporter
writes Russian roulette from depth 64 (`rr_depth`); in a medium whose albedo is near 1 (marble:
0.999) Mitsuba's roulette then keeps each path with probability 0.95 per event and multiplies
the survivors' weight by 1/0.95, so a path of 1000 events has weight 1e22 and probability 1e-22:
the estimator is unbiased only in theory. `--rr-depth` (default: equal to --max-depth, i.e. no
roulette) sets it; the spp, max depth, rr depth and time of each reference are recorded in
references/suite/manifest.json.
"""

import argparse
import datetime
import hashlib
import json
import math
import os
import re
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.normpath(os.path.join(HERE, "..", ".."))
sys.path.insert(0, HERE)
import render_reference  # noqa: E402
from make_references import subsurface_bin  # noqa: E402

SET = "suite"  # or "calibration" (--set): which design, scene folder and reference folder
SCENES = os.path.join(ROOT, "scenes", "suite")
# SUITE_REFS: another folder for the references (trials that must not touch the committed ones).
REFS = os.environ.get("SUITE_REFS") or os.path.join(ROOT, "references", "suite")
HOLDOUT_SEED = 39

# ---------------------------------------------------------------------------------------------
# The grid
# ---------------------------------------------------------------------------------------------

# Media: Jensen 2001 presets of different character, and one set of custom coefficients.
MEDIA = {
    "skin1": '"skin1"',  # Jensen's skin 1: the canonical medium
    "skin2": '"skin2"',  # Jensen's skin 2: less absorbing, scatters more (longer red diffusion)
    "marble": '"marble"',  # albedo 0.999: long diffusion, paths of thousands of events
    "ketchup": '"ketchup"',  # low scattering, strong green/blue absorption
    "chicken1": '"chicken1"',  # low scattering (red mean free path 6 mm), moderate absorption
    # Custom: a jade-like medium, green-tinted, moderately scattering, and eta 1.5 (every preset
    # has Jensen's 1.3), so the boundary's Fresnel is exercised too.
    "custom": "{ sigma_a = [0.12, 0.025, 0.08], sigma_s = [0.6, 0.9, 0.7], eta = 1.5 }",
}

# Shapes: (kind, size in metres); the camera looks along -z at the origin.
SHAPES = {
    "slab1": ("slab", 0.001),
    "slab3": ("slab", 0.003),
    "slab8": ("slab", 0.008),
    "slab15": ("slab", 0.015),
    "cyl8": ("cylinder", 0.008),  # diameters
    "cyl12": ("cylinder", 0.012),
    "cyl18": ("cylinder", 0.018),
    # Calibration radii (not in the suite's design; see CALIBRATION).
    "cyl6": ("cylinder", 0.006),
    "cyl10": ("cylinder", 0.010),
    "cyl14": ("cylinder", 0.014),
    "sph14": ("sphere", 0.014),
    "sph20": ("sphere", 0.020),
    "sph10": ("sphere", 0.010),
    "sph25": ("sphere", 0.025),
    "wedge": ("wedge", 0.025),  # 0..25 mm thick, as the canonical wedge
    "hand": ("hand", None),
    "head": ("head", None),
}

# Lights: (azimuth from the camera's axis about the vertical, degrees, + toward the image's
# right; elevation, degrees) for the key light, in the frame of the view direction. 0 = from
# the camera's side, 180 = from straight behind the object.
LIGHTS = {
    "front": [(0.0, 20.0, "front")],  # from the camera's side, 20 degrees above the axis
    "side60": [(60.0, 0.0, "front")],  # 60 degrees to the right of the axis
    "back0": [(180.0, 0.0, "back")],  # straight behind, on the axis
    "back15": [(165.0, 0.0, "back")],  # behind, 15 degrees off the axis (to the right)
    "back35": [(145.0, 0.0, "back")],  # behind, 35 degrees off the axis
    # Two at once: the back15 key and a dim front fill from the upper left.
    "two": [(165.0, 0.0, "back"), (-40.0, 20.0, "fill")],
}

# Irradiance each kind of light gives at the target (scene units as the canonical scenes:
# a front key of about 2, a back light of about 30).
IRRADIANCE = {"front": 2.0, "back": 30.0, "fill": 0.5}

# The designed subset: (shape, medium, light). Every medium, shape and light appears; the
# thick parts (slab8, slab15, cyl12, cyl18, sph25, wedge) are lit from behind 15 and 35
# degrees off the axis in several media; side and off-axis back lights give grazing outlines
# on every curved shape. Ketchup and chicken1 are kept off the 1 mm slab, whose thickness is
# below their red mean free path (4 and 6 mm).
DESIGN = [
    ("slab1", "skin1", "back0"),
    ("slab1", "marble", "back35"),
    ("slab1", "skin2", "back15"),
    ("slab1", "custom", "side60"),
    ("slab3", "skin2", "back35"),
    ("slab3", "chicken1", "back0"),
    ("slab3", "skin1", "two"),
    ("slab3", "marble", "front"),
    ("slab8", "skin1", "back35"),
    ("slab8", "skin2", "back15"),
    ("slab8", "marble", "back0"),
    ("slab8", "custom", "back35"),
    ("slab8", "ketchup", "front"),
    ("slab15", "skin1", "back15"),
    ("slab15", "skin2", "back35"),
    ("slab15", "marble", "back15"),
    ("slab15", "chicken1", "back35"),
    ("slab15", "custom", "back0"),
    ("cyl8", "skin1", "side60"),
    ("cyl8", "skin2", "back0"),
    ("cyl8", "ketchup", "back35"),
    ("cyl8", "marble", "two"),
    ("cyl12", "skin1", "back35"),
    ("cyl12", "skin2", "back35"),
    ("cyl12", "marble", "back35"),
    ("cyl12", "chicken1", "side60"),
    ("cyl12", "custom", "back15"),
    ("cyl18", "skin1", "back15"),
    ("cyl18", "skin2", "back15"),
    ("cyl18", "custom", "back35"),
    ("cyl18", "ketchup", "side60"),
    ("cyl18", "chicken1", "front"),
    ("sph10", "skin1", "front"),
    ("sph10", "skin2", "back15"),
    ("sph10", "marble", "side60"),
    ("sph10", "chicken1", "back35"),
    ("sph25", "skin1", "back35"),
    ("sph25", "skin2", "side60"),
    ("sph25", "marble", "back15"),
    ("sph25", "ketchup", "back0"),
    ("sph25", "custom", "two"),
    ("wedge", "skin1", "back15"),
    ("wedge", "skin2", "back35"),
    ("wedge", "marble", "back0"),
    ("wedge", "chicken1", "side60"),
    ("wedge", "custom", "front"),
    ("hand", "skin1", "back15"),
    ("hand", "skin2", "two"),
    ("hand", "marble", "back35"),
    ("hand", "chicken1", "front"),
    ("head", "skin1", "back35"),
    ("head", "skin2", "side60"),
    ("head", "ketchup", "two"),
    ("head", "custom", "back15"),
]

# The calibration set (issue 39, item 5): curved parts of sizes the suite does not have, in the
# two skins, lit from behind on and off the axis, rendered to fit constants against. The suite's
# own scenes are its test, so a constant fitted here leaves the whole suite held out.
# `suite.py --set calibration ...` works on it: scenes/calibration/, references/calibration/.
CALIBRATION = [
    (shape, medium, light)
    for shape in ("cyl6", "cyl10", "cyl14")
    for medium in ("skin1", "skin2")
    for light in ("back0", "back35")
] + [
    ("sph14", "skin1", "back15"),
    ("sph14", "skin2", "back15"),
    ("sph20", "skin2", "back35"),
]

# Rough cost of a shape's reference (image area covered, path lengths), for the render order.
SHAPE_COST = ["slab1", "slab3", "cyl6", "cyl8", "sph10", "slab8", "cyl10", "cyl12", "sph14", "cyl14", "wedge",
              "sph20", "sph25", "slab15", "cyl18", "hand", "head"]
MEDIUM_COST = ["ketchup", "chicken1", "skin1", "custom", "skin2", "marble"]

SIZE = 128  # image width and height (pixels); region means need few pixels
INSET_PX = 3  # every region lies at least this far inside the silhouette


def scene_name(shape, medium, light):
    return f"{shape}--{medium}--{light}"


def design():
    rows = CALIBRATION if SET == "calibration" else DESIGN
    names = [scene_name(*d) for d in rows]
    assert len(set(names)) == len(names), "duplicate scenes in the design"
    return {scene_name(*d): d for d in rows}


# ---------------------------------------------------------------------------------------------
# Scene files
# ---------------------------------------------------------------------------------------------


def vsub(a, b):
    return [a[i] - b[i] for i in range(3)]


def vadd(a, b):
    return [a[i] + b[i] for i in range(3)]


def vscale(a, s):
    return [x * s for x in a]


def dot(a, b):
    return sum(a[i] * b[i] for i in range(3))


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def norm(a):
    n = math.sqrt(dot(a, a))
    return [x / n for x in a]


def ff(x):
    """A TOML float (always with a point)."""
    s = f"{x:.6g}"
    return s if any(c in s for c in ".en") else s + ".0"


def fmt(v):
    return "[" + ", ".join(ff(x) for x in v) + "]"


def view_setup(shape):
    """(camera position, target, fov_y_deg, near, far, light distance, spot inner half-angle,
    object TOML lines, mm_per_unit, shadow bias, size, note) for a shape."""
    kind, size = SHAPES[shape]

    def canonical(mesh, fov, note, inner=9.0):
        # The canonical shapes' frame: 0.2 in front, the lights 0.35 away, millimetre units.
        return dict(cam=[0.0, 0.0, 0.2], target=[0.0, 0.0, 0.0], fov=fov, near=0.05, far=2.0,
                    dist=0.35, inner=inner, mesh=mesh, mm=1000.0, bias=0.0005, size=SIZE, extra="",
                    note=note)

    def fov_framing(width):
        return math.degrees(2 * math.atan(width / 2 / 0.2))

    if kind == "slab":
        # A slab wider than the view (80 mm, the view 20 mm across): an infinite slab, as the
        # canonical tilted slab. Uniform: its centre is one long average.
        mesh = f'mesh = {{ shape = "slab", width = 0.08, height = 0.08, thickness = {size:.6g} }}'
        return canonical(mesh, 5.7248,
                         f"a {size * 1000:.0f} mm slab, 80 mm square, wider than the view (20 mm)")
    if kind == "cylinder":
        r = size / 2
        # The cylinder fills 62 % of the width; longer than the view.
        mesh = f'mesh = {{ shape = "cylinder", radius = {r:.6g}, length = 0.12, segments = 256 }}'
        return canonical(mesh, fov_framing(2 * r * 1.6),
                         f"a {size * 1000:.0f} mm cylinder (a finger's proxy) seen side on, longer than the view")
    if kind == "sphere":
        r = size / 2
        mesh = f'mesh = {{ shape = "sphere", radius = {r:.6g}, segments = 128 }}'
        return canonical(mesh, fov_framing(2 * r * 1.5), f"a {size * 1000:.0f} mm sphere")
    if kind == "wedge":
        mesh = 'mesh = { shape = "wedge", length = 0.08, height = 0.06, max_thickness = 0.025 }'
        return canonical(mesh, 28.0, "the canonical wedge, 0 to 25 mm thick over 80 mm", inner=14.0)
    if kind == "hand":
        # The canonical hand's placement (palm to the camera), framed closer; 192 pixels: the
        # fingers are 15 mm wide.
        mesh = 'mesh = { gltf = "builtin:hand" }'
        extra = ("# The hand has ~8 facets around a finger: both renderers draw its smooth surface.\n"
                 "tessellate = 3\ntranslation = [-0.04, -0.028, 0.02]\nrotation_deg = [0.0, -90.0, 180.0]\n")
        return dict(cam=[-0.02, -0.005, 0.45], target=[-0.02, -0.005, 0.0], fov=26.0, near=0.05, far=5.0,
                    dist=0.35, inner=20.0, mesh=mesh, mm=1000.0, bias=0.0005, size=192, extra=extra,
                    note="the WebXR hand, palm to the camera")
    if kind == "head":
        mesh = 'mesh = { gltf = "../../../shared/assets/LeePerrySmith/LeePerrySmith.glb" }'
        return dict(cam=[3.0, 1.6, 11.0], target=[0.0, 1.4, 0.5], fov=24.0, near=1.0, far=100.0,
                    dist=12.0, inner=16.0, mesh=mesh, mm=48.0, bias=0.02, size=192, extra="",
                    note="the Lee Perry-Smith head seen from the front right")
    raise ValueError(shape)


def light_positions(setup, light):
    """[(position, intensity, kind)] of a light setting, in the frame of the view direction."""
    cam, target = setup["cam"], setup["target"]
    to_cam = norm(vsub(cam, target))
    up0 = [0.0, 1.0, 0.0]
    right = norm(cross(up0, to_cam))  # the image's right, seen from the camera
    up = cross(to_cam, right)
    out = []
    for az, el, kind in LIGHTS[light]:
        a, e = math.radians(az), math.radians(el)
        d = vadd(vadd(vscale(to_cam, math.cos(a) * math.cos(e)), vscale(right, math.sin(a) * math.cos(e))),
                 vscale(up, math.sin(e)))
        pos = vadd(target, vscale(d, setup["dist"]))
        out.append((pos, IRRADIANCE[kind] * setup["dist"] ** 2, kind))
    return out


def scene_toml(name):
    shape, medium, light = design()[name]
    s = view_setup(shape)
    lights = light_positions(s, light)
    azs = ", ".join(f"{az:g} deg azimuth / {el:g} deg elevation" for az, el, _ in LIGHTS[light])
    lines = [
        f"# Generated by tools/reference/suite.py (issue 39): do not edit, regenerate.",
        f"# {s['note']}; medium {medium}; light {light} ({azs} from the camera's axis).",
        "[camera]",
        f"position = {fmt(s['cam'])}",
        f"target = {fmt(s['target'])}",
        f"fov_y_deg = {ff(s['fov'])}",
        f"near = {ff(s['near'])}",
        f"far = {ff(s['far'])}",
        "",
        "[render]",
        f"width = {s['size']}",
        f"height = {s['size']}",
        "exposure_ev = 0.0",
        "# No ambient light and a black background, as the canonical scenes.",
        "ambient = [0.0, 0.0, 0.0]",
        "background = [0.0, 0.0, 0.0]",
    ]
    if SHAPES[shape][0] not in ("head",):
        lines.append("transmittance = { normal_shrink = 0.0005 }")
    for pos, intensity, kind in lights:
        inner = s["inner"]
        lines += [
            "",
            "[[lights]]",
            f"# {kind}",
            'kind = "spot"',
            f"position = {fmt(pos)}",
            f"target = {fmt(s['target'])}",
            f"intensity = {ff(intensity)}",
            f"inner_angle_deg = {ff(inner)}",
            f"outer_angle_deg = {ff(inner + 5)}",
            "shadow_map_size = 2048",
            f"shadow_bias = {ff(s['bias'])}",
        ]
    lines += [
        "",
        "[[objects]]",
        f'name = "{shape}"',
        s["mesh"],
        f"mm_per_unit = {ff(s['mm'])}",
    ]
    if s["extra"]:
        lines.append(s["extra"].rstrip("\n"))
    lines += [
        "",
        "[objects.material]",
        f"medium = {MEDIA[medium]}",
        "use_gltf_color = false",
        "roughness = 0.3",
        "# The physical rough dielectric boundary the path tracer renders.",
        "specular = 1.0",
        "",
    ]
    return "\n".join(lines)


# ---------------------------------------------------------------------------------------------
# Regions from the geometry
# ---------------------------------------------------------------------------------------------


def export(scene_path, out_dir):
    r = subprocess.run([subsurface_bin(), "export-mitsuba", scene_path, "--out", out_dir],
                       capture_output=True, text=True)
    if r.returncode != 0:
        raise RuntimeError(f"{scene_path}: export-mitsuba failed: {r.stderr.strip()}")


def pixel_geometry(xml, lights, W, H):
    """Per pixel (row-major): None (background) or a dict with the normal n, the view ray's
    direction d, the thickness it crosses, and per light (n.l, visible)."""
    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    scene = mi.load_file(xml)
    sensor = scene.sensors()[0]
    px = []
    for y in range(H):
        for x in range(W):
            ray, _ = sensor.sample_ray(0.0, 0.5, mi.Point2f((x + 0.5) / W, (y + 0.5) / H), mi.Point2f(0.5, 0.5))
            si = scene.ray_intersect(ray)
            if not si.is_valid():
                px.append(None)
                continue
            d = [float(ray.d[i]) for i in range(3)]
            n = [float(si.sh_frame.n[i]) for i in range(3)]
            if dot(n, d) > 0:
                n = vscale(n, -1.0)
            p = [float(si.p[i]) for i in range(3)]
            si2 = scene.ray_intersect(si.spawn_ray(ray.d))
            thick = float(si2.t) if si2.is_valid() else 0.0
            per_light = []
            for pos, _, _ in lights:
                l = norm(vsub(pos, p))
                vis = not scene.ray_test(si.spawn_ray_to(mi.Point3f(*pos)))
                per_light.append((dot(n, l), vis))
            px.append({"n": n, "d": d, "thick": thick, "lights": per_light})
    return px


def chamfer_distance(hit, W, H):
    """Distance in pixels from each pixel to the nearest background pixel (3-4 chamfer, /3);
    pixels beyond the image do not count as background (a slab or a cylinder continues)."""
    INF = 10 ** 9
    d = [0 if not hit[i] else INF for i in range(W * H)]
    for y in range(H):
        for x in range(W):
            i = y * W + x
            if d[i] == 0:
                continue
            best = d[i]
            for dx, dy, c in ((-1, 0, 3), (0, -1, 3), (-1, -1, 4), (1, -1, 4)):
                xx, yy = x + dx, y + dy
                if 0 <= xx < W and 0 <= yy < H:
                    best = min(best, d[yy * W + xx] + c)
            d[i] = best
    for y in range(H - 1, -1, -1):
        for x in range(W - 1, -1, -1):
            i = y * W + x
            if d[i] == 0:
                continue
            best = d[i]
            for dx, dy, c in ((1, 0, 3), (0, 1, 3), (1, 1, 4), (-1, 1, 4)):
                xx, yy = x + dx, y + dy
                if 0 <= xx < W and 0 <= yy < H:
                    best = min(best, d[yy * W + xx] + c)
            d[i] = best
    return [v / 3.0 if v < INF else math.inf for v in d]


def largest_rect(mask, W, H, min_side=3):
    """The largest axis-aligned rectangle of True pixels with both sides >= min_side:
    (x0, y0, x1, y1) inclusive, or None."""
    heights = [0] * W
    best = None
    best_area = 0
    for y in range(H):
        for x in range(W):
            heights[x] = heights[x] + 1 if mask[y * W + x] else 0
        stack = []  # indices with increasing heights
        for x in range(W + 1):
            h = heights[x] if x < W else 0
            while stack and heights[stack[-1]] >= h:
                top = stack.pop()
                hh = heights[top]
                left = stack[-1] + 1 if stack else 0
                w = x - left
                # The widest rectangle of height hh whose bottom row is y.
                if hh >= min_side and w >= min_side and hh * w > best_area:
                    best_area = hh * w
                    best = (left, y - hh + 1, x - 1, y)
            stack.append(x)
    return best


def rect_cap(r, W, H, frac=0.6):
    """Shrinks a rectangle larger than `frac` of the image on an axis about its centre."""
    x0, y0, x1, y1 = r
    for axis, n in ((0, W), (1, H)):
        lo, hi = (x0, x1) if axis == 0 else (y0, y1)
        if hi - lo + 1 > frac * n:
            c = (lo + hi) / 2
            half = frac * n / 2
            lo, hi = int(math.ceil(c - half)), int(math.floor(c + half)) - 1
        if axis == 0:
            x0, x1 = lo, hi
        else:
            y0, y1 = lo, hi
    return (x0, y0, x1, y1)


def overlap(a, b):
    ix = max(0, min(a[2], b[2]) - max(a[0], b[0]) + 1)
    iy = max(0, min(a[3], b[3]) - max(a[1], b[1]) + 1)
    return ix * iy


def area(r):
    return (r[2] - r[0] + 1) * (r[3] - r[1] + 1)


def write_preview(path, px, regions, W, H):
    """A PNG of the geometry (grey: how directly the key light meets the surface, dark blue:
    not lit) with each region's rectangle outlined: for checking the regions by eye."""
    import mitsuba as mi

    img = [0.0] * (W * H * 3)
    for i, p in enumerate(px):
        if p is None:
            continue
        ndl, vis = p["lights"][0]
        v = 0.15 + 0.85 * max(0.0, ndl) if vis else 0.08
        img[3 * i:3 * i + 3] = [v, v, v] if vis and ndl > 0 else [0.05, 0.05, 0.2]
    colours = [(1, 0, 0), (0, 1, 0), (0, 0.5, 1), (1, 1, 0), (1, 0, 1), (0, 1, 1), (1, 0.5, 0), (0.6, 0.3, 1)]
    for k, (_, (x0, y0, x1, y1)) in enumerate(regions):
        c = colours[k % len(colours)]
        for x in range(x0, x1 + 1):
            for y in (y0, y1):
                img[3 * (y * W + x):3 * (y * W + x) + 3] = c
        for y in range(y0, y1 + 1):
            for x in (x0, x1):
                img[3 * (y * W + x):3 * (y * W + x) + 3] = c
    bmp = mi.Bitmap(mi.TensorXf(img, shape=(H, W, 3)), mi.Bitmap.PixelFormat.RGB)
    bmp.convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.UInt8, srgb_gamma=True).write(path)


def compute_regions(name, xml, W, H, preview=None):
    shape, _, light = design()[name]
    s = view_setup(shape)
    lights = light_positions(s, light)
    px = pixel_geometry(xml, lights, W, H)
    hit = [p is not None for p in px]
    dist = chamfer_distance(hit, W, H)
    finite = [v for v in dist if v != math.inf and v > 0]
    maxd = max(finite) if finite else math.inf
    # The camera's right and up, and the key light's direction projected on the image.
    to_cam = norm(vsub(s["cam"], s["target"]))
    right = norm(cross([0.0, 1.0, 0.0], to_cam))
    up = cross(to_cam, right)
    lkey = norm(vsub(lights[0][0], s["target"]))
    lim = (dot(lkey, right), -dot(lkey, up))  # image coordinates, y down
    lim_len = math.hypot(*lim)
    thick_max = max((p["thick"] for p in px if p), default=0.0)
    inside = [hit[i] and dist[i] >= INSET_PX + 0.5 for i in range(W * H)]
    margin = 2
    for y in range(H):
        for x in range(W):
            if x < margin or y < margin or x >= W - margin or y >= H - margin:
                inside[y * W + x] = False
    band = max(5.0, 0.2 * maxd) if maxd != math.inf else 0.0

    def outline_side(i):
        # The outward direction at the silhouette: down the gradient of the distance to it
        # (pixels beyond the image continue the object).
        x, y = i % W, i // W

        def dd(xx, yy):
            if not (0 <= xx < W and 0 <= yy < H):
                return dist[i] + 1.0
            v = dist[yy * W + xx]
            return dist[i] + 1.0 if v == math.inf else v

        g = (dd(x - 1, y) - dd(x + 1, y), dd(x, y - 1) - dd(x, y + 1))
        ln = math.hypot(*g)
        if ln < 1e-6 or lim_len < 0.1:
            return 0.0
        return (g[0] * lim[0] + g[1] * lim[1]) / (ln * lim_len)

    def direct(p):
        return max((ndl if vis else 0.0) for ndl, vis in p["lights"])

    in_band = lambda i: dist[i] <= INSET_PX + 0.5 + band  # noqa: E731
    # In order of priority: a later class that repeats an earlier one's rectangle is dropped
    # (on a backlit curved shape, the band the light grazes is both an outline and a
    # terminator: it is named an outline).
    classes = [
        ("centre", lambda i, p: dist[i] >= 0.6 * maxd),
        ("lit side", lambda i, p: direct(p) >= 0.5),
    ]
    if band:
        if lim_len >= 0.1:
            classes += [
                ("light-side outline", lambda i, p: in_band(i) and outline_side(i) >= 0.7),
                ("far outline", lambda i, p: in_band(i) and outline_side(i) <= -0.7),
                # Across the light's direction in the image (a front-lit cylinder's rims).
                ("side outline", lambda i, p: in_band(i) and abs(outline_side(i)) <= 0.3),
            ]
        else:
            classes.append(("outline", lambda i, p: in_band(i)))
    classes += [
        ("terminator", lambda i, p: -0.1 <= p["lights"][0][0] <= 0.25 and direct(p) < 0.3),
        ("far side", lambda i, p: direct(p) <= 0.0 and p["lights"][0][0] <= -0.3),
    ]
    if thick_max > 0:
        classes += [
            ("thick part", lambda i, p: p["thick"] >= 0.75 * thick_max),
            ("thin part", lambda i, p: 0.08 * thick_max <= p["thick"] <= 0.35 * thick_max),
        ]
    n_inside = sum(inside)
    regions = []
    for cname, pred in classes:
        mask = [inside[i] and pred(i, px[i]) for i in range(W * H)]
        count = sum(mask)
        # A class that is (nearly) the whole object is no feature (the lit side of a front-lit
        # slab, the far side of a backlit one); the centre is always kept.
        if cname != "centre" and count > 0.85 * n_inside:
            continue
        r = largest_rect(mask, W, H)
        if r is None or area(r) < 16:
            continue
        r = rect_cap(r, W, H)
        if any(overlap(r, q) > 0.5 * area(r) or overlap(r, q) > 0.5 * area(q) for _, q in regions):
            continue
        regions.append((cname, r))
    if preview:
        write_preview(preview, px, regions, W, H)
    return regions, {"max_inset_px": maxd, "max_thickness": thick_max, "hit_pixels": sum(hit)}


def rect_json(r, W, H):
    # Pixel x0..x1 inclusive: compare takes floor(x0 W) .. ceil(x1 W); a quarter pixel in
    # from each edge keeps float rounding from adding a row.
    x0, y0, x1, y1 = r
    return [round((x0 + 0.25) / W, 5), round((y0 + 0.25) / H, 5), round((x1 + 0.75) / W, 5),
            round((y1 + 0.75) / H, 5)]


# ---------------------------------------------------------------------------------------------
# Commands
# ---------------------------------------------------------------------------------------------


def cmd_generate(a):
    os.makedirs(SCENES, exist_ok=True)
    if a.preview:
        os.makedirs(a.preview, exist_ok=True)
    names = a.names or list(design())
    meta_path = os.path.join(SCENES, "suite.json")
    meta = {"scenes": {}}
    if os.path.isfile(meta_path):
        with open(meta_path) as f:
            meta = json.load(f)
    for name in names:
        shape, medium, light = design()[name]
        toml_path = os.path.join(SCENES, name + ".toml")
        with open(toml_path, "w") as f:
            f.write(scene_toml(name))
        if a.no_regions:
            continue
        t = time.time()
        size = view_setup(shape)["size"]
        with tempfile.TemporaryDirectory() as tmp:
            export(toml_path, tmp)
            preview = os.path.join(a.preview, name + ".png") if a.preview else None
            regions, info = compute_regions(name, os.path.join(tmp, "scene.xml"), size, size, preview)
        with open(os.path.join(SCENES, name + ".regions.json"), "w") as f:
            json.dump({"regions": [{"name": n, "rect": rect_json(r, size, size)} for n, r in regions]}, f, indent=1)
            f.write("\n")
        meta["scenes"][name] = {
            "shape": shape, "medium": medium, "light": light, "size": size,
            "regions": {n: {"px": list(r), "pixels": area(r)} for n, r in regions},
            "max_inset_px": None if info["max_inset_px"] == math.inf else round(info["max_inset_px"], 1),
            "hit_pixels": info["hit_pixels"],
        }
        print(f"{name}: {len(regions)} regions ({', '.join(n for n, _ in regions)}), {time.time() - t:.1f} s",
              flush=True)
    meta["about"] = ("Generated by tools/reference/suite.py generate (issue 39): each scene's shape, "
                     "medium, light and regions in pixels (x0, y0, x1, y1 inclusive).")
    meta["media"] = MEDIA
    meta["lights"] = {k: [list(l[:2]) + [l[2]] for l in v] for k, v in LIGHTS.items()}
    meta["scenes"] = {k: meta["scenes"][k] for k in design() if k in meta["scenes"]}
    with open(meta_path, "w") as f:
        json.dump(meta, f, indent=1)
        f.write("\n")


def hval(seed, s):
    return int(hashlib.sha256(f"{seed}:{s}".encode()).hexdigest(), 16)


HOLDOUT_RULE = (
    "Stratified by shape. Within each shape, scenes are ranked by sha256('SEED:NAME'); the first "
    "floor(k/3) of a shape with k scenes are held out. The remaining places, up to round(n/3) "
    "in all, go one each to the shapes with k mod 3 > 0 ranked by sha256('SEED:SHAPE'), taking "
    "the next scene of that shape's ranking."
)


def choose_holdout(seed=HOLDOUT_SEED):
    by_shape = {}
    for name, (shape, _, _) in design().items():
        by_shape.setdefault(shape, []).append(name)
    held = []
    rest = []
    for shape, names in by_shape.items():
        ranked = sorted(names, key=lambda n: hval(seed, n))
        k = len(ranked) // 3
        held += ranked[:k]
        if len(ranked) % 3:
            rest.append((shape, ranked[k]))
    need = round(len(design()) / 3) - len(held)
    rest.sort(key=lambda t: hval(seed, t[0]))
    held += [n for _, n in rest[:need]]
    return sorted(held)


def cmd_holdout(a):
    if SET == "calibration":
        sys.exit("error: the calibration set has no held-out part (the suite is its test)")
    path = os.path.join(SCENES, "holdout.json")
    held = choose_holdout(a.seed)
    if os.path.isfile(path) and not a.force:
        with open(path) as f:
            old = json.load(f)
        if old["held_out"] != held or old["seed"] != a.seed:
            sys.exit(f"error: {path} exists with another choice; it must not change (--force to overwrite)")
        print(f"{path}: unchanged, {len(held)} held out")
        return
    rendered = [n for n in design() if os.path.isfile(os.path.join(REFS, n + ".exr"))]
    doc = {
        "about": "Issue 39: the held-out third of the generated suite. Never tune constants on these "
                 "scenes; report their errors beside the tuning scenes'.",
        "seed": a.seed,
        "rule": HOLDOUT_RULE.replace("SEED", str(a.seed)),
        "chosen": datetime.date.today().isoformat(),
        "references_rendered_when_chosen": len(rendered),
        "n_scenes": len(design()),
        "held_out": held,
        "tuning": sorted(n for n in design() if n not in held),
    }
    with open(path, "w") as f:
        json.dump(doc, f, indent=1)
        f.write("\n")
    print(f"{path}: {len(held)} of {len(design())} held out (seed {a.seed})")


def load_holdout():
    if SET == "calibration":
        # Fitted on whole; what it is tested on is the suite.
        return {"held_out": []}
    path = os.path.join(SCENES, "holdout.json")
    if not os.path.isfile(path):
        sys.exit(f"error: {path} is missing: choose the held-out third (suite.py holdout) before any reference")
    with open(path) as f:
        return json.load(f)


def render_queue():
    """Cheap shapes first; held-out and tuning scenes interleaved (about one in three held out
    all along the queue), so that a partial run is a usable sample of both."""
    held = set(load_holdout()["held_out"])

    def key(n):
        shape, medium, _ = design()[n]
        return (SHAPE_COST.index(shape), MEDIUM_COST.index(medium), hval(HOLDOUT_SEED, n))

    h = sorted((n for n in design() if n in held), key=key)
    t = sorted((n for n in design() if n not in held), key=key)
    out = []
    i = j = 0
    while i < len(h) or j < len(t):
        if j >= len(t) or (i < len(h) and (i + 0.5) / len(h) <= (j + 0.5) / len(t)):
            out.append(h[i])
            i += 1
        else:
            out.append(t[j])
            j += 1
    return out


def patched_xml(xml, rr_depth):
    with open(xml) as f:
        text = f.read()
    old = '<integer name="rr_depth" value="64"/>'
    if old not in text:
        raise RuntimeError(f"{xml}: no rr_depth 64 to replace (has the exporter changed?)")
    text = text.replace(old, f'<integer name="rr_depth" value="{rr_depth}"/>')
    out = xml[:-4] + f".rr{rr_depth}.xml"
    with open(out, "w") as f:
        f.write(text)
    return out


def render_one(name, out, spp, pass_spp, max_depth, rr_depth, seed=0, size=None, quiet=False):
    scene = os.path.join(SCENES, name + ".toml")
    with tempfile.TemporaryDirectory() as tmp:
        export(scene, tmp)
        xml = patched_xml(os.path.join(tmp, "scene.xml"), rr_depth)
        args = [xml, "--out", out, "--spp", str(spp), "--pass-spp", str(pass_spp), "--seed", str(seed),
                "--max-depth", str(max_depth)]
        if size:
            args += ["--width", str(size), "--height", str(size)]
        if quiet:
            args.append("--quiet")
        t = time.time()
        rc = render_reference.main(args)
        if rc != 0:
            raise RuntimeError(f"{name}: render_reference failed ({rc})")
        return time.time() - t


def load_manifest():
    path = os.path.join(REFS, "manifest.json")
    if os.path.isfile(path):
        with open(path) as f:
            return json.load(f)
    return {"about": "Issue 39: how each reference of the generated suite was rendered "
                     "(tools/reference/suite.py render).", "references": {}}


def save_manifest(m):
    path = os.path.join(REFS, "manifest.json")
    tmp = path + ".partial"
    with open(tmp, "w") as f:
        json.dump(m, f, indent=1)
        f.write("\n")
    os.replace(tmp, path)


def worst_rel_se(name):
    """The largest relative standard error of a region's mean luminance in a reference
    (regions whose reference is black are left out: they have no relative error)."""
    exr = os.path.join(REFS, name + ".exr")
    worst = 0.0
    for _, _, _, y, sey in region_table(exr, load_regions(name)):
        if y > 0:
            worst = max(worst, sey / y)
    return worst


def cmd_render(a):
    load_holdout()  # refuses to render before the held-out third is chosen
    names = a.names or render_queue()
    for name in names:
        if name not in design():
            sys.exit(f"error: {name}: not a scene of the suite")
    os.makedirs(REFS, exist_ok=True)
    variant = render_reference.pick_variant("auto")
    total = time.time()
    rr = a.rr_depth or a.max_depth
    # Round 0: every scene at --spp, in the queue's order.
    for k, name in enumerate(names):
        out = os.path.join(REFS, name + ".exr")
        if os.path.isfile(out) and not a.force:
            print(f"[{k + 1}/{len(names)}] {name}: present, skipped", flush=True)
            continue
        secs = render_one(name, out, a.spp, a.pass_spp, a.max_depth, rr, seed=a.seed)
        m = load_manifest()
        size = view_setup(design()[name][0])["size"]
        m["references"][name] = {
            "spp": a.spp, "pass_spp": a.pass_spp, "max_depth": a.max_depth, "rr_depth": rr,
            "width": size, "height": size, "variant": variant, "seconds": round(secs, 1),
            "parts": [{"seed": a.seed, "spp": a.spp, "seconds": round(secs, 1)}],
            "date": datetime.datetime.now().isoformat(timespec="seconds"),
        }
        save_manifest(m)
        print(f"[{k + 1}/{len(names)}] {name}: {a.spp} spp, {secs:.0f} s, worst region s.e. "
              f"{100 * worst_rel_se(name):.1f} % ({(time.time() - total) / 60:.1f} min so far)", flush=True)
    if not a.refine_to:
        return
    # Refinement rounds: each scene whose worst region's standard error is above --refine-to
    # gets more samples (a render with its own seed, merged by merge_references.py), one step
    # per scene per round, so that the whole queue improves together.
    import merge_references

    rnd = 0
    while True:
        rnd += 1
        todo = []
        for name in names:
            info = load_manifest()["references"].get(name)
            if not info or not os.path.isfile(os.path.join(REFS, name + ".exr")):
                continue
            worst = worst_rel_se(name)
            if worst > a.refine_to and info["spp"] + info.get("pass_spp", a.pass_spp) <= a.max_spp:
                todo.append((name, worst))
        if not todo:
            print(f"refinement: every reference within {100 * a.refine_to:.0f} % or at {a.max_spp} spp", flush=True)
            return
        print(f"refinement round {rnd}: {len(todo)} references above {100 * a.refine_to:.0f} %", flush=True)
        for k, (name, worst) in enumerate(todo):
            m = load_manifest()
            info = m["references"][name]
            spp = info["spp"]
            need = spp * (worst / a.refine_to) ** 2 * 1.1
            # The reference's own pass size: every pass of a merged image weighs the same.
            pass_spp = info.get("pass_spp", a.pass_spp)
            add = max(spp, int(math.ceil((need - spp) / pass_spp)) * pass_spp)
            add = min(add, (a.max_spp - spp) // pass_spp * pass_spp)
            if add <= 0:
                continue
            seed = max(p["seed"] for p in info["parts"]) + 1
            out = os.path.join(REFS, name + ".exr")
            part = os.path.join(REFS, f".{name}.part{seed}.exr")
            merged = os.path.join(REFS, f".{name}.merged.exr")
            secs = render_one(name, part, add, pass_spp, info["max_depth"], info["rr_depth"], seed=seed)
            rc = merge_references.main([merged, f"{out}:{spp}", f"{part}:{add}"])
            if rc:
                raise RuntimeError(f"{name}: merge failed")
            os.replace(merged, out)
            os.replace(render_reference.stderr_path(merged), render_reference.stderr_path(out))
            for f in (part, render_reference.stderr_path(part)):
                os.remove(f)
            info["spp"] = spp + add
            info["seconds"] = round(info["seconds"] + secs, 1)
            info["parts"].append({"seed": seed, "spp": add, "seconds": round(secs, 1)})
            info["date"] = datetime.datetime.now().isoformat(timespec="seconds")
            save_manifest(m)
            print(f"  [{k + 1}/{len(todo)}] {name}: {spp} + {add} spp ({secs:.0f} s), worst region s.e. "
                  f"{100 * worst:.1f} -> {100 * worst_rel_se(name):.1f} % ({(time.time() - total) / 60:.1f} min so far)",
                  flush=True)


def read_rgb(path):
    """(W, H, flat list of floats RGB) of an EXR."""
    import mitsuba as mi

    if not mi.variant():
        mi.set_variant("scalar_rgb")
    bmp = mi.Bitmap(path).convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32, srgb_gamma=False)
    t = mi.TensorXf(bmp)
    h, w = t.shape[0], t.shape[1]
    return w, h, list(t.array)


LUM = (0.2126, 0.7152, 0.0722)


def region_stats(img, se, W, H, rect):
    """Mean RGB, mean luminance and the standard error of the luminance (pixels independent,
    channels fully correlated, as `subsurface compare`)."""
    x0, y0, x1, y1 = rect
    xs = range(int(x0 * W), min(W, math.ceil(x1 * W)))
    ys = range(int(y0 * H), min(H, math.ceil(y1 * H)))
    n = len(xs) * len(ys)
    mean = [0.0] * 3
    var = [0.0] * 3
    for y in ys:
        for x in xs:
            i = 3 * (y * W + x)
            for c in range(3):
                mean[c] += img[i + c]
                if se is not None:
                    var[c] += se[i + c] ** 2
    mean = [m / n for m in mean]
    ses = [math.sqrt(v) / n for v in var]
    y = sum(LUM[c] * mean[c] for c in range(3))
    sey = sum(LUM[c] * ses[c] for c in range(3))
    return n, mean, y, sey


def region_table(exr, regions):
    W, H, img = read_rgb(exr)
    sep = render_reference.stderr_path(exr)
    se = read_rgb(sep)[2] if os.path.isfile(sep) else None
    return [(r["name"],) + region_stats(img, se, W, H, r["rect"]) for r in regions]


def load_regions(name):
    with open(os.path.join(SCENES, name + ".regions.json")) as f:
        return json.load(f)["regions"]


def cmd_check(a):
    names = a.names or [n for n in design() if os.path.isfile(os.path.join(REFS, n + ".exr"))]
    held = set(load_holdout()["held_out"])
    m = load_manifest()["references"]
    worst = 0.0
    flagged = 0
    count = 0
    for name in names:
        exr = os.path.join(REFS, name + ".exr")
        if not os.path.isfile(exr):
            print(f"{name}: no reference")
            continue
        info = m.get(name, {})
        print(f"{name} ({'held out' if name in held else 'tuning'}; {info.get('spp', '?')} spp, "
              f"max depth {info.get('max_depth', '?')}, {info.get('seconds', '?')} s)")
        for rname, n, mean, y, sey in region_table(exr, load_regions(name)):
            rel = sey / y if y > 0 else math.inf
            count += 1
            worst = max(worst, rel)
            flag = "  <-- standard error > 5 %" if rel > 0.05 else ""
            flagged += rel > 0.05
            print(f"  {rname:20s} {n:5d} px  Y {y:.4g}  RGB {mean[0]:.4g} {mean[1]:.4g} {mean[2]:.4g}  "
                  f"rel. s.e. {100 * rel:.2f} %{flag}")
    print(f"{count} regions, {flagged} with a standard error over 5 %, worst {100 * worst:.2f} %")


def cmd_depth_sweep(a):
    name = a.name
    regions = load_regions(name)
    depths = [int(x) for x in a.depths.split(",")]
    os.makedirs(a.out_dir, exist_ok=True)
    rows = []
    for depth in depths:
        rr = a.rr_depth or depth
        out = os.path.join(a.out_dir, f"{name}.d{depth}.rr{rr}.exr")
        secs = render_one(name, out, a.spp, a.pass_spp, depth, rr, seed=a.seed, size=a.size, quiet=True)
        # The regions are normalised: they hold at any image size.
        table = region_table(out, regions)
        rows.append((depth, rr, secs, table))
        print(f"{name} max_depth {depth} rr_depth {rr}: {secs:.0f} s  " +
              "  ".join(f"{r[0]} {r[2][0]:.4g}/{r[2][1]:.4g}/{r[2][2]:.4g} (Y {r[3]:.4g} +- {100 * r[4] / r[3] if r[3] else 0:.1f} %)"
                        for r in table), flush=True)
    last = rows[-1][3]
    for depth, rr, secs, table in rows[:-1]:
        print(f"  depth {depth} vs {rows[-1][0]}: " + "  ".join(
            f"{r[0]} " + "/".join(f"{100 * (r[2][c] / l[2][c] - 1):+.1f}" if l[2][c] > 0 else "n/a" for c in range(3)) + " %"
            for r, l in zip(table, last)))


# ---------------------------------------------------------------------------------------------
# Report (issue 39, item 4): the real-time renderer's region errors against the references
# ---------------------------------------------------------------------------------------------

REPORT_BANDS = (0.10, 0.20, 0.25, 0.35)  # shares of regions within these relative errors
REPORT_SE_MAX = 0.05  # regions whose reference is noisier than this are counted apart
REPORT_AXES = ("medium", "shape", "light", "region")  # the breakdowns: a failure class is a row
# `subsurface compare` adds a region of its own, "skin" (every pixel of a scattering
# material): kept in report.json, but not one of the suite's regions, so not in the shares.
COMPARE_WHOLE = "skin"


def settings_table(exe, env):
    """`subsurface settings` as {key: (default, description)}."""
    r = subprocess.run([exe, "settings"], capture_output=True, text=True, env=env)
    if r.returncode != 0:
        sys.exit(f"error: {exe} settings: {r.stderr.strip()}")
    out = {}
    for line in r.stdout.splitlines():
        m = re.match(r"^(\S+)\s+=\s+(.*?)\s{2,}(.*)$", line) or re.match(r"^(\S+)\s+=\s+(\S+)\s+(.*)$", line)
        if m:
            out[m.group(1)] = (m.group(2).strip().strip('"'), m.group(3).strip())
    return out


def report_configs(exe, env, quality=None):
    """The configurations: the defaults, `paper` transmittance, and each value of a quality
    preset when `subsurface settings` lists a key named *quality* (its values parsed from the
    description's leading "a, b or c", or given by --quality)."""
    configs = {"default": [], "paper": ["--transmittance", "paper"]}
    for key, (default, desc) in settings_table(exe, env).items():
        if "quality" not in key.split(".")[-1]:
            continue
        if quality:
            values = quality.split(",")
        else:
            m = re.match(r"^((?:[\w.-]+, )*[\w.-]+ or [\w.-]+)\b", desc)
            values = re.split(r", | or ", m.group(1)) if m else []
            if not values:
                print(f"warning: {key}: cannot read its values from {desc!r}; pass --quality V1,V2", file=sys.stderr)
        for v in values:
            if v != default:
                configs[f"quality={v}"] = ["--set", f"{key}={v}"]
    return configs


def run_compare(exe, env, name, args, tmp, supersample=1):
    ref = os.path.join(REFS, name + ".exr")
    cmd = [exe, "compare", ref, os.path.join(SCENES, name + ".toml"),
           "--regions", os.path.join(SCENES, name + ".regions.json"),
           "--json", "--out", os.path.join(tmp, "x.png")] + args
    if supersample > 1:
        cmd += ["--supersample", str(supersample)]
    for attempt in range(3):  # a reference replaced mid-read (a refinement round) reads again
        r = subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=tmp)
        if r.returncode == 0:
            return json.loads(r.stdout)
        time.sleep(5)
    raise RuntimeError(f"{name} {' '.join(args)}: {r.stderr.strip()}")


def report_stats(rows):
    """Shares within each band, mean |error|, mean error and the worst region of rows
    [(scene, region, error), ...] (errors already freed of the noisy and the black ones)."""
    n = len(rows)
    if not n:
        return {"n": 0}
    errs = [e for _, _, e in rows]
    worst = max(rows, key=lambda r: abs(r[2]))
    return {
        "n": n,
        "scenes": len({s for s, _, _ in rows}),
        "within": {f"{round(100 * b)}": sum(abs(e) <= b for e in errs) / n for b in REPORT_BANDS},
        "mean_abs": sum(abs(e) for e in errs) / n,
        "mean": sum(errs) / n,
        "worst": {"scene": worst[0], "region": worst[1], "error": worst[2]},
    }


def report_rows(scenes, cfg, part=None, **tags):
    """(scene, region, error) of every counted region of one configuration, filtered by part
    ("tuning"/"held_out") and tags (medium=..., shape=..., light=..., region=...)."""
    rows = []
    for name, s in scenes.items():
        if part and (part == "held_out") != s["held_out"]:
            continue
        if any(k != "region" and s[k] != v for k, v in tags.items()):
            continue
        for rname, g in s["configs"][cfg]["regions"].items():
            if "region" in tags and rname != tags["region"]:
                continue
            if g["error"] is None or g["stderr"] is None or g["stderr"] > REPORT_SE_MAX:
                continue
            rows.append((name, rname, g["error"]))
    return rows


def report_markdown(doc):
    scenes, configs = doc["scenes"], list(doc["configs"])
    pct = lambda x: "–" if x is None else f"{100 * x:+.0f}%"
    share = lambda x: f"{100 * x:.0f}%"
    held = sum(s["held_out"] for s in scenes.values())
    L = [f"{len(scenes)} scenes with a reference ({len(scenes) - held} tuning, {held} held out), "
         f"{doc['counted_regions']} regions counted, {len(doc['noisy'])} apart (reference standard error "
         f"> {100 * REPORT_SE_MAX:.0f} %) and {len(doc['black'])} with a black reference. "
         "Error = (real-time − reference) / reference of the region's mean luminance.", ""]
    L.append("| configuration | part | scenes | regions | " + " | ".join(f"±{round(100 * b)} %" for b in REPORT_BANDS)
             + " | mean \\|err\\| | mean err | worst region |")
    L.append("|---|---|---:|---:|" + "---:|" * len(REPORT_BANDS) + "---:|---:|---|")
    for cfg in configs:
        for part in ("tuning", "held_out", "all"):
            st = doc["summary"][cfg][part]
            if not st["n"]:
                L.append(f"| `{cfg}` | {part.replace('_', ' ')} | 0 | 0 |" + " |" * (len(REPORT_BANDS) + 3))
                continue
            w = st["worst"]
            L.append(f"| `{cfg}` | {part.replace('_', ' ')} | {st['scenes']} | {st['n']} | "
                     + " | ".join(share(st["within"][k]) for k in st["within"])
                     + f" | {100 * st['mean_abs']:.1f}% | {pct(st['mean'])} | {w['scene']} {w['region']} {pct(w['error'])} |")
    L.append("")
    for axis in REPORT_AXES:
        L.append(f"By {axis} (tuning and held out together; held-out regions in brackets):")
        L.append("")
        L.append(f"| {axis} | regions | " + " | ".join(
            f"`{c}` ±20 % | `{c}` ±25 % | `{c}` mean | `{c}` worst" for c in configs) + " |")
        L.append("|---|---:|" + "---:|---:|---:|---|" * len(configs))
        for value, per in doc["by"][axis].items():
            st0 = per[configs[0]]
            if not st0["n"]:
                continue
            cells = []
            for c in configs:
                st = per[c]
                w = st["worst"]
                cells.append(f"{share(st['within']['20'])} | {share(st['within']['25'])} | {pct(st['mean'])} | "
                             f"{pct(w['error'])} {'--'.join(x for x in w['scene'].split('--') if x != value)}"
                             + (f" {w['region']}" if axis != "region" else ""))
            label = value
            if axis == "light":
                label += " (" + " + ".join(f"{az:g}°" for az, _, _ in LIGHTS[value]) + ")"
            L.append(f"| {label} | {st0['n']} ({per['held_out_n']}) | " + " | ".join(cells) + " |")
        L.append("")
    L.append(f"The worst regions of `{configs[0]}` (|error| > 25 %):")
    L.append("")
    L.append("| scene | part | region | " + " | ".join(f"`{c}`" for c in configs) + " | reference s.e. |")
    L.append("|---|---|---|" + "---:|" * len(configs) + "---:|")
    worst = sorted(((n, r, g) for n, s in scenes.items() for r, g in s["configs"][configs[0]]["regions"].items()
                    if g["error"] is not None and g["stderr"] is not None and g["stderr"] <= REPORT_SE_MAX
                    and abs(g["error"]) > 0.25), key=lambda t: -abs(t[2]["error"]))
    if not worst:
        L.append("| none | | |" + " |" * (len(configs) + 1))
    for n, r, g in worst:
        L.append(f"| {n} | {'held out' if scenes[n]['held_out'] else 'tuning'} | {r} | "
                 + " | ".join(pct(scenes[n]["configs"][c]["regions"][r]["error"]) for c in configs)
                 + f" | {100 * g['stderr']:.1f}% |")
    L.append("")
    if doc["noisy"] or doc["black"]:
        L.append(f"Counted apart: regions whose reference standard error is above {100 * REPORT_SE_MAX:.0f} % "
                 "(or whose reference is black):")
        L.append("")
        L.append("| scene | part | region | reference s.e. | " + " | ".join(f"`{c}`" for c in configs) + " |")
        L.append("|---|---|---|---:|" + "---:|" * len(configs))
        for n, r in doc["noisy"] + doc["black"]:
            g0 = scenes[n]["configs"][configs[0]]["regions"][r]
            se = "black" if g0["stderr"] is None else f"{100 * g0['stderr']:.1f}%"
            L.append(f"| {n} | {'held out' if scenes[n]['held_out'] else 'tuning'} | {r} | {se} | "
                     + " | ".join(pct(scenes[n]["configs"][c]["regions"][r]["error"]) for c in configs) + " |")
        L.append("")
    return "\n".join(L)


def report_histogram(doc, path):
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib is not installed (python3 -m pip install matplotlib): no histogram", file=sys.stderr)
        return False
    configs = list(doc["configs"])
    lo, hi, step = -100, 150, 5
    edges = list(range(lo, hi + step, step))
    fig, axes = plt.subplots(1, len(configs), figsize=(5.5 * len(configs), 4), sharey=True, squeeze=False)
    for ax, cfg in zip(axes[0], configs):
        for part, colour, label in (("tuning", "tab:blue", "tuning"), ("held_out", "tab:orange", "held out")):
            errs = [min(max(100 * e, lo + 0.01), hi - 0.01) for _, _, e in report_rows(doc["scenes"], cfg, part)]
            if not errs:
                continue
            w = [100 / len(errs)] * len(errs)
            ax.hist(errs, bins=edges, weights=w, histtype="stepfilled", alpha=0.35, color=colour,
                    label=f"{label} ({len(errs)} regions)")
            ax.hist(errs, bins=edges, weights=w, histtype="step", color=colour)
        for x, style in ((20, ":"), (25, "--"), (35, "-")):
            for sgn in (-1, 1):
                ax.axvline(sgn * x, color="grey", linestyle=style, linewidth=0.8,
                           label=f"±{x} %" if sgn > 0 else None)
        ax.axvline(0, color="black", linewidth=0.6)
        ax.set_title(f"{cfg}")
        ax.set_xlabel(f"region error, real-time vs path-traced (%; clipped to {lo}..{hi})")
        ax.set_xlim(lo, hi)
        ax.legend(fontsize=7)
    axes[0][0].set_ylabel("share of the part's regions (%)")
    fig.suptitle(f"Issue 39 suite: {len(doc['scenes'])} scenes, region errors "
                 f"(reference s.e. ≤ {100 * REPORT_SE_MAX:.0f} %)", fontsize=10)
    fig.tight_layout()
    os.makedirs(os.path.dirname(path), exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return True


def cmd_report(a):
    exe = subsurface_bin()
    env = dict(os.environ)
    env.setdefault("WGPU_BACKEND", "vulkan")
    assets = os.path.normpath(os.path.join(ROOT, "..", "shared", "assets"))
    if os.path.isdir(assets):
        env.setdefault("SUBSURFACE_ASSETS", assets)
    meta = json.load(open(os.path.join(SCENES, "suite.json")))["scenes"]
    held = set(load_holdout()["held_out"])
    manifest = load_manifest()["references"]
    names = [n for n in (a.names or design()) if os.path.isfile(os.path.join(REFS, n + ".exr")) and n in manifest]
    configs = report_configs(exe, env, a.quality)
    print(f"{len(names)} references; configurations: " + ", ".join(f"{k} {' '.join(v)}".strip() for k, v in configs.items()),
          file=sys.stderr)
    scenes = {}
    t0 = time.time()
    with tempfile.TemporaryDirectory() as tmp:
        for k, name in enumerate(names):
            shape, medium, light = design()[name]
            s = scenes[name] = {"shape": shape, "medium": medium, "light": light,
                                "light_dirs": [list(l[:2]) + [l[2]] for l in LIGHTS[light]],
                                "held_out": name in held, "spp": manifest[name]["spp"],
                                "max_depth": manifest[name]["max_depth"], "configs": {}}
            for cfg, args in configs.items():
                j = run_compare(exe, env, name, args, tmp, a.supersample)
                regions = {g["name"]: {"error": g["rel_error"], "stderr": g["rel_stderr"]}
                           for g in j["regions"] if g["name"] != COMPARE_WHOLE}
                missing = set(meta[name]["regions"]) - set(regions)
                if missing:
                    raise RuntimeError(f"{name}: compare did not report {sorted(missing)}")
                whole = next((g for g in j["regions"] if g["name"] == COMPARE_WHOLE), None)
                s["configs"][cfg] = {
                    "regions": regions,
                    "whole": None if whole is None else {"error": whole["rel_error"], "stderr": whole["rel_stderr"]},
                    "rmse_debiased": j.get("rmse_debiased"), "rel_rmse_debiased": j.get("rel_rmse_debiased"),
                    "flip_mean": j.get("flip_mean"),
                }
                print(f"[{k + 1}/{len(names)}] {name:26s} {cfg:10s} " + " ".join(
                    f"{r} " + ("n/a" if g["error"] is None else f"{100 * g['error']:+.0f}%")
                    + ("(noisy)" if g["stderr"] is not None and g["stderr"] > REPORT_SE_MAX else "")
                    for r, g in regions.items()), file=sys.stderr, flush=True)
    c0 = next(iter(configs))
    noisy = [(n, r) for n, s in scenes.items() for r, g in s["configs"][c0]["regions"].items()
             if g["stderr"] is not None and g["stderr"] > REPORT_SE_MAX and g["error"] is not None]
    black = [(n, r) for n, s in scenes.items() for r, g in s["configs"][c0]["regions"].items()
             if g["error"] is None or g["stderr"] is None]
    doc = {
        "generated_by": "tools/reference/suite.py report",
        "about": "Issue 39, item 4: every region's relative error of mean luminance, (real-time - reference) / "
                 "reference, per configuration, with the reference's relative standard error; summary shares "
                 f"leave out regions whose reference standard error is above {REPORT_SE_MAX} (listed in noisy) "
                 "or whose reference is black.",
        "date": datetime.datetime.now().isoformat(timespec="seconds"),
        "binary": exe,
        "wgpu_backend": env.get("WGPU_BACKEND"),
        "supersample": a.supersample,
        "configs": configs,
        "bands": list(REPORT_BANDS),
        "stderr_max": REPORT_SE_MAX,
        "scenes_total": len(design()),
        "counted_regions": len(report_rows(scenes, c0)),
        "noisy": noisy,
        "black": black,
        "seconds": round(time.time() - t0, 1),
    }
    doc["summary"] = {c: {p: report_stats(report_rows(scenes, c, None if p == "all" else p))
                          for p in ("tuning", "held_out", "all")} for c in configs}
    doc["by"] = {}
    for axis in REPORT_AXES:
        if axis == "region":
            values = sorted({r for s in scenes.values() for r in s["configs"][c0]["regions"]})
        else:
            order = {"medium": list(MEDIA), "shape": list(SHAPES), "light": list(LIGHTS)}[axis]
            values = [v for v in order if any(s[axis] == v for s in scenes.values())]
        doc["by"][axis] = {}
        for v in values:
            per = {c: report_stats(report_rows(scenes, c, **{axis: v})) for c in configs}
            per["held_out_n"] = len(report_rows(scenes, c0, "held_out", **{axis: v}))
            doc["by"][axis][v] = per
    doc["scenes"] = scenes
    out = a.out or os.path.join(REFS, "report.json")
    with open(out, "w") as f:
        json.dump(doc, f, indent=1)
        f.write("\n")
    md = report_markdown(doc)
    print(md)
    if a.markdown:
        with open(a.markdown, "w") as f:
            f.write(md + "\n")
    hist = a.histogram or os.path.join(ROOT, "docs", "images",
                                       "calibration.png" if SET == "calibration" else "generalization.png")
    drawn = report_histogram(doc, hist)
    print(f"wrote {out}" + (f", {hist}" if drawn else "") + f" ({doc['seconds']:.0f} s)", file=sys.stderr)


def cmd_explain(a):
    import suite_explain

    exe = subsurface_bin()
    env = dict(os.environ)
    env.setdefault("WGPU_BACKEND", "vulkan")
    report = a.report or os.path.join(REFS, "report.json")
    with open(report) as f:
        doc = json.load(f)
    misses = [(n, r, g["error"], s["held_out"]) for n, s in sorted(doc["scenes"].items())
              for r, g in s["configs"]["default"]["regions"].items()
              if g["error"] is not None and g["stderr"] is not None and g["stderr"] <= doc["stderr_max"]
              and abs(g["error"]) > a.band and (not a.names or n in a.names)]
    print(f"{len(misses)} regions outside ±{100 * a.band:.0f} % in {report}", file=sys.stderr)
    recs = suite_explain.explain(misses, lambda n, args, tmp, ss: run_compare(exe, env, n, args, tmp, ss), a.band)
    out = a.out or os.path.join(REFS, "misses.json")
    suite_explain.save(recs, out, a.band)
    md = suite_explain.markdown(recs, a.band)
    print(md)
    if a.markdown:
        with open(a.markdown, "w") as f:
            f.write(md + "\n")
    print(f"wrote {out}", file=sys.stderr)


def cmd_queue(_a):
    held = set(load_holdout()["held_out"])
    for n in render_queue():
        print(n, "(held out)" if n in held else "")


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--set", choices=("suite", "calibration"), default="suite",
                   help="the suite (scenes/suite, references/suite) or the calibration set of curved parts "
                        "(scenes/calibration, references/calibration), fitted on and never a test")
    sub = p.add_subparsers(dest="cmd", required=True)
    g = sub.add_parser("generate", help="write scenes/suite/*.toml, *.regions.json and suite.json")
    g.add_argument("names", nargs="*")
    g.add_argument("--no-regions", action="store_true", help="scene files only (no binary needed)")
    g.add_argument("--preview", metavar="DIR", help="also write DIR/NAME.png: the geometry with the regions outlined")
    h = sub.add_parser("holdout", help="choose the held-out third: scenes/suite/holdout.json")
    h.add_argument("--seed", type=int, default=HOLDOUT_SEED)
    h.add_argument("--force", action="store_true")
    r = sub.add_parser("render", help="path-trace references/suite/NAME.exr (+ .stderr.exr)")
    r.add_argument("names", nargs="*", help="default: every scene, in the queue's order")
    r.add_argument("--spp", type=int, default=128)
    r.add_argument("--pass-spp", type=int, default=32)
    r.add_argument("--max-depth", type=int, default=4096)
    r.add_argument("--rr-depth", type=int, help="default: --max-depth (no Russian roulette)")
    r.add_argument("--seed", type=int, default=0)
    r.add_argument("--force", action="store_true", help="render even where a reference exists")
    r.add_argument("--refine-to", type=float, metavar="SE",
                   help="then add samples where a region's relative standard error is above SE (e.g. 0.05)")
    r.add_argument("--max-spp", type=int, default=2048, help="refinement stops at this many samples (default 2048)")
    d = sub.add_parser("depth-sweep", help="region means of one scene against max_depth")
    d.add_argument("name")
    d.add_argument("--depths", default="64,256,1024,4096")
    d.add_argument("--spp", type=int, default=64)
    d.add_argument("--pass-spp", type=int, default=16)
    d.add_argument("--size", type=int, default=64)
    d.add_argument("--rr-depth", type=int, help="default: each depth (no Russian roulette)")
    d.add_argument("--seed", type=int, default=0)
    d.add_argument("--out-dir", default=os.path.join(tempfile.gettempdir(), "suite-depth-sweep"))
    c = sub.add_parser("check", help="region means and standard errors of the rendered references")
    c.add_argument("names", nargs="*")
    sub.add_parser("queue", help="print the render order")
    rp = sub.add_parser("report", help="the real-time renderer's region errors against every reference: "
                        "references/suite/report.json, a Markdown table, docs/images/generalization.png")
    rp.add_argument("names", nargs="*", help="default: every scene whose reference exists")
    rp.add_argument("--quality", metavar="V1,V2", help="values of a quality setting (default: read from `subsurface settings`)")
    rp.add_argument("--supersample", type=int, default=1, help="compare --supersample N (default 1, as fidelity_table.py)")
    rp.add_argument("--out", help="default: references/suite/report.json")
    rp.add_argument("--markdown", metavar="FILE", help="also write the Markdown tables to FILE")
    rp.add_argument("--histogram", metavar="PNG", help="default: docs/images/generalization.png")
    ex = sub.add_parser("explain", help="what each region outside the band is made of: the scene rendered again "
                        "with one part of the method changed at a time (references/suite/misses.json)")
    ex.add_argument("names", nargs="*", help="default: every scene with a miss in the report")
    ex.add_argument("--band", type=float, default=0.25, help="regions outside this relative error (default 0.25)")
    ex.add_argument("--report", help="default: references/suite/report.json")
    ex.add_argument("--out", help="default: references/suite/misses.json")
    ex.add_argument("--markdown", metavar="FILE", help="also write the Markdown table to FILE")
    a = p.parse_args()
    global SET, SCENES, REFS
    SET = a.set
    if SET == "calibration":
        SCENES = os.path.join(ROOT, "scenes", "calibration")
        REFS = os.environ.get("SUITE_REFS") or os.path.join(ROOT, "references", "calibration")
    commands = {
        "generate": cmd_generate,
        "holdout": cmd_holdout,
        "render": cmd_render,
        "depth-sweep": cmd_depth_sweep,
        "check": cmd_check,
        "report": cmd_report,
        "queue": cmd_queue,
        "explain": cmd_explain,
    }
    commands[a.cmd](a)


if __name__ == "__main__":
    main()
