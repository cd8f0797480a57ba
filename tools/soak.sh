#!/usr/bin/env bash
# The viewer soak (issue 15): `subsurface view --frames FRAMES --soak` in a window (under
# xvfb-run when there is no display), every frame changing the SSS and transmittance methods,
# the exposure, a light and the window size (1x1 included, and minimised to 0x0). Prints a line per 12-frame cycle
# and the verdict: resident memory from the middle of the run to its end (limit +1 %), GPU
# allocator bytes (+0.1 %) and live wgpu objects (no growth). Exits non-zero on growth or on
# any GPU validation error. CI runs 120 frames (crates/subsurface-cli/tests/view.rs).
#   tools/soak.sh [FRAMES] [extra view arguments...]    (default 10000 frames)
set -euo pipefail
cd "$(dirname "$0")/.."
frames="${1:-10000}"
shift || true
cargo build -q --release -p subsurface-cli
bin="${CARGO_TARGET_DIR:-target}/release/subsurface"
run=("$bin" view --width 320 --height 240 --frames "$frames" --soak "$@")
if [ -z "${DISPLAY:-}${WAYLAND_DISPLAY:-}" ]; then
    run=(xvfb-run -a -s "-screen 0 1280x800x24" "${run[@]}")
fi
start=$(date +%s)
"${run[@]}" 2>&1 | grep -E "^(soak|error)"
status=${PIPESTATUS[0]}
echo "soak: $frames frames in $(( $(date +%s) - start )) s"
exit "$status"
