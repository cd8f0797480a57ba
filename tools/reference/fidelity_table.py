#!/usr/bin/env python3
"""Writes docs/lab/fidelity.md (the error of every method x canonical scene against the committed
path-traced references, and the default method's against those rendered without light between
parts, references/no-bounce/), references/fidelity.json (the values the regression guard in
crates/subsurface-cli/tests/fidelity.rs checks against) and references/compare/*.png.

    python3 tools/reference/fidelity_table.py

Run from anywhere after `cargo build -p subsurface-cli` (or set SUBSURFACE_BIN). Needs a GPU
adapter (lavapipe will do: WGPU_BACKEND=vulkan). Head scenes need ../shared/assets.
"""

import datetime
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

# Every screen-space method with the default transmittance, every transmittance method with
# the default blur, and the baseline without either.
COMBOS = [("none", "off")] + [(s, "diffusion") for s in ("none", "gaussian6", "separable", "hable13")] + [
    ("separable", t) for t in ("off", "paper", "beer", "seed-report")
]
# Side-by-side images kept in the repository (the others go to a temporary directory).
KEEP_IMAGES = {("none", "off"), ("separable", "paper"), ("separable", "diffusion")}
# The default method (`subsurface render` with no flags). Every run is at `--quality high`
# (every term of the renderer), as the regression guard in tests/fidelity.rs renders; the
# cheaper presets are checked against their own targets there.
DEFAULT = ("separable", "diffusion")


def main():
    exe = subsurface_bin()
    env = dict(os.environ)
    env.setdefault("WGPU_BACKEND", "vulkan")
    names = sorted(os.path.basename(p)[:-4] for p in glob.glob(os.path.join(ROOT, "references/*.exr")) if not p.endswith(".stderr.exr"))
    os.makedirs(os.path.join(ROOT, "references/compare"), exist_ok=True)
    results = {}
    with tempfile.TemporaryDirectory() as tmp:
        for name in names:
            scene = os.path.join(ROOT, "scenes/canonical", name + ".toml")
            results[name] = {}
            # Scenes with a shadow edge (knife-edge) or a thickness curve (wedge): the curves,
            # plotted for every method.
            regions = scene[:-5] + ".regions.json"
            spec = json.load(open(regions)) if os.path.exists(regions) else {}
            kind = "edge" if "edge" in spec else "thickness" if "thickness" in spec else None
            for sss, tr in COMBOS:
                key = f"{sss}+{tr}"
                img = f"references/compare/{name}--{sss}--{tr}.png"
                out = os.path.join(ROOT, img) if (sss, tr) in KEEP_IMAGES else os.path.join(tmp, "x.png")
                plot = f"references/compare/{name}--{sss}--{tr}.{kind}.png" if kind else None
                r = subprocess.run(
                    [exe, "compare", "--quality", "high", os.path.join(ROOT, "references", name + ".exr"), scene,
                     "--sss", sss, "--transmittance", tr, "--json", "--out", out]
                    + (["--plot", os.path.join(ROOT, plot)] if plot else []),
                    capture_output=True, text=True, env=env)
                if r.returncode != 0:
                    sys.exit(f"{name} {key}: {r.stderr.strip()}")
                j = json.loads(r.stdout)
                results[name][key] = {
                    "rmse": j["rmse"],
                    "rel_rmse": j["rel_rmse"],
                    "noise_rms": j["noise_rms"],
                    "rmse_debiased": j["rmse_debiased"],
                    "rel_rmse_debiased": j["rel_rmse_debiased"],
                    "flip_mean": j["flip_mean"],
                    "regions": {g["name"]: g["rel_error"] for g in j["regions"]},
                    "regions_stderr": {g["name"]: g["rel_stderr"] for g in j["regions"]},
                    "image": img if (sss, tr) in KEEP_IMAGES else None,
                }
                if j.get("edge"):
                    e = j["edge"]
                    results[name][key]["edge"] = {
                        "edge_width_mm": e["edge_width_mm"],
                        "edge_width_mm_reference": e["edge_width_mm_reference"],
                        "edge_width_rel_error": e["edge_width_rel_error"],
                        "plot": plot,
                    }
                if j.get("thickness"):
                    t = j["thickness"]
                    results[name][key]["thickness"] = {
                        "max_abs_rel_error": t["max_abs_rel_error"],
                        "curve": [[b["thickness_mm"], b["rel_error"], b["significant"]] for b in t["bins"]],
                        "plot": plot,
                    }
                print(f"{name:16} {key:22} RMSE {j['rmse']:.4f} debiased {j['rmse_debiased']} FLIP {j['flip_mean']:.4f} "
                      + " ".join(f"{g['name']} {100 * g['rel_error']:+.1f}%" for g in j["regions"]), file=sys.stderr)
        # The default method without its bounce (--bounce-ring 0) against the references
        # without light between parts (render_reference.py --no-bounce): the direct part, like
        # with like. And the share of the full reference's light that the light between parts
        # is in the path tracer, beside the share the bounce adds to ours.
        no_bounce = {}
        for path in sorted(glob.glob(os.path.join(ROOT, "references/no-bounce/*.exr"))):
            if path.endswith(".stderr.exr"):
                continue
            name = os.path.basename(path)[:-4]

            def without_bounce(reference):
                r = subprocess.run(
                    [exe, "compare", "--quality", "high", reference, os.path.join(ROOT, "scenes/canonical", name + ".toml"),
                     "--sss", DEFAULT[0], "--transmittance", DEFAULT[1], "--bounce-ring", "0",
                     "--json", "--out", os.path.join(tmp, "x.png")],
                    capture_output=True, text=True, env=env)
                if r.returncode != 0:
                    sys.exit(f"no-bounce/{name}: {r.stderr.strip()}")
                return json.loads(r.stdout)

            j = without_bounce(path)
            off_full = {g["name"]: g["rel_error"] for g in
                        without_bounce(os.path.join(ROOT, "references", name + ".exr"))["regions"]}
            full = results.get(name, {}).get("+".join(DEFAULT), {}).get("regions", {})
            regions = {g["name"]: g["rel_error"] for g in j["regions"]}
            no_bounce[name] = {
                "regions": regions,
                "regions_stderr": {g["name"]: g["rel_stderr"] for g in j["regions"]},
                "regions_full": full,
                # ours without the bounce / full reference, and / reference without light
                # between parts: their ratio is the references' own.
                "path_tracer_share": {k: 1 - (1 + off_full[k]) / (1 + e) for k, e in regions.items()
                                      if e is not None and off_full.get(k) is not None},
                "bounce_share": {k: full[k] - off_full[k] for k in regions
                                 if full.get(k) is not None and off_full.get(k) is not None},
            }
            print(f"no-bounce/{name:16} " + " ".join(f"{g['name']} {100 * g['rel_error']:+.1f}%" for g in j["regions"]),
                  file=sys.stderr)
    with open(os.path.join(ROOT, "references/fidelity.json"), "w") as f:
        json.dump({"generated_by": "tools/reference/fidelity_table.py", "scenes": results, "no_bounce": no_bounce},
                  f, indent=1)
        f.write("\n")
    write_markdown(results, no_bounce)


