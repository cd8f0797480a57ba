"""`suite.py report`: the real-time renderer's error on every region of every suite scene against
its path-traced reference, per configuration (the defaults, `paper`, each quality preset), split
into the tuning and the held-out parts, with the breakdowns by medium, shape, light and region,
a Markdown table and a histogram."""

import datetime
import json
import os
import re
import subprocess
import sys
import tempfile
import time

from make_references import subsurface_bin
from suite_design import LIGHTS, MEDIA, SHAPES


class SuiteSet:
    """The set of scenes a report reads (suite.py's `--set`): its name ("suite" or
    "calibration"), its scene and reference folders, its scenes {name: (shape, medium, light)},
    the held-out names and the references' manifest."""

    def __init__(self, name, root, scenes, refs, design, held, manifest):
        self.name, self.root, self.scenes, self.refs = name, root, scenes, refs
        self.design, self.held, self.manifest = design, held, manifest

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


def run_compare(exe, env, suite, name, args, tmp, supersample=1):
    ref = os.path.join(suite.refs, name + ".exr")
    cmd = [exe, "compare", ref, os.path.join(suite.scenes, name + ".toml"),
           "--regions", os.path.join(suite.scenes, name + ".regions.json"),
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


def cmd_report(a, suite):
    if a.with_ and not a.out:
        sys.exit("error: --with: give --out too (the committed report is the defaults')")
    # Read before the 70 s of rendering, so that a wrong path fails at once.
    before = read_report(a.against) if a.against else None
    overrides = [arg for kv in a.with_ for arg in ("--set", kv)]
    exe = subsurface_bin()
    env = dict(os.environ)
    env.setdefault("WGPU_BACKEND", "vulkan")
    assets = os.path.normpath(os.path.join(suite.root, "..", "shared", "assets"))
    if os.path.isdir(assets):
        env.setdefault("SUBSURFACE_ASSETS", assets)
    meta = json.load(open(os.path.join(suite.scenes, "suite.json")))["scenes"]
    held = suite.held
    manifest = suite.manifest
    names = [n for n in (a.names or suite.design) if os.path.isfile(os.path.join(suite.refs, n + ".exr"))
             and n in manifest]
    configs = report_configs(exe, env, a.quality)
    print(f"{len(names)} references; configurations: " + ", ".join(f"{k} {' '.join(v)}".strip() for k, v in configs.items()),
          file=sys.stderr)
    scenes = {}
    t0 = time.time()
    with tempfile.TemporaryDirectory() as tmp:
        for k, name in enumerate(names):
            shape, medium, light = suite.design[name]
            s = scenes[name] = {"shape": shape, "medium": medium, "light": light,
                                "light_dirs": [list(l[:2]) + [l[2]] for l in LIGHTS[light]],
                                "held_out": name in held, "spp": manifest[name]["spp"],
                                "max_depth": manifest[name]["max_depth"], "configs": {}}
            for cfg, args in configs.items():
                j = run_compare(exe, env, suite, name, args + overrides, tmp, a.supersample)
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
        # Settings changed in every configuration (`--with`), on top of each one's own.
        "with": list(a.with_),
        "configs": configs,
        "bands": list(REPORT_BANDS),
        "stderr_max": REPORT_SE_MAX,
        "scenes_total": len(suite.design),
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
    out = a.out or os.path.join(suite.refs, "report.json")
    with open(out, "w") as f:
        json.dump(doc, f, indent=1)
        f.write("\n")
    md = report_markdown(doc)
    print(md)
    if a.markdown:
        with open(a.markdown, "w") as f:
            f.write(md + "\n")
    hist = a.histogram
    if not hist and not a.with_:
        hist = os.path.join(suite.root, "docs", "images",
                            "calibration.png" if suite.name == "calibration" else "generalization.png")
    drawn = bool(hist) and report_histogram(doc, hist)
    print(f"wrote {out}" + (f", {hist}" if drawn else "") + f" ({doc['seconds']:.0f} s)", file=sys.stderr)
    if before is not None:
        print("\n".join(report_changes(before, doc, a.moved)))


def read_report(path):
    """A report written by `report`, or a one-line exit naming the file."""
    try:
        with open(path) as f:
            doc = json.load(f)
    except (OSError, ValueError) as e:
        sys.exit(f"error: {path}: {e}")
    if not isinstance(doc, dict) or "summary" not in doc or "scenes" not in doc:
        sys.exit(f"error: {path}: not a report of suite.py report (no summary or scenes)")
    return doc


def report_changes(before, after, moved=0.02):
    """What changed from report `before` to `after` (Markdown lines): each configuration's shares
    within ±20 / 25 / 35 % and mean |error| on each part, then every counted region whose error
    moved by more than `moved` or crossed ±25 %, largest gain first."""
    L = ["| configuration | part | ±20 % | ±25 % | ±35 % | mean \\|err\\| |", "|---|---|---|---|---|---|"]
    fmt = lambda st, k: f"{100 * st['within'][k]:.1f}"  # noqa: E731
    for cfg in after["summary"]:
        if cfg not in before["summary"]:
            continue
        for part in ("tuning", "held_out"):
            b, n = before["summary"][cfg][part], after["summary"][cfg][part]
            if not b["n"] or not n["n"]:
                continue
            L.append(f"| `{cfg}` | {part.replace('_', ' ')} | "
                     + " | ".join(f"{fmt(b, k)} → {fmt(n, k)}" for k in ("20", "25", "35"))
                     + f" | {100 * b['mean_abs']:.1f} → {100 * n['mean_abs']:.1f} |")
    L += ["", "| configuration | scene | part | region | before | after |", "|---|---|---|---|---:|---:|"]
    rows = []
    for cfg in after["summary"]:
        if cfg not in before["summary"]:
            continue
        was = {(n, r): e for n, r, e in report_rows(before["scenes"], cfg)}
        for name, r, e1 in report_rows(after["scenes"], cfg):
            e0 = was.get((name, r))
            if e0 is not None and (abs(e1 - e0) > moved or (abs(e0) > 0.25) != (abs(e1) > 0.25)):
                rows.append((abs(e1) - abs(e0), cfg, name, after["scenes"][name]["held_out"], r, e0, e1))
    for _, cfg, name, held, r, e0, e1 in sorted(rows):
        L.append(f"| `{cfg}` | {name} | {'held out' if held else 'tuning'} | {r} | {100 * e0:+.1f}% | {100 * e1:+.1f}% |")
    if not rows:
        L.append(f"| none moved by more than {100 * moved:.0f} points | | | | | |")
    return L
