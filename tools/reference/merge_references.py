#!/usr/bin/env python3
"""Merges independent renders of one reference into one with more samples.

    python3 tools/reference/merge_references.py OUT.exr A.exr:SPP_A B.exr:SPP_B [...]

Each input is a render of the same scene by render_reference.py with its own --seed (renders
with the same seed share their random numbers and must not be merged), and SPP its sample
count. The merged image is the sample-weighted mean, w_i = spp_i / sum(spp); its standard
error, written beside it as OUT.stderr.exr, is sqrt(sum(w_i^2 se_i^2)) from each input's own
.stderr.exr. So 8192 samples rendered today can join 8192 rendered yesterday, and a reference
gets as many samples as the time on hand allows, in as many sittings as it takes.
"""

import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import render_reference  # noqa: E402


def parse(argv):
    if len(argv) < 3 or any(":" not in a for a in argv[1:]):
        sys.exit(__doc__.split("\n\n")[1].strip())
    out = argv[0]
    inputs = []
    for a in argv[1:]:
        path, spp = a.rsplit(":", 1)
        try:
            n = int(spp)
        except ValueError:
            sys.exit(f"error: {a}: the sample count after ':' must be an integer")
        if n < 1:
            sys.exit(f"error: {a}: the sample count must be at least 1")
        for p in (path, render_reference.stderr_path(path)):
            if not os.path.isfile(p):
                sys.exit(f"error: {p}: no such file")
        inputs.append((path, n))
    return out, inputs


def main(argv=None):
    out, inputs = parse(argv if argv is not None else sys.argv[1:])
    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    import drjit as dr

    def load(path):
        bmp = mi.Bitmap(path).convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32, srgb_gamma=False)
        return mi.TensorXf(bmp)

    total = sum(n for _, n in inputs)
    mean = None
    var = None
    shape = None
    for path, n in inputs:
        img = load(path)
        se = load(render_reference.stderr_path(path))
        if shape is None:
            shape = img.shape
        if img.shape != shape or se.shape != shape:
            sys.exit(f"error: {path}: {img.shape[1]}x{img.shape[0]}, but the first input is {shape[1]}x{shape[0]}")
        w = n / total
        mean = img * w if mean is None else mean + img * w
        var = se * se * (w * w) if var is None else var + se * se * (w * w)
    render_reference.write_exr(out, mean)
    render_reference.write_exr(render_reference.stderr_path(out), dr.sqrt(var))
    print(f"{out}: {shape[1]}x{shape[0]}, {total} spp from {len(inputs)} renders")
    return 0


if __name__ == "__main__":
    sys.exit(main())
