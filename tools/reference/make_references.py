#!/usr/bin/env python3
"""Regenerates the committed references: every scenes/canonical/*.toml is exported with
`subsurface export-mitsuba` and path-traced to references/NAME.exr.

    python3 tools/reference/make_references.py [--spp 128] [--pass-spp 16] [--seed 0] [NAME ...]

Run from the repository root after `cargo build --release -p subsurface-cli` (or set
SUBSURFACE_BIN). Head scenes need ../shared/assets (the Lee Perry-Smith head); they are skipped
with a note when it is missing.
"""

import argparse
import glob
import os
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.normpath(os.path.join(HERE, "..", ".."))
sys.path.insert(0, HERE)
import render_reference  # noqa: E402


def subsurface_bin():
    if os.environ.get("SUBSURFACE_BIN"):
        return os.environ["SUBSURFACE_BIN"]
    for p in ("target/release/subsurface", "target/debug/subsurface"):
        if os.path.isfile(os.path.join(ROOT, p)):
            return os.path.join(ROOT, p)
    sys.exit("error: no subsurface binary (cargo build --release -p subsurface-cli, or set SUBSURFACE_BIN)")


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("names", nargs="*", help="scene names (default: all of scenes/canonical)")
    p.add_argument("--spp", type=int, default=128)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--pass-spp", type=int, default=16,
                   help="samples per pass (default 16); more per pass is faster, fewer gives a finer standard error")
    a = p.parse_args()
    scenes = sorted(glob.glob(os.path.join(ROOT, "scenes/canonical/*.toml")))
    names = a.names or [os.path.basename(s)[:-5] for s in scenes]
    os.makedirs(os.path.join(ROOT, "references"), exist_ok=True)
    exe = subsurface_bin()
    for name in names:
        scene = os.path.join(ROOT, "scenes/canonical", name + ".toml")
        with tempfile.TemporaryDirectory() as tmp:
            r = subprocess.run([exe, "export-mitsuba", scene, "--out", tmp], capture_output=True, text=True)
            if r.returncode != 0:
                if name.startswith("head") and "LeePerrySmith" in r.stderr:
                    print(f"{name}: skipped, no head model ({r.stderr.strip()})")
                    continue
                sys.exit(r.stderr.strip())
            out = os.path.join(ROOT, "references", name + ".exr")
            t = time.time()
            rc = render_reference.main([os.path.join(tmp, "scene.xml"), "--out", out, "--spp", str(a.spp),
                                         "--pass-spp", str(a.pass_spp), "--seed", str(a.seed)])
            if rc != 0:
                sys.exit(rc)
            print(f"{name}: {time.time() - t:.0f} s")


if __name__ == "__main__":
    main()
