#!/usr/bin/env bash
# Fuzzes every loader a user's files reach for SECONDS each (default 600): the glTF/GLB
# loader, scene files (TOML parsing, validation, loading) and images (PNG, JPEG, EXR).
# Each target mutates its seeds from a fresh random seed (set SUBSURFACE_FUZZ_SEED to
# repeat a run) and fails on any panic, hang (> 5 s) or malformed error; failing inputs are
# saved under target/tmp. `cargo test` runs the same targets as a short fixed replay.
set -euo pipefail
cd "$(dirname "$0")/.."
export SUBSURFACE_FUZZ_SECONDS="${1:-600}"
cargo build -q -p subsurface-render --tests
cargo test -q -p subsurface-render --test integration mesh_fuzz::mutants -- --nocapture 2>&1 | grep -E "executions|failures|panicked|test result" &
mesh=$!
cargo test -q -p subsurface-render --test integration fuzz_inputs:: -- --nocapture 2>&1 | grep -E "executions|failures|panicked|test result" &
inputs=$!
status=0
wait "$mesh" || status=1
wait "$inputs" || status=1
exit "$status"
