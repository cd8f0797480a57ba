"""`suite.py explain`: what each region that misses is made of (issue 39, "each miss explained
with its measured figures").

For every counted region of the report whose default error is outside --band, the scene is
rendered again with one part of the method changed at a time (the ablations below), and the
region's mean is read per channel from `subsurface compare --json`. From those runs:

- the reflected light (transmittance off) and the transmitted light (the rest), in luminance;
- what each transmitted term adds (lateral taps, unscattered, once scattered);
- the error per pixel (no transmitted map) and at 4 x 4 samples a pixel (no sampling error);
- the transmitted light the path tracer implies, reference minus our reflected light, against
  ours, per channel;
- a verdict: the first change that brings the region within the band, else the share of the
  error the transmitted light would have to carry.

The verdict is read from the measurements, not chosen per scene: the rules are in `verdict`.
"""

import json
import os
import tempfile

LUM = (0.2126, 0.7152, 0.0722)

# (key, compare arguments, what the run shows)
ABLATIONS = [
    ("default", [], "as shipped"),
    ("reflected", ["--transmittance", "off"], "no transmitted light: what the front surface reflects"),
    ("no_lateral", ["--lateral-taps", "0"], "the chord's slab alone"),
    ("no_unscattered", ["--set", "transmittance.ballistic=false"], "without the unscattered light"),
    ("no_single", ["--set", "transmittance.single_scattering=false"], "without the once-scattered light"),
    ("no_side_walls", ["--set", "transmittance.side_walls=false"], "without the side walls' share"),
    ("no_thin_parts", ["--set", "sss.thin_parts=false"], "thin parts reflect as thick ones"),
    ("per_pixel", ["--map-texel-mm", "0"], "every pixel evaluates its own transmitted light"),
    ("no_blur", ["--sss", "none"], "no screen-space diffusion"),
    ("supersample", ["--supersample", "4"], "4 x 4 samples a pixel, as the path tracer's box filter"),
]


def lum(rgb):
    return sum(c * w for c, w in zip(rgb, LUM))


# Terms whose removal can explain a miss, as (ablation, what it removes).
TERMS = (("no_lateral", "lateral taps"), ("no_unscattered", "unscattered light"),
         ("no_single", "once-scattered light"), ("no_side_walls", "side walls' share"),
         ("no_thin_parts", "thin parts' reflectance"))


def verdict(r, band):
    """The first measured change that brings the region within the band, in the order of the
    cheapest explanation: sampling, the map, a term that over- or under-counts, the blur; else
    the transmitted light's own transport."""
    err = r["error"]
    if abs(r["errors"]["supersample"]) <= band:
        return "sampling", "4 x 4 samples a pixel bring it to {:+.0%}".format(r["errors"]["supersample"])
    if abs(r["errors"]["per_pixel"]) <= band:
        return "map", "evaluated per pixel it reads {:+.0%}".format(r["errors"]["per_pixel"])
    for key, name in TERMS:
        if abs(r["errors"][key]) <= band and abs(r["errors"][key]) < abs(err):
            return "term", "without the {} it reads {:+.0%}".format(name, r["errors"][key])
    if abs(r["errors"]["no_blur"]) <= band:
        return "blur", "without the blur it reads {:+.0%}".format(r["errors"]["no_blur"])
    t_ours, t_needed = r["transmitted"], r["transmitted_needed"]
    if r["reflected_share"] >= 0.5:
        # Most of the region's light is reflected: a transmitted error cannot carry it alone.
        if abs(r["errors"]["reflected"]) < abs(err):
            return "reflected", ("{:.0%} of ours is reflected light; without the transmitted light it reads "
                                 "{:+.0%}").format(r["reflected_share"], r["errors"]["reflected"])
        return "reflected", "{:.0%} of ours is reflected light, {:.2f}x the whole reference".format(
            r["reflected_share"], r["ours"] / r["reference"])
    if t_needed <= 0:
        return "transmitted", "the reference is below our reflected light alone"
    return "transmitted", "ours transmits {:.2f}x what the reference implies (R/G/B {})".format(
        t_ours / t_needed, " / ".join("{:.2f}".format(x) if x is not None else "-" for x in r["transmitted_ratio_rgb"]))


