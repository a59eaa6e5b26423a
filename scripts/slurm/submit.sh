#!/usr/bin/env bash
# Submits a sharded run and its merge in one go:
#   RUN_DIR=/shared/runs/basin133 bash scripts/slurm/submit.sh 16 basin-array.sbatch [sbatch options...]
# prints the array job id and the merge job id. The merge starts only when every array
# task ended successfully (afterok); if some failed, resubmit their ids with
#   sbatch --array=<ids> scripts/slurm/<array script>
# and then the merge with --dependency=afterok:<new job id>.
set -euo pipefail
n=${1:?number of shards}
script=${2:?array script, e.g. basin-array.sbatch}
shift 2
here=$(cd "$(dirname "$0")" && pwd)
array=$(sbatch --parsable --array=0-$((n - 1)) "$@" "$here/$script")
array=${array%%;*}
merge=$(sbatch --parsable --dependency=afterok:"$array" "$@" "$here/merge.sbatch")
echo "array job $array ($n shards), merge job ${merge%%;*}"
