#!/usr/bin/env python3
"""The quality report: what each term of the skin costs and what it buys, measured on the
same run, so that the presets can be read off the front of cost against error.

    python3 tools/reference/quality.py [--width 1280 --height 720] [--frames 5] [--rounds 2]
        [--scenes default,scenes/head.toml] [--only NAME,..] [--out references/quality.json]

For each configuration (the three presets, `high` with one term switched off or cut down in
turn, the skin switched off) it measures:
- the cost: `subsurface bench --json` on each cost scene (the embedded default scene and the
  head), whose run also renders the same frame without any skin effect (`skin_ms`,
  `skin_share`: the skin's cost and its share of that frame), per pass;
- the error: `subsurface compare --json` of every canonical scene against its path-traced
  reference (references/NAME.exr): the worst and the mean |region error|, and the FLIP mean;
- with `--suite`, the error on the generated suite (issue 39, references/suite/): the share of
  its counted regions within +-25 %, and the mean |region error|, on its tuning and held-out
  parts apart. The canonical scenes are what the presets were tuned on; the suite is where a
  term's gain shows on scenes nobody tuned to (a thin part lit from the front, other media).
It writes the JSON (`--out`), prints a Markdown table, and draws docs/images/quality.png
(worst region error against the skin's share of the frame, the presets marked) with
matplotlib when it is installed.

Run after `cargo build --release -p subsurface-cli` (or set SUBSURFACE_BIN); the head needs
../shared/assets (SUBSURFACE_ASSETS).

The error does not depend on the adapter (the images agree to a fraction of a level), the cost
does: measure the cost where it matters and the error anywhere, then join them:

    python3 tools/reference/quality.py --no-error --width 1920 --height 1080 --out gpu.json  # on the GPU
    python3 tools/reference/quality.py --no-cost --costs gpu.json                           # here
"""

import argparse
import glob
import json
import os
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.normpath(os.path.join(HERE, "..", ".."))
sys.path.insert(0, HERE)
from make_references import subsurface_bin  # noqa: E402

# (name, preset, keys set over it). The presets first; then `high` less one term at a time
# (each the cheapest setting of that term), then no skin at all.
CONFIGS = [
    ("high", "high", []),
    ("medium", "medium", []),
    ("low", "low", []),
    ("former low: no taps, chords per pixel", "low",
     ["transmittance.lateral_taps=0", "transmittance.single_scattering=true", "transmitted_map.texel_mm=0"]),
    ("low, 4 lateral taps", "low", ["transmittance.lateral_taps=4"]),
    ("high, 11 taps", "high", ["sss.samples=11"]),
    ("high, 7 jittered taps", "high", ["sss.samples=7", "sss.jitter=true"]),
    ("high, no lateral taps", "high", ["transmittance.lateral_taps=0"]),
    ("high, 8 lateral taps", "high", ["transmittance.lateral_taps=8"]),
    ("high, no single scattering", "high", ["transmittance.single_scattering=false"]),
    ("high, no ballistic lobe", "high", ["transmittance.ballistic=false"]),
    ("high, no source shift", "high", ["sss.source_shift=false"]),
    ("high, bounce ring 1", "high", ["bounce.ring=1"]),
    ("high, no bounce", "high", ["bounce.ring=0"]),
    ("high, 1-texel thickness", "high", ["transmittance.thickness_filter=1"]),
    ("high, no thin parts", "high", ["sss.thin_parts=false"]),
    ("high, no side walls", "high", ["transmittance.side_walls=false"]),
    ("high, no lit side", "high", ["transmittance.lit_side=false"]),
    ("high, per pixel", "high", ["transmitted_map.texel_mm=0"]),
    ("high, paper transmittance", "high", ["transmittance.method=paper"]),
    ("no skin effects", "high", ["sss.method=none", "transmittance.method=off", "bounce.ring=0"]),
]
PRESETS = ("high", "medium", "low")


def settings_args(preset, keys):
    out = ["--quality", preset]
    for k in keys:
        out += ["--set", k]
    return out


