"""The generated suite's grid (issue 39): media, shapes and light directions, the designed subset
of their product and the calibration set, and each scene's file. `suite.py generate` writes the
files; the regions are suite_regions.py's, the report suite_report.py's."""

import math


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


def scene_toml(shape, medium, light):
    s = view_setup(shape)
    lights = light_positions(s, light)
    azs = ", ".join(f"{az:g} deg azimuth / {el:g} deg elevation" for az, el, _ in LIGHTS[light])
    lines = [
        "# Generated by tools/reference/suite.py (issue 39): do not edit, regenerate.",
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