def write_markdown(results, no_bounce):
    path = os.path.join(ROOT, "docs/lab/fidelity.md")
    with open(path) as f:
        text = f.read()
    begin, end = "<!-- table: begin (tools/reference/fidelity_table.py) -->", "<!-- table: end -->"
    lines = [begin, "", f"Generated {datetime.date.today().isoformat()} on `{os.environ.get('WGPU_BACKEND', 'vulkan')}`.", ""]
    for name, combos in results.items():
        lines.append(f"### {name}")
        lines.append("")
        region_names = list(next(iter(combos.values()))["regions"])
        first = next(iter(combos.values()))
        if first.get("noise_rms") is not None:
            lines.append(f"Reference noise (RMS of its per-pixel standard error): {first['noise_rms']:.4f}; "
                         "region means: ± one standard error of the reference's mean.")
            lines.append("")
        lines.append("| sss + transmittance | RMSE | RMSE, noise removed | rel. | FLIP | "
                     + " | ".join(f"{r} (mean err.)" for r in region_names) + " |")
        lines.append("|---|---:|---:|---:|---:|" + "---:|" * len(region_names))

        def reg(v, r):
            se = (v.get("regions_stderr") or {}).get(r)
            pm = f" ±{100 * se:.1f}" if se is not None else ""
            if v["regions"][r] is None:  # a black reference region: no relative error
                return "n/a"
            return f"{100 * v['regions'][r]:+.1f}%{pm}"

        def opt(x, fmt):
            return "–" if x is None else format(x, fmt)

        for key, v in combos.items():
            regs = " | ".join(reg(v, r) for r in region_names)
            rel = None if v.get("rel_rmse_debiased") is None else 100 * v["rel_rmse_debiased"]
            lines.append(f"| `{key}` | {v['rmse']:.4f} | {opt(v.get('rmse_debiased'), '.4f')} | "
                         f"{opt(rel, '.0f')}% | {v['flip_mean']:.3f} | {regs} |")
        lines.append("")
        if first.get("edge"):
            lines.append("Knife edge: 10-90 % rise distance across the shadow edge, averaged along it (mm, R / G / B); "
                         f"reference {' / '.join(f'{x:.2f}' for x in first['edge']['edge_width_mm_reference'])} mm.")
            lines.append("")
            lines.append("| sss + transmittance | width R | width G | width B | error R | error G | error B |")
            lines.append("|---|---:|---:|---:|---:|---:|---:|")
            for key, v in combos.items():
                e = v["edge"]
                lines.append(f"| `{key}` | " + " | ".join(f"{x:.2f}" for x in e["edge_width_mm"]) + " | "
                             + " | ".join(f"{100 * x:+.0f}%" for x in e["edge_width_rel_error"]) + " |")
            lines.append("")
            lines.append("Curves across the edge (real-time solid, reference dashed), per blur:")
            lines.append("")
            for key, v in combos.items():
                if key.endswith("+diffusion") or key == "none+off":
                    lines.append(f"![{name} {key} edge](../../{v['edge']['plot']})")
                    lines.append("")
        if first.get("thickness"):
            lines.append("Against thickness (pixels binned by the thickness the light crosses, 1 mm bins): worst "
                         "relative error per channel where the reference exceeds 1 % of its thinnest bin.")
            lines.append("")
            lines.append("| sss + transmittance | worst R | worst G | worst B |")
            lines.append("|---|---:|---:|---:|")
            for key, v in combos.items():
                lines.append(f"| `{key}` | " + " | ".join(f"{100 * x:.0f}%" for x in v["thickness"]["max_abs_rel_error"]) + " |")
            lines.append("")
            lines.append("Mean radiance against thickness (real-time solid, reference dashed):")
            lines.append("")
            for key, v in combos.items():
                if key.endswith("+diffusion") or key in ("none+off", "separable+paper"):
                    lines.append(f"![{name} {key} thickness](../../{v['thickness']['plot']})")
                    lines.append("")
        for key, v in combos.items():
            if v["image"]:
                lines.append(f"`{key}` (real-time | reference | FLIP):")
                lines.append("")
                lines.append(f"![{name} {key}](../../{v['image']})")
                lines.append("")
    if no_bounce:
        lines.append("### Light between parts")
        lines.append("")
        lines.append(f"`{'+'.join(DEFAULT)}` against the full reference (as above); the same without its bounce "
                     "(`--bounce-ring 0`) against the reference rendered without light between parts "
                     "(`references/no-bounce/`, `render_reference.py --no-bounce`; region means, ± one standard "
                     "error of the reference's mean); and the share of the full reference's light that is light "
                     "between parts in the path tracer (1 - no-bounce / full) beside the share the bounce adds "
                     "to ours (finding 11).")
        lines.append("")
        lines.append("| scene | region | ours vs full reference | ours without the bounce vs no-bounce reference "
                     "| light between parts: path tracer | ours (the bounce) |")
        lines.append("|---|---|---:|---:|---:|---:|")
        pct = lambda x: "–" if x is None else f"{100 * x:+.1f}%"
        for name, v in no_bounce.items():
            for r, e in v["regions"].items():
                se = v["regions_stderr"].get(r)
                now = "n/a" if e is None else f"{100 * e:+.1f}%" + (f" ±{100 * se:.1f}" if se is not None else "")
                lines.append(f"| {name} | {r} | {pct(v['regions_full'].get(r))} | {now} "
                             f"| {pct(v['path_tracer_share'].get(r))} | {pct(v['bounce_share'].get(r))} |")
        lines.append("")
    lines.append(end)
    if begin in text and end in text:
        text = text[: text.index(begin)] + "\n".join(lines) + text[text.index(end) + len(end):]
    else:
        text = text.rstrip() + "\n\n" + "\n".join(lines) + "\n"
    with open(path, "w") as f:
        f.write(text)
    print(f"wrote {path}", file=sys.stderr)


if __name__ == "__main__":
    main()