def run_json(cmd, env):
    r = subprocess.run(cmd, capture_output=True, text=True, env=env)
    if r.returncode != 0:
        sys.exit(f"{' '.join(cmd)}: {r.stderr.strip().splitlines()[-1] if r.stderr.strip() else r.returncode}")
    return json.loads(r.stdout)


def cost(exe, env, scene, preset, keys, a):
    cmd = [exe, "bench", "--json", "--width", str(a.width), "--height", str(a.height),
           "--warmup", str(a.warmup), "--frames", str(a.frames), "--rounds", str(a.rounds)]
    cmd += settings_args(preset, keys)
    if scene != "default":
        cmd.insert(2, scene)
    j = run_json(cmd, env)
    run = j["runs"][0]
    return {
        "adapter": j["adapter"],
        "frame_ms": run["frame_ms"],
        "skin_ms": run.get("skin_ms"),
        "skin_share": run.get("skin_share"),
        "passes": {p["name"]: p["ms"] for p in run["passes"]},
    }


def error(exe, env, name, preset, keys, tmp):
    scene = os.path.join(ROOT, "scenes/canonical", name + ".toml")
    ref = os.path.join(ROOT, "references", name + ".exr")
    cmd = [exe, "compare", ref, scene, "--json", "--out", os.path.join(tmp, "x.png")]
    cmd += settings_args(preset, keys)
    j = run_json(cmd, env)
    return {"flip_mean": j["flip_mean"], "regions": {g["name"]: g["rel_error"] for g in j["regions"]}}


SUITE_BAND = 0.25


def suite_error(exe, env, preset, keys, tmp):
    """The share of the suite's counted regions within SUITE_BAND and their mean |error|, per
    part. The regions counted are the ones its report counts (reference standard error at
    most its limit), read from references/suite/report.json, so both tools count alike."""
    with open(os.path.join(ROOT, "references/suite/report.json")) as f:
        report = json.load(f)
    limit = report["stderr_max"]
    rows = {"tuning": [], "held_out": []}
    for name, s in report["scenes"].items():
        scene = os.path.join(ROOT, "scenes/suite", name + ".toml")
        cmd = [exe, "compare", os.path.join(ROOT, "references/suite", name + ".exr"), scene,
               "--regions", os.path.join(ROOT, "scenes/suite", name + ".regions.json"),
               "--json", "--out", os.path.join(tmp, "x.png")] + settings_args(preset, keys)
        j = run_json(cmd, env)
        counted = {r for r, g in s["configs"]["default"]["regions"].items()
                   if g["error"] is not None and g["stderr"] is not None and g["stderr"] <= limit}
        part = "held_out" if s["held_out"] else "tuning"
        rows[part] += [g["rel_error"] for g in j["regions"] if g["name"] in counted]
    return {p: {"regions": len(e), "within_25": sum(abs(x) <= SUITE_BAND for x in e) / len(e),
                "mean_abs_error": sum(abs(x) for x in e) / len(e)} for p, e in rows.items() if e}


def summary(errors):
    regions = [(f"{scene}: {r}", e) for scene, v in errors.items() for r, e in v["regions"].items()]
    worst = max(regions, key=lambda x: abs(x[1]))
    return {
        "worst_region": worst[0],
        "worst_error": worst[1],
        "mean_abs_error": sum(abs(e) for _, e in regions) / len(regions),
        "mean_flip": sum(v["flip_mean"] for v in errors.values()) / len(errors),
        "regions": len(regions),
    }


