#!/usr/bin/env bash
# One call on a lent GPU (docs/gpu-benchmarks.md): the two WGSL walks side by side, the
# thesis's frame-rate table with each, and each walk's image against the CPU tracer's.
#
#   1. A/B: ROUNDS rounds alternating the octree walk and the 64-ary view (`--wide-view`) on
#      the views that decide between them: the pool's water, parallel and bunny views with the
#      thesis's settings, the water view with svo-view's defaults, and the bunny alone (cube
#      and contour primary rays, and shaded with the defaults) at depths 8, 9 (odd: the view's
#      2x2x2 root) and 10.
#   2. The thesis's table (the pool at depths 3-8 and 10; water, bunny and parallel views at
#      640x480 and 1920x1200; contours, no shadow rays, one bounce a path) with each walk.
#   3. `--vs-cpu` at depth 8, 1920x1200, each view with each walk (3 frames each side).
#
# Usage: docs/bench/gpu_walks.sh BIN_DIR POOL.toml BUNNY [FRAMES] [ROUNDS]
#   BIN_DIR holds release builds of svo-bake and svo-view; POOL.toml is the scene file (its
#   bunny path must resolve from where the file is); BUNNY is the Stanford bunny (.ply/.obj).
#   Prints each run's report; "== NAME WALK" heads each A/B run.
# Vulkan on a container without a loader: see gpu_bench.sh.
set -euo pipefail
bin=$1; scene=$2; mesh=$3; frames=${4:-100}; rounds=${5:-3}
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-$(mktemp -d)}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
for d in 3 4 5 6 7 8 10; do
  "$bin/svo-bake" "$scene" --depth $d -o "$work/pool$d.svo" -q
done
for d in 8 9 10; do
  "$bin/svo-bake" "$mesh" --depth $d -o "$work/bunny$d.svo" -q
done
thesis=(--bounces 1 --path-bounces 1 --shadows none)
# name, then svo-view's arguments
cases=(
  "water-thesis-d8|$work/pool8.svo --view water --size 1920x1200 ${thesis[*]}"
  "water-defaults-d8|$work/pool8.svo --view water --size 1920x1200"
  "parallel-thesis-d8|$work/pool8.svo --view parallel --size 1920x1200 ${thesis[*]}"
  "poolbunny-thesis-d8|$work/pool8.svo --view bunny --size 1920x1200 ${thesis[*]}"
  "water-thesis-d7|$work/pool7.svo --view water --size 1920x1200 ${thesis[*]}"
  "bunny-cube-primary-d8|$work/bunny8.svo --size 1920x1080 --hit cube --bounces 0 --shadows none"
  "bunny-contour-primary-d8|$work/bunny8.svo --size 1920x1080 --hit contour --bounces 0 --shadows none"
  "bunny-defaults-d8|$work/bunny8.svo --size 1920x1080"
  "bunny-cube-primary-d9|$work/bunny9.svo --size 1920x1080 --hit cube --bounces 0 --shadows none"
  "bunny-contour-primary-d9|$work/bunny9.svo --size 1920x1080 --hit contour --bounces 0 --shadows none"
  "bunny-cube-primary-d10|$work/bunny10.svo --size 1920x1080 --hit cube --bounces 0 --shadows none"
  "bunny-contour-primary-d10|$work/bunny10.svo --size 1920x1080 --hit contour --bounces 0 --shadows none"
  "bunny-defaults-d10|$work/bunny10.svo --size 1920x1080"
)
run() { "$bin/svo-view" "$@" --headless --bench "$frames" | grep -v '^wrote'; }
first=1
for r in $(seq 1 "$rounds"); do
  for c in "${cases[@]}"; do
    name=${c%%|*}; args=${c#*|}
    for walk in octree wide; do
      extra=(); [ $walk = wide ] && extra=(--wide-view)
      echo "== round $r $name $walk"
      # word splitting of $args is intended: it holds paths without spaces and flags
      # shellcheck disable=SC2086
      if [ $first = 1 ]; then run $args "${extra[@]}"; else run $args "${extra[@]}" | grep -v '^adapter\|^[0-9]*x[0-9]* depth'; fi
    done
  done
  first=0
done
for d in 3 4 5 6 7 8 10; do
  for v in water bunny parallel; do
    for size in 640x480 1920x1200; do
      for walk in octree wide; do
        extra=(); [ $walk = wide ] && extra=(--wide-view)
        echo "--- thesis depth $d view $v size $size $walk"
        run "$work/pool$d.svo" --view $v --size $size "${thesis[@]}" "${extra[@]}" | grep 'frame(s)'
      done
    done
  done
done
for v in water bunny parallel; do
  for walk in octree wide; do
    extra=(); [ $walk = wide ] && extra=(--wide-view)
    echo "=== vs-cpu thesis depth 8 view $v size 1920x1200 $walk"
    "$bin/svo-view" "$work/pool8.svo" --view $v --size 1920x1200 "${thesis[@]}" "${extra[@]}" \
      --headless --vs-cpu --bench 3 | grep -v '^wrote'
  done
done
