#!/usr/bin/env bash
# Hashes of what the binaries make from the shared meshes: .svo bytes (bakes in memory and in
# parts, chunked output, conversions, exports), CPU renders and their AOVs, and GPU renders
# (on whatever adapter wgpu finds: lavapipe on a machine without a GPU). A change that should
# not change behaviour leaves every line the same: run it before and after and diff.
#
# Usage: scripts/output_hashes.sh BIN_DIR [MODELS_DIR] > hashes.txt
#   BIN_DIR holds builds of svo-bake and svo-view; MODELS_DIR defaults to ../shared/models.
set -euo pipefail
bin=$1
models=${2:-$(cd "$(dirname "$0")/../.." && pwd)/shared/models}
repo=$(cd "$(dirname "$0")/.." && pwd)
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-$(mktemp -d)}
w=$(mktemp -d)
trap 'rm -rf "$w"' EXIT
bunny=$models/stanford/bun_zipper.ply
bake() { "$bin/svo-bake" "$@" -q; }
bake "$bunny" --depth 8 -o "$w/bunny8.svo"
bake "$bunny" --depth 10 -o "$w/bunny10.svo" --threads 1
bake "$bunny" --depth 10 -o "$w/bunny10_parts.svo" --memory 64MiB
bake "$bunny" --depth 9 --solid vote -o "$w/bunny9_solid.svo"
bake "$bunny" --depth 7 --strategy aabb-plane-sat --channels normal --pad 2 -o "$w/bunny7_sat.svo"
bake "$models/classic/teapot.obj" --depth 8 -o "$w/teapot8.svo"
bake "$models/classic/spot.obj" --depth 9 --no-contours -o "$w/spot9.svo"
bake "$models/gltf/DamagedHelmet.glb" --depth 8 -o "$w/helmet8.svo"
bake "$models/gltf/GlassVaseFlowers.glb" --depth 8 -o "$w/vase8.svo"
bake "$repo/examples/scenes/pool.toml" --depth 8 -o "$w/pool8.svo"
bake "$w/bunny10.svo" -o "$w/bunny10_conv.svo" --channels normal
bake "$bunny" --depth 8 -o "$w/bunny8.binvox"
bake "$bunny" --depth 7 -o "$w/bunny7.vox"
# A plan, its parts one by one and the merge, as on a cluster.
"$bin/svo-bake" plan "$bunny" --depth 9 --parts 4 --bins -o "$w/plan.svoplan" >/dev/null
for i in 0 1 2 3; do "$bin/svo-bake" part "$w/plan.svoplan" $i >/dev/null; done
"$bin/svo-bake" merge "$w/plan.svoplan" -o "$w/bunny9_merged.svo" >/dev/null
"$bin/svo-bake" merge "$w/plan.svoplan" --chunked -o "$w/bunny9_chunked.svo" >/dev/null
cpu() { "$bin/svo-view" "$@" --cpu >/dev/null; }
gpu() { "$bin/svo-view" "$@" --headless >/dev/null; }
cpu "$w/bunny8.svo" --size 320x240 -o "$w/bunny8_cpu.png"
cpu "$w/bunny8.svo" --size 320x240 --aov depth -o "$w/bunny8_depth.pfm"
cpu "$w/bunny8.svo" --size 320x240 --aov normal -o "$w/bunny8_normal.png"
cpu "$w/bunny8.svo" --size 320x240 --aov cost -o "$w/bunny8_cost.png"
cpu "$w/bunny8.svo" --size 320x240 --aov leaf -o "$w/bunny8_leaf.png"
cpu "$w/bunny8.svo" --size 320x240 --hit cube --shadows opaque -o "$w/bunny8_cube.png"
cpu "$w/bunny9_solid.svo" --size 320x240 -o "$w/bunny9_solid_cpu.png"
cpu "$w/helmet8.svo" --size 320x240 -o "$w/helmet8_cpu.png"
cpu "$w/vase8.svo" --size 320x240 -o "$w/vase8_cpu.png"
cpu "$w/pool8.svo" --view water --size 320x200 -o "$w/pool8_water_cpu.png"
cpu "$w/bunny9_chunked.svo" --size 320x240 -o "$w/bunny9_chunked_cpu.png"
cpu "$w/pool8.svo" --view water --size 320x200 --reference "$bunny" --compare -o "$w/pool8_cmp.png"
gpu "$w/bunny8.svo" --size 320x240 -o "$w/bunny8_gpu.png"
gpu "$w/bunny8.svo" --size 320x240 --aov cost -o "$w/bunny8_gpu_cost.png"
gpu "$w/bunny8.svo" --size 320x240 --aov depth -o "$w/bunny8_gpu_depth.pfm"
gpu "$w/bunny8.svo" --size 320x240 --hit cube --shadows opaque -o "$w/bunny8_gpu_cube.png"
gpu "$w/bunny9_solid.svo" --size 320x240 -o "$w/bunny9_solid_gpu.png"
gpu "$w/vase8.svo" --size 320x240 -o "$w/vase8_gpu.png"
gpu "$w/pool8.svo" --view water --size 320x200 -o "$w/pool8_water_gpu.png"
gpu "$w/pool8.svo" --view water --size 320x200 --wide-view -o "$w/pool8_water_gpu_wide.png"
(cd "$w" && find . -type f ! -name '*.tmp*' | sort | xargs sha256sum)
