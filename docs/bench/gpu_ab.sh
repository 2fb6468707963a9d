#!/usr/bin/env bash
# Two builds of svo-view side by side on one GPU (docs/gpu-benchmarks.md): ROUNDS rounds
# alternating build A and build B, each walk (the octree, and the 64-ary view with
# --wide-view) on the pool's water, parallel and bunny views with the thesis's settings, the
# water view with svo-view's defaults, and the bunny alone (cube primary rays, and shaded
# with the defaults). After the rounds, each build's images of every case are compared byte
# for byte ("images identical" or "images DIFFER").
#
# Usage: docs/bench/gpu_ab.sh BIN_A BIN_B POOL.toml BUNNY [FRAMES] [ROUNDS]
#   BIN_A and BIN_B hold release builds of svo-view (BIN_A's svo-bake bakes the trees);
#   POOL.toml is the scene file (its bunny path must resolve from where the file is); BUNNY
#   is the Stanford bunny. Prints "== round R CASE WALK BUILD" and each run's report.
# Vulkan on a container without a loader: see gpu_bench.sh.
set -euo pipefail
a=$1; b=$2; scene=$3; mesh=$4; frames=${5:-100}; rounds=${6:-3}
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-$(mktemp -d)}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
"$a/svo-bake" "$scene" --depth 8 -o "$work/pool8.svo" -q
"$a/svo-bake" "$mesh" --depth 8 -o "$work/bunny8.svo" -q
thesis="--bounces 1 --path-bounces 1 --shadows none"
cases=(
  "water-thesis|$work/pool8.svo --view water --size 1920x1200 $thesis"
  "water-defaults|$work/pool8.svo --view water --size 1920x1200"
  "parallel-thesis|$work/pool8.svo --view parallel --size 1920x1200 $thesis"
  "poolbunny-thesis|$work/pool8.svo --view bunny --size 1920x1200 $thesis"
  "bunny-cube-primary|$work/bunny8.svo --size 1920x1080 --hit cube --bounces 0 --shadows none"
  "bunny-defaults|$work/bunny8.svo --size 1920x1080"
)
for r in $(seq 1 "$rounds"); do
  for c in "${cases[@]}"; do
    name=${c%%|*}; args=${c#*|}
    for walk in octree wide; do
      extra=""; [ $walk = wide ] && extra="--wide-view"
      for build in A B; do
        bin=$a; [ $build = B ] && bin=$b
        echo "== round $r $name $walk $build"
        # shellcheck disable=SC2086
        "$bin/svo-view" $args $extra --headless --bench "$frames" | grep -v '^wrote\|^adapter\|^[0-9]*x[0-9]* depth'
      done
    done
  done
done
same=1
for c in "${cases[@]}"; do
  name=${c%%|*}; args=${c#*|}
  for walk in octree wide; do
    extra=""; [ $walk = wide ] && extra="--wide-view"
    for build in A B; do
      bin=$a; [ $build = B ] && bin=$b
      # shellcheck disable=SC2086
      "$bin/svo-view" $args $extra --headless -o "$work/$name-$walk-$build.png" >/dev/null
    done
    cmp -s "$work/$name-$walk-A.png" "$work/$name-$walk-B.png" || { same=0; echo "$name $walk: images DIFFER"; }
  done
done
"$a/svo-view" "$work/pool8.svo" --headless --bench 1 | grep '^adapter'
[ $same = 1 ] && echo "images identical"