def markdown(report):
    scenes = report["cost_scenes"]
    suite = any("suite" in c for c in report["configs"])
    head = "| configuration | " + " | ".join(f"skin ms, {s} | skin share, {s}" for s in scenes) \
        + " | worst region | mean abs error | mean FLIP |" \
        + (" suite within 25 %, tuning / held out | suite mean abs error, tuning / held out |" if suite else "")
    rule = "|---|" + "---:|---:|" * len(scenes) + "---|---:|---:|" + ("---:|---:|" if suite else "")
    lines = [head, rule]
    for c in report["configs"]:
        cells = []
        for s in scenes:
            k = c["cost"][s]
            ms = k["skin_ms"]
            # A GPU's milliseconds need more digits than lavapipe's.
            cells += [("-" if ms is None else f"{ms:.3f}" if abs(ms) < 10 else f"{ms:.1f}"),
                      f"{100 * k['skin_share']:.1f} %" if k["skin_share"] is not None else "-"]
        e = c["error"]
        name = f"**{c['name']}**" if c["name"] in PRESETS else c["name"]
        lines.append(f"| {name} | " + " | ".join(cells)
                     + f" | {100 * e['worst_error']:+.1f} % ({e['worst_region']}) | {100 * e['mean_abs_error']:.1f} % | {e['mean_flip']:.4f} |"
                     + suite_cells(c.get("suite"), suite))
    return "\n".join(lines) + "\n"


def suite_cells(s, shown):
    if not shown:
        return ""
    if not s:
        return " - | - |"
    t, h = s["tuning"], s["held_out"]
    return (f" {100 * t['within_25']:.0f} % / {100 * h['within_25']:.0f} % |"
            f" {100 * t['mean_abs_error']:.1f} % / {100 * h['mean_abs_error']:.1f} % |")


