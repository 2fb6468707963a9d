#!/usr/bin/env bash
# Bake a mesh on a Slurm cluster: plan the parts here, bake them as an array job (one task a
# part, requeued if its node fails or it is requeued), and merge them in a job that waits for
# every part. Every path must be on a filesystem the compute nodes share.
#
#   scripts/slurm/svo-bake-slurm.sh MESH DEPTH PARTS OUT.svo [sbatch options ...]
#
# e.g. scripts/slurm/svo-bake-slurm.sh /shared/scan.ply 16 64 /shared/scan.svo -p batch -c 8
#
# SVO_BAKE names the svo-bake binary (default: svo-bake on the PATH). The plan is written
# beside OUT.svo (OUT.svoplan) with each part's triangles (OUT.IIIII.svobin, so a task loads
# its own triangles, not the mesh), the parts beside the plan (OUT.IIIII.svopart); remove
# them once the merge is done. Prints the array job's and the merge job's ids, and with
# SVO_WAIT=1 waits for the merge and exits with its status.
set -euo pipefail

if [ $# -lt 4 ]; then
    sed -n '2,14p' "$0" | sed 's/^# \{0,1\}//'
    exit 2
fi
mesh=$1 depth=$2 parts=$3 out=$4
shift 4
bake=${SVO_BAKE:-svo-bake}
plan="${out%.svo}.svoplan"

"$bake" plan "$mesh" --depth "$depth" --parts "$parts" --bins -o "$plan" >&2

# One task a part; each reads the plan and its triangles and writes its own part file, so a
# task run twice (requeued) writes the same bytes.
array=$(sbatch --parsable --requeue --job-name=svo-part --array="0-$((parts - 1))" \
    --output="${out%.svo}.part-%a.log" "$@" \
    --wrap="exec '$bake' part '$plan' \"\$SLURM_ARRAY_TASK_ID\"")
array=${array%%;*}

wait_flag=()
if [ "${SVO_WAIT:-0}" = 1 ]; then
    wait_flag=(--wait)
fi
echo "parts: job $array ($parts tasks)"
merge=$(sbatch --parsable --job-name=svo-merge --dependency="afterok:$array" \
    --kill-on-invalid-dep=yes --output="${out%.svo}.merge.log" "${wait_flag[@]}" "$@" \
    --wrap="exec '$bake' merge '$plan' -o '$out'")
echo "merge: job ${merge%%;*}"
