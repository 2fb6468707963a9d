#!/usr/bin/env bash
# The 2015 thesis's frame-rate table on a GPU (docs/gpu-benchmarks.md): its pool scene
# (examples/scenes/pool.toml) baked at depths 3-8 and 10, its three views (water, bunny,
# parallel) at 640x480 and 1920x1200, rendered by `svo-view --headless`.
#
# "thesis" runs use the thesis's settings: contours, no shadow rays (its section 1.7: "a
# whitted ray tracer without shadow rays") and one bounce a path: a primary ray that hits
# water spawns a reflection and a refraction ray and those spawn none (its section 1.5:
# every ray hits the water, "requiring two more traversals for the reflection and
# refraction rays"). "each" runs repeat the depth-8 1920x1200 ones with one reflection and
# one refraction allowed on each path (--bounces 1 alone, the setting of the tables before
# 2026-11-25, which also traces a refracted ray's reflection), and "wide" runs repeat the
# thesis's at depths 4-10 with the 64-ary view (--wide-view, off by default). "full" runs use
# svo-view's defaults (3 reflection and 3 refraction bounces, product shadows); at depth 8
# each is then compared with the CPU reference tracer (--vs-cpu, 3 frames on each side, so
# that the CPU's frames do not dominate the script's time).
#
# Usage: docs/bench/gpu_pool.sh BIN_DIR POOL.toml [FRAMES]
#   BIN_DIR holds release builds of svo-bake and svo-view; POOL.toml is the scene file (its
#   bunny path must resolve from where the file is). Prints each run's report.
# Vulkan on a container without a loader: see gpu_bench.sh.
set -euo pipefail
bin=$1; scene=$2; frames=${3:-50}
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-$(mktemp -d)}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
depths="3 4 5 6 7 8 10"
for d in $depths; do
  "$bin/svo-bake" "$scene" --depth $d -o "$work/pool$d.svo" -q
done
view() { echo "=== $*"; "$bin/svo-view" "$@" --headless --bench "$frames" | grep -v '^wrote'; }
check() { echo "=== $* --vs-cpu"; "$bin/svo-view" "$@" --headless --vs-cpu --bench 3 | grep -v '^wrote'; }
for d in $depths; do
  for v in water bunny parallel; do
    for size in 640x480 1920x1200; do
      echo "--- thesis depth $d view $v size $size"
      view "$work/pool$d.svo" --view $v --size $size --bounces 1 --path-bounces 1 --shadows none
    done
  done
done
for v in water bunny parallel; do
  echo "--- each depth 8 view $v size 1920x1200"
  view "$work/pool8.svo" --view $v --size 1920x1200 --bounces 1 --shadows none
done
for d in 4 6 8 10; do
  for v in water bunny parallel; do
    for size in 640x480 1920x1200; do
      echo "--- wide depth $d view $v size $size"
      view "$work/pool$d.svo" --view $v --size $size --bounces 1 --path-bounces 1 --shadows none --wide-view
    done
  done
done
for d in 8 10; do
  for v in water bunny parallel; do
    echo "--- full depth $d view $v size 1920x1200"
    view "$work/pool$d.svo" --view $v --size 1920x1200
    if [ $d = 8 ]; then
      check "$work/pool$d.svo" --view $v --size 1920x1200
    fi
  done
done