def plot(report, path):
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib is not installed: no plot", file=sys.stderr)
        return
    scene = report["cost_scenes"][0]
    fig, ax = plt.subplots(figsize=(8, 5), dpi=110)
    high = next((c for c in report["configs"] if c["name"] == "high"), None)
    max_share = (high["cost"][scene]["skin_share"] or 1.0) if high else 1.0
    # Presets first, so that their labels take the first places.
    ordered = sorted(report["configs"], key=lambda c: c["name"] not in PRESETS)
    labelled = []
    for c in ordered:
        share = c["cost"][scene]["skin_share"]
        if share is None:
            continue
        x, y = 100 * share, 100 * abs(c["error"]["worst_error"])
        preset = c["name"] in PRESETS
        ax.scatter([x], [y], s=90 if preset else 30, marker="s" if preset else "o",
                   color="tab:red" if preset else "tab:blue", zorder=3)
        # The configurations that keep every term sit in one cluster: name the presets and
        # the points that stand apart, each label below any it would overwrite.
        if preset or y > 22 or x < 100 * 0.9 * max_share:
            dy = 4
            while any(abs(x - lx) < 8 and abs(dy - ldy) < 11 and abs(y - ly) < 3 for lx, ly, ldy in labelled):
                dy -= 11
            labelled.append((x, y, dy))
            ax.annotate(c["name"], (x, y), textcoords="offset points", xytext=(5, dy),
                        fontsize=9 if preset else 8, weight="bold" if preset else "normal")
    ax.axhline(20, color="grey", lw=0.8, ls="--")
    ax.axhline(25, color="grey", lw=0.8, ls=":")
    ax.axhline(40, color="grey", lw=0.8, ls="-.")
    adapter = report["adapter"].split(" (")[0]
    ax.set_xlabel(f"skin's cost, % of the frame without it ({scene} scene, {report['size']}, {adapter})")
    ax.set_ylabel("worst |region error| over the canonical scenes, %")
    ax.set_title("Quality presets on the front of cost against error")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path)
    print(f"wrote {path}", file=sys.stderr)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--width", type=int, default=1280)
    p.add_argument("--height", type=int, default=720)
    p.add_argument("--warmup", type=int, default=2)
    p.add_argument("--frames", type=int, default=5)
    p.add_argument("--rounds", type=int, default=2)
    p.add_argument("--scenes", default="default,scenes/head.toml", help="cost scenes, comma-separated")
    p.add_argument("--only", default="", help="configuration names, comma-separated (default: all)")
    p.add_argument("--config", action="append", default=[], metavar="NAME=PRESET:KEY=V;KEY=V",
                   help="an extra configuration (repeatable); with --only NAME measures just it")
    p.add_argument("--no-cost", action="store_true", help="measure the error only")
    p.add_argument("--suite", action="store_true",
                   help="also measure each configuration on the generated suite (references/suite/, "
                        "about 40 s a configuration on lavapipe)")
    p.add_argument("--no-error", action="store_true",
                   help="measure the cost only (no references needed): for a machine with the GPU to report")
    p.add_argument("--costs", default="", metavar="FILE.json",
                   help="take each configuration's cost (and the adapter and size) from this report, "
                        "as --no-error wrote it, instead of measuring it")
    p.add_argument("--replot", action="store_true", help="draw the plot from --out's JSON, measuring nothing")
    p.add_argument("--out", default=os.path.join(ROOT, "references/quality.json"))
    p.add_argument("--plot", default=os.path.join(ROOT, "docs/images/quality.png"))
    a = p.parse_args()
    if a.replot:
        with open(a.out) as f:
            plot(json.load(f), a.plot)
        return
    exe = subsurface_bin()
    env = dict(os.environ)
    env.setdefault("WGPU_BACKEND", "vulkan")
    env.setdefault("SUBSURFACE_ASSETS", os.path.normpath(os.path.join(ROOT, "..", "shared", "assets")))
    only = set(filter(None, a.only.split(",")))
    names = sorted(os.path.basename(p)[:-4] for p in glob.glob(os.path.join(ROOT, "references/*.exr"))
                   if not p.endswith(".stderr.exr"))
    scenes = [s if s == "default" else os.path.join(ROOT, s) for s in a.scenes.split(",")]
    labels = [s if s == "default" else os.path.basename(s)[:-5] for s in scenes]
    report = {"adapter": "-", "size": f"{a.width}x{a.height}", "frames": a.frames, "rounds": a.rounds,
              "cost_scenes": labels, "error_scenes": names, "configs": []}
    measured = {}
    if a.costs:
        try:
            with open(a.costs) as f:
                given = json.load(f)
            measured = {c["name"]: c["cost"] for c in given["configs"]}
            for k in ("adapter", "size", "frames", "rounds", "cost_scenes"):
                report[k] = given[k]
        except (OSError, ValueError, KeyError, TypeError) as e:
            sys.exit(f"error: --costs {a.costs}: not a report written by --no-error ({e})")
        labels = given["cost_scenes"]
    configs = list(CONFIGS)
    for c in a.config:
        name, rest = c.split("=", 1)
        preset, _, keys = rest.partition(":")
        configs.append((name, preset, [k for k in keys.split(";") if k]))
    with tempfile.TemporaryDirectory() as tmp:
        for name, preset, keys in configs:
            if only and name not in only:
                continue
            c = {"name": name, "preset": preset, "keys": keys, "cost": {}, "errors": {}}
            if name in measured:
                c["cost"] = measured[name]
            for scene, label in zip(scenes, labels):
                if name in measured:
                    continue
                if a.no_cost:
                    c["cost"][label] = {"adapter": "-", "frame_ms": None, "skin_ms": None,
                                        "skin_share": None, "passes": {}}
                    continue
                c["cost"][label] = cost(exe, env, scene, preset, keys, a)
                report["adapter"] = c["cost"][label]["adapter"]
            costs = ", ".join(f"{l} {c['cost'][l]['skin_ms'] or 0:.3f} ms ({100 * (c['cost'][l]['skin_share'] or 0):.1f} %)"
                              for l in labels)
            if a.no_error:
                print(f"{name:30} {costs}", file=sys.stderr)
                report["configs"].append(c)
                continue
            for n in names:
                c["errors"][n] = error(exe, env, n, preset, keys, tmp)
            c["error"] = summary(c["errors"])
            suite = ""
            if a.suite:
                c["suite"] = suite_error(exe, env, preset, keys, tmp)
                suite = "; suite within 25 %: " + " / ".join(
                    f"{p} {100 * v['within_25']:.0f} %" for p, v in c["suite"].items())
            print(f"{name:30} {costs}; worst {100 * c['error']['worst_error']:+.1f} %, "
                  f"mean {100 * c['error']['mean_abs_error']:.1f} %{suite}", file=sys.stderr)
            report["configs"].append(c)
    with open(a.out, "w") as f:
        json.dump(report, f, indent=1)
    if a.no_error:
        return
    print(markdown(report))
    plot(report, a.plot)


if __name__ == "__main__":
    main()