def explain(misses, run_compare, band):
    """misses: [(scene, region, error, held_out)]; run_compare(scene, args, tmp, supersample)
    -> compare's JSON. Returns one record per miss."""
    out = []
    by_scene = {}
    for scene, region, err, held in misses:
        by_scene.setdefault(scene, []).append((region, err, held))
    with tempfile.TemporaryDirectory() as tmp:
        for k, (scene, regions) in enumerate(sorted(by_scene.items())):
            runs = {}
            for key, args, _ in ABLATIONS:
                ss = 1
                if key == "supersample":
                    args, ss = [], 4
                j = run_compare(scene, args, tmp, ss)
                runs[key] = {g["name"]: g for g in j["regions"]}
            for region, err, held in regions:
                ref = runs["default"][region]["mean_reference"]
                ours = runs["default"][region]["mean_realtime"]
                refl = runs["reflected"][region]["mean_realtime"]
                rec = {
                    "scene": scene, "region": region, "held_out": held, "error": err,
                    "reference": lum(ref), "ours": lum(ours), "reference_rgb": ref, "ours_rgb": ours,
                    "errors": {key: runs[key][region]["rel_error"] for key, _, _ in ABLATIONS},
                    "reflected": lum(refl),
                    "transmitted": lum(ours) - lum(refl),
                    "transmitted_needed": lum(ref) - lum(refl),
                    "adds": {key: lum(ours) - lum(runs[key][region]["mean_realtime"])
                             for key, _ in TERMS},
                }
                rec["reflected_share"] = rec["reflected"] / max(rec["ours"], 1e-12)
                rec["transmitted_ratio_rgb"] = [
                    (o - f) / (r_ - f) if r_ - f > 1e-6 * max(r_, 1e-12) else None
                    for o, f, r_ in zip(ours, refl, ref)]
                rec["cause"], rec["why"] = verdict(rec, band)
                out.append(rec)
            print(f"[{k + 1}/{len(by_scene)}] {scene}: " + ", ".join(
                f"{r['region']} {r['cause']}" for r in out if r["scene"] == scene), flush=True)
    return out


def markdown(records, band):
    lines = [
        f"Regions outside ±{band:.0%} with the defaults, each rendered again with one part changed "
        "(`suite.py explain`). Columns: the error as shipped; per pixel (no map); at 4 x 4 samples; "
        "without the lateral taps, the unscattered and the once-scattered light, the side walls' share and "
        "the thin parts' reflectance; the share of ours "
        "that is reflected light; the verdict and its figure.",
        "",
        "| scene | region | error | per pixel | 4x4 | no lateral | no unscattered | no single | no walls | no thin | reflected | cause | measured |",
        "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|---|",
    ]
    for r in sorted(records, key=lambda r: (r["cause"], r["scene"], r["region"])):
        e = r["errors"]
        lines.append("| {}{} | {} | {:+.0%} | {:+.0%} | {:+.0%} | {:+.0%} | {:+.0%} | {:+.0%} | {:+.0%} | {:+.0%} | {:.0%} | {} | {} |".format(
            r["scene"], " (held out)" if r["held_out"] else "", r["region"], r["error"], e["per_pixel"],
            e["supersample"], e["no_lateral"], e["no_unscattered"], e["no_single"], e["no_side_walls"],
            e["no_thin_parts"], r["reflected_share"],
            r["cause"], r["why"]))
    counts = {}
    for r in records:
        counts[r["cause"]] = counts.get(r["cause"], 0) + 1
    lines += ["", "Causes: " + ", ".join(f"{c} {n}" for c, n in sorted(counts.items(), key=lambda t: -t[1]))]
    return "\n".join(lines)


def save(records, path, band):
    tmp = path + ".partial"
    with open(tmp, "w") as f:
        json.dump({"generated_by": "tools/reference/suite.py explain", "band": band,
                   "ablations": {k: {"args": a, "shows": s} for k, a, s in ABLATIONS},
                   "misses": records}, f, indent=1)
        f.write("\n")
    os.replace(tmp, path)
