#!/usr/bin/env python3
"""Path-traced reference of a scene exported by `subsurface export-mitsuba`.

    python3 tools/reference/render_reference.py EXPORT_DIR/scene.xml --out ref.exr \
        [--spp 128] [--seed 0] [--width W --height H] [--max-depth 256] [--variant auto] \
        [--no-bounce]

Needs Mitsuba 3 (`python3 -m pip install mitsuba==3.9.1`). `--variant auto` (the default) takes
`llvm_ad_rgb`, which JIT-compiles the path tracer and runs several times faster, when an LLVM
shared library is found (DRJIT_LIBLLVM_PATH, else Debian's libLLVM-19 from the `libllvm19`
package), and `scalar_rgb`, which runs on any CPU, otherwise; `cuda_ad_rgb` on an NVIDIA GPU. The image is rendered in passes of --pass-spp samples, each with its own seed derived
from --seed (so the result depends only on --seed and --spp), and progress is printed after
every pass. The output is a linear-radiance RGB EXR (half float), the same radiance units as our
renderer's diffuse + specular (the exporter scales the emitters, docs/lab/fidelity.md).

Beside it, OUT.stderr.exr holds each pixel's standard error: the spread of the per-pass images
divided by sqrt(number of passes). A path-traced reference is never noise-free; with this the
comparison can tell its noise from a real difference (`subsurface compare` subtracts the noise
floor from the squared error and gives region means with their uncertainty).

A medium whose coefficients differ between channels (every skin) is rendered one channel at a
time (`--per-channel`, the default): three renders, each with every medium grey at one
channel's coefficients, each keeping its own channel. With a chromatic medium, `volpath` samples
every free flight for all three channels at once and weights each channel by the ratio of its
transmittance to the sampling density; over the hundreds of scattering events that light takes
through a thick backlit part, those weights multiply into a heavy-tailed estimator whose sample
mean falls short of its expectation for any sample count one can afford, and whose spread
underestimates its own error. Measured on a 10 mm slab of skin1 lit from behind: red 0.72 to
0.80 (standard errors 3-4 %, 8192 and 32768 samples) rendered chromatic, 0.952 (0.8 %, 8192
samples) rendered grey, where exact slab transport (adding-doubling) predicts 0.91 to 1.02.

`--no-bounce` renders the scene without light between parts (no_bounce.py): a path ends where,
after leaving a surface into the air, it reaches another surface. What is left is what a
renderer without global illumination computes; the difference from the full reference is the
light one part sends another (docs/lab/fidelity.md, finding 9). It needs a vectorised variant.
"""

import argparse
import os
import sys
import time


