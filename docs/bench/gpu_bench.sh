#!/usr/bin/env bash
# GPU benchmark of `svo-view --headless` on the Stanford bunny (docs/gpu-benchmarks.md):
# depths 8 and 10, cube and contour, primary rays only, shaded with one light
# and product shadows, and a glass bunny (reflection + refraction + shadows through glass);
# each also with --full-shader (nothing left out) to measure what the scene's shader variant
# saves, and once per depth against the CPU reference (image difference and CPU time; 3
# frames).
#
# Usage: docs/bench/gpu_bench.sh BIN_DIR BUNNY.obj [FRAMES]
#   BIN_DIR holds release builds of svo-bake and svo-view. The .svo files are baked into a
#   temporary folder first. Prints each run's report.
# On a container with an NVIDIA driver but no libvulkan or with a GLX-only Vulkan ICD, point
# the loader at the EGL library: a JSON with "library_path": "libEGL_nvidia.so.0" in
# VK_DRIVER_FILES, and libvulkan.so.1 on LD_LIBRARY_PATH (see docs/gpu-benchmarks.md).
set -euo pipefail
bin=$1; mesh=$2; frames=${3:-50}
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-$(mktemp -d)}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# The glass bunny: the same triangles with a glass material (10% mirror, 80% transmission,
# IOR 1.5).
printf 'newmtl glass\nKd 0.85 0.92 1.0\nKs 0.1 0.1 0.1\nNi 1.5\nd 0.2\nillum 7\n' > "$work/glass.mtl"
{ printf 'mtllib glass.mtl\nusemtl glass\n'; grep -v '^mtllib\|^usemtl' "$mesh"; } > "$work/glass.obj"
for d in 8 10; do
  "$bin/svo-bake" "$mesh" --depth $d -o "$work/bunny$d.svo" -q
  "$bin/svo-bake" "$work/glass.obj" --depth $d -o "$work/glass$d.svo" -q
done
view() { echo "=== $*"; "$bin/svo-view" "$@" --headless --size 1920x1080 --bench "$frames" | grep -v '^wrote'; }
# The comparisons with the CPU tracer: 3 frames on each side (the CPU's frames take 0.1-1 s).
check() { echo "=== $* --vs-cpu"; "$bin/svo-view" "$@" --headless --size 1920x1080 --vs-cpu --bench 3 | grep -v '^wrote'; }
for d in 8 10; do
  f=$work/bunny$d.svo; g=$work/glass$d.svo
  check "$f"
  check "$g"
  for hit in cube contour; do
    view "$f" --hit $hit --bounces 0 --shadows none
    view "$f" --hit $hit --bounces 0 --shadows none --full-shader
    view "$f" --hit $hit
    view "$f" --hit $hit --full-shader
    view "$g" --hit $hit
  done
done
