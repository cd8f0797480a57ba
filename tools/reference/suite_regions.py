"""The suite's regions, computed from each scene's geometry rather than drawn: a ray through every
pixel centre of the exported camera (Mitsuba, scalar variant) gives the pixel's normal, the
thickness its view ray crosses, which lights see it and its distance to the silhouette; each
region is the largest rectangle of one class of pixels (suite.py's docstring names them)."""

import math
import subprocess

from make_references import subsurface_bin
from suite_design import INSET_PX, cross, dot, light_positions, norm, view_setup, vscale, vsub



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


def compute_regions(shape, light, xml, W, H, preview=None):
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