def parse_args(argv):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("scene", help="scene.xml written by `subsurface export-mitsuba`")
    p.add_argument("--out", required=True, help="output EXR (linear RGB)")
    p.add_argument("--spp", type=int, default=128, help="samples per pixel (default 128)")
    p.add_argument("--pass-spp", type=int, default=16,
                   help="samples per pass (default 16); the passes also give the standard error")
    p.add_argument("--seed", type=int, default=0, help="base seed (default 0)")
    p.add_argument("--width", type=int, help="override the exported width")
    p.add_argument("--height", type=int, help="override the exported height")
    p.add_argument("--max-depth", type=int, help="override the exported max_depth (256)")
    p.add_argument("--variant", default="auto",
                   help="Mitsuba variant: auto (llvm_ad_rgb when libLLVM is found, else scalar_rgb), "
                        "scalar_rgb, llvm_ad_rgb, cuda_ad_rgb")
    p.add_argument("--per-channel", dest="per_channel", action=argparse.BooleanOptionalAction, default=True,
                   help="render chromatic media one channel at a time, each grey (default; see above)")
    p.add_argument("--no-bounce", action="store_true",
                   help="end a path where it reaches a surface through the air after a surface "
                        "event: no light between parts (no_bounce.py; llvm_ad_rgb or cuda_ad_rgb)")
    p.add_argument("--quiet", action="store_true", help="no progress output")
    a = p.parse_args(argv)
    for k in ("spp", "pass_spp"):
        if getattr(a, k) < 1:
            p.error(f"--{k.replace('_', '-')}: must be at least 1")
    if a.spp % a.pass_spp != 0:
        p.error("--spp must be a multiple of --pass-spp (the passes must weigh the same for the standard error)")
    if a.spp // a.pass_spp < 2 and a.spp > 1:
        a.pass_spp = max(1, a.spp // 2)
    return a


DEBIAN_LIBLLVM = "/usr/lib/x86_64-linux-gnu/libLLVM-19.so"


def pick_variant(variant):
    """`auto`: the LLVM JIT variant when Dr.Jit can find libLLVM (it needs the path on Debian,
    where the library is versioned), else the scalar one. Must run before mitsuba is imported."""
    if variant != "auto":
        return variant
    if not os.environ.get("DRJIT_LIBLLVM_PATH") and os.path.isfile(DEBIAN_LIBLLVM):
        os.environ["DRJIT_LIBLLVM_PATH"] = DEBIAN_LIBLLVM
    if os.environ.get("DRJIT_LIBLLVM_PATH"):
        return "llvm_ad_rgb"
    return "scalar_rgb"


def stderr_path(out):
    base = out[:-4] if out.lower().endswith(".exr") else out
    return base + ".stderr.exr"


def channel_values(color):
    """The three floats of a Color3f parameter, scalar or JIT (a JIT array of one lane)."""
    import drjit as dr

    return [float(dr.slice(color[j]) if dr.is_jit_v(color) else color[j]) for j in range(3)]


def chromatic_media(mi, params):
    """The homogeneous media of the scene whose albedo or extinction differs between channels:
    (albedo key, sigma_t key, albedo, sigma_t) each."""
    media = []
    for key in params.keys():
        if not key.endswith(".albedo.value.value"):
            continue
        base = key[: -len("albedo.value.value")]
        sigma_key = base + "sigma_t.value.value"
        if sigma_key not in params.keys():
            continue
        albedo = channel_values(params[key])
        sigma_t = channel_values(params[sigma_key])
        if len(set(albedo)) > 1 or len(set(sigma_t)) > 1:
            media.append((key, sigma_key, albedo, sigma_t))
    return media


def render(a):
    """Returns (mean image, standard-error image, seconds). Raises on any Mitsuba error."""
    import mitsuba as mi
    import drjit as dr

    mi.set_variant(a.variant)
    params = {}
    if a.width:
        params["width"] = a.width
    if a.height:
        params["height"] = a.height
    if a.max_depth:
        params["max_depth"] = a.max_depth
    scene = mi.load_file(a.scene, **params)
    integrator = None
    if a.no_bounce:
        if a.variant.startswith("scalar"):
            raise RuntimeError("--no-bounce: needs llvm_ad_rgb (install libllvm19) or cuda_ad_rgb")
        sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
        import no_bounce

        no_bounce.register()
        # The exporter's volpath settings (export_mitsuba.rs): max_depth 256, rr_depth 64.
        integrator = mi.load_dict({"type": "volpath_nobounce", "max_depth": a.max_depth or 256, "rr_depth": 64})
    scene_params = mi.traverse(scene)
    media = chromatic_media(mi, scene_params) if a.per_channel else []
    # One render per channel with every medium grey at that channel's coefficients (see the
    # module's notes), or one render as the scene is.
    channels = [0, 1, 2] if media else [None]
    passes = -(-a.spp // a.pass_spp)
    total = a.spp * len(channels)
    mean = None
    stderr = None
    done_all = 0
    start = time.time()
    for c in channels:
        if c is not None:
            for albedo_key, sigma_key, albedo, sigma_t in media:
                scene_params[albedo_key] = mi.Color3f(albedo[c])
                scene_params[sigma_key] = mi.Color3f(sigma_t[c])
            scene_params.update()
        acc = None
        acc2 = None
        done = 0
        for i in range(passes):
            n = min(a.pass_spp, a.spp - done)
            # Distinct, deterministic seeds per pass: the sum is one render of a.spp samples.
            img = mi.render(scene, integrator=integrator, spp=n, seed=a.seed * 1000003 + i)
            # Plain Dr.Jit tensors (no numpy needed). Equal passes: the mean of the passes is
            # the render of a.spp samples, and their spread estimates its noise.
            acc = img if acc is None else acc + img
            acc2 = img * img if acc2 is None else acc2 + img * img
            # A Python integrator (--no-bounce) returns the image unevaluated, and the LLVM
            # backend launches kernels asynchronously: finish each pass before reporting it.
            dr.eval(acc, acc2)
            dr.sync_thread()
            done += n
            done_all += n
            if not a.quiet:
                el = time.time() - start
                eta = el / done_all * (total - done_all)
                what = "" if c is None else f" ({'RGB'[c]})"
                print(
                    f"\r{os.path.basename(a.out)}{what}: {done}/{a.spp} spp, {el:.0f} s, about {eta:.0f} s left ",
                    end="",
                    file=sys.stderr,
                    flush=True,
                )
        k = passes
        m = acc / k
        if k > 1:
            var_pass = dr.maximum(acc2 / k - m * m, 0.0) * (k / (k - 1))
            se = dr.sqrt(var_pass / k)
        else:
            se = m * 0.0
        if c is not None:
            # Keep channel c of this render: multiply by a 0/1 mask (plain tensors, no numpy).
            h, w = m.shape[0], m.shape[1]
            mask = mi.TensorXf([1.0 if j == c else 0.0 for j in range(3)] * (h * w), shape=(h, w, 3))
            m = m * mask
            se = se * mask
        mean = m if mean is None else mean + m
        stderr = se if stderr is None else stderr + se
    if not a.quiet:
        print(file=sys.stderr)
    return mean, stderr, time.time() - start


def write_exr(path, img):
    """Writes through a temporary file so that a failure leaves no partial EXR."""
    import mitsuba as mi

    tmp = os.path.join(os.path.dirname(os.path.abspath(path)), f".{os.path.basename(path)}.partial-{os.getpid()}.exr")
    try:
        # Half floats: plenty for radiance (11-bit mantissa, range to 65504) at half the size,
        # which matters for references committed to the repository.
        bmp = mi.Bitmap(img, mi.Bitmap.PixelFormat.RGB)
        bmp = bmp.convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float16, srgb_gamma=False)
        bmp.write(tmp)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)


def main(argv=None):
    a = parse_args(argv if argv is not None else sys.argv[1:])
    a.variant = pick_variant(a.variant)
    try:
        import mitsuba  # noqa: F401
    except ImportError:
        print("error: mitsuba is not installed (python3 -m pip install mitsuba==3.9.1)", file=sys.stderr)
        return 2
    if not os.path.isfile(a.scene):
        print(f"error: {a.scene}: no such file", file=sys.stderr)
        return 1
    try:
        img, stderr, secs = render(a)
        write_exr(a.out, img)
        write_exr(stderr_path(a.out), stderr)
    except Exception as e:  # Mitsuba raises RuntimeError with multi-line messages
        msg = " ".join(str(e).split())
        print(f"error: {a.scene}: {msg}", file=sys.stderr)
        return 1
    import drjit as dr

    h, w = img.shape[:2]
    mean = dr.mean(img.array)
    mean = float(mean[0]) if hasattr(mean, "__len__") else float(mean)  # llvm/cuda: an array
    print(f"{a.out}: {w}x{h}, {a.spp} spp, seed {a.seed}, {secs:.1f} s, mean radiance {mean:.5g}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
