#!/bin/bash
# Interleaved A/B timing of two `subsurface` binaries (e.g. the previous commit's release
# build and this one's) on the head and the default scene, separable SSS, transmittance off
# and diffusion, 1280x720: ROUNDS rounds of old then new, one line per run (frame ms and the
# median ms of each pass). Single runs on a shared machine scatter by 15-30 %; compare rounds.
# Usage: tools/ab_bench.sh OLD_BINARY NEW_BINARY [ROUNDS]
set -euo pipefail
old=$1 new=$2 rounds=${3:-3}
cd "$(dirname "$0")/.."
for round in $(seq "$rounds"); do
  for side in old new; do
    bin=$old
    [ "$side" = new ] && bin=$new
    for scene in scenes/head.toml default; do
      args=(--width 1280 --height 720 --sss separable --transmittance off,diffusion
        --frames 5 --warmup 2 --json)
      [ "$scene" != default ] && args=("$scene" "${args[@]}")
      "$bin" bench "${args[@]}" 2>/dev/null | python3 -c "
import json, sys
for run in json.load(sys.stdin)['runs']:
    passes = {p['name']: round(p['ms'], 1) for p in run['passes']}
    print('$round $side ${scene##*/}', run['transmittance'], round(run['frame_ms'], 1), passes)"
    done
  done
done
