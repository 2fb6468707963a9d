#!/usr/bin/env bash
# Workgroup-shape sweep of `svo-view --headless` (docs/gpu-benchmarks.md): the pool scene's
# three views at depth 8 and 1920x1200 with the thesis's settings, and the bunny at depth 8
# (shaded, and as glass), for each `--workgroup` shape; then the opaque bunny at depths 8 and
# 10 (cubes with primary rays only, contours shaded) at the shapes that matter for it.
# (bench/gpu_workgroup_opaque_h100.txt was taken with the same loop typed inline.)
#
# Usage: docs/bench/gpu_workgroup.sh BIN_DIR POOL.toml BUNNY.obj [FRAMES]
# Vulkan on a container without a loader: see gpu_bench.sh.
set -euo pipefail
bin=$1; scene=$2; mesh=$3; frames=${4:-50}
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-$(mktemp -d)}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
printf 'newmtl glass\nKd 0.85 0.92 1.0\nKs 0.1 0.1 0.1\nNi 1.5\nd 0.2\nillum 7\n' > "$work/glass.mtl"
{ printf 'mtllib glass.mtl\nusemtl glass\n'; grep -v '^mtllib\|^usemtl' "$mesh"; } > "$work/glass.obj"
"$bin/svo-bake" "$scene" --depth 8 -o "$work/pool.svo" -q
"$bin/svo-bake" "$mesh" --depth 8 -o "$work/bunny.svo" -q
"$bin/svo-bake" "$mesh" --depth 10 -o "$work/bunny10.svo" -q
"$bin/svo-bake" "$work/glass.obj" --depth 8 -o "$work/glass.svo" -q
run() { "$bin/svo-view" "$@" --headless --bench "$frames" | grep median | sed 's/ frame(s): median / /; s/ ms\/frame.*//'; }
printf '%-8s %10s %10s %10s %10s %10s\n' workgroup water bunny parallel bunny-shaded glass
for wg in 8x8 16x8 8x16 16x16 32x4 32x8 8x4 4x4 64x1; do
  w=$(run "$work/pool.svo" --view water --size 1920x1200 --bounces 1 --shadows none --workgroup $wg | cut -d' ' -f2)
  b=$(run "$work/pool.svo" --view bunny --size 1920x1200 --bounces 1 --shadows none --workgroup $wg | cut -d' ' -f2)
  p=$(run "$work/pool.svo" --view parallel --size 1920x1200 --bounces 1 --shadows none --workgroup $wg | cut -d' ' -f2)
  s=$(run "$work/bunny.svo" --size 1920x1080 --workgroup $wg | cut -d' ' -f2)
  g=$(run "$work/glass.svo" --size 1920x1080 --workgroup $wg | cut -d' ' -f2)
  printf '%-8s %10s %10s %10s %10s %10s\n' $wg $w $b $p $s $g
done
echo "wg d8prim d8shaded d10prim d10shaded (cube primary, contour shaded; ms)"
for wg in 8x8 32x8 16x16 16x8 64x4 8x8 32x8; do
  l=$wg
  for f in bunny bunny10; do
    for a in "--hit cube --bounces 0 --shadows none" "--hit contour"; do
      # shellcheck disable=SC2086
      l="$l $(run "$work/$f.svo" --size 1920x1080 --workgroup $wg $a | cut -d' ' -f2)"
    done
  done
  echo "$l"
done
