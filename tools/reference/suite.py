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
    python3 tools/reference/suite.py report --with KEY=VALUE --out FILE --against references/suite/report.json
                                                         # a variant on the whole suite, and what it moved
    python3 tools/reference/suite.py explain [NAME ...]  # each miss rendered with one part changed at a time
    python3 tools/reference/suite.py --set calibration ...  # the same on the calibration set of curved parts

Run from the repository root with a `subsurface` binary (SUBSURFACE_BIN, else target/release or
target/debug) and Mitsuba 3 (`python3 -m pip install mitsuba==3.9.1`; libllvm19 for the fast
variant). The head scenes need ../shared/assets (the Lee Perry-Smith head).

The grid is not the full cross product: `DESIGN` (suite_design.py) lists the scenes, chosen so
that every medium, shape and light direction appears, and so that the classes the canonical set
missed (thick parts lit from behind off the axis, in several media; outlines the light grazes)
are crossed with several media each.

Regions are computed from the geometry, not drawn (suite_regions.py): each scene is exported with
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
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.normpath(os.path.join(HERE, "..", ".."))
sys.path.insert(0, HERE)
import render_reference  # noqa: E402
from make_references import subsurface_bin  # noqa: E402
import suite_report  # noqa: E402
from suite_design import (CALIBRATION, DESIGN, LIGHTS, MEDIA, MEDIUM_COST, SHAPE_COST, scene_name,  # noqa: E402
                          scene_toml, view_setup)
from suite_regions import area, compute_regions, export, rect_json  # noqa: E402

SET = "suite"  # or "calibration" (--set): which design, scene folder and reference folder
SCENES = os.path.join(ROOT, "scenes", "suite")
# SUITE_REFS: another folder for the references (trials that must not touch the committed ones).
REFS = os.environ.get("SUITE_REFS") or os.path.join(ROOT, "references", "suite")
HOLDOUT_SEED = 39


def design():
    """The scenes of the set in use, {name: (shape, medium, light)}."""
    rows = CALIBRATION if SET == "calibration" else DESIGN
    names = [scene_name(*d) for d in rows]
    assert len(set(names)) == len(names), "duplicate scenes in the design"
    return {scene_name(*d): d for d in rows}


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
            f.write(scene_toml(shape, medium, light))
        if a.no_regions:
            continue
        t = time.time()
        size = view_setup(shape)["size"]
        with tempfile.TemporaryDirectory() as tmp:
            export(toml_path, tmp)
            preview = os.path.join(a.preview, name + ".png") if a.preview else None
            regions, info = compute_regions(shape, light, os.path.join(tmp, "scene.xml"), size, size, preview)
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
    suite = suite_set()
    recs = suite_explain.explain(
        misses, lambda n, args, tmp, ss: suite_report.run_compare(exe, env, suite, n, args, tmp, ss), a.band)
    out = a.out or os.path.join(REFS, "misses.json")
    suite_explain.save(recs, out, a.band)
    md = suite_explain.markdown(recs, a.band)
    print(md)
    if a.markdown:
        with open(a.markdown, "w") as f:
            f.write(md + "\n")
    print(f"wrote {out}", file=sys.stderr)


def suite_set():
    """The set in use as suite_report reads it."""
    return suite_report.SuiteSet(SET, ROOT, SCENES, REFS, design(), set(load_holdout()["held_out"]),
                                 load_manifest()["references"])


def cmd_report(a):
    suite_report.cmd_report(a, suite_set())


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
    rp.add_argument("--histogram", metavar="PNG",
                    help="default: docs/images/generalization.png (none with --with)")
    rp.add_argument("--with", dest="with_", metavar="KEY=VALUE", action="append", default=[],
                    help="a setting changed in every configuration, as compare's --set (repeatable; "
                         "needs --out): a variant measured on the whole suite")
    rp.add_argument("--against", metavar="REPORT",
                    help="then print what changed from this report: the shares, and every region that "
                         "moved by more than --moved or crossed ±25 %%")
    rp.add_argument("--moved", type=float, default=0.02, help="with --against: the smallest move listed (default 0.02)")
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
