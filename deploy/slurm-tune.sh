#!/bin/bash
# A chessarm gain sweep as a Slurm job array: each array task runs one contiguous shard of the
# candidates (`--shard-from-env` reads SLURM_ARRAY_TASK_ID, SLURM_ARRAY_TASK_MIN and
# SLURM_ARRAY_TASK_COUNT) into its own folder. Submit with `sbatch deploy/slurm-tune.sh`; when
# every task is done, merge in task order, which gives the single-machine tune.csv byte for byte:
#
#   for i in $(seq 0 7); do cat sweep/shard-$i/tune.csv; done > sweep/tune.csv
#
# CHESSARM (the binary, default `chessarm` on PATH), CHESSARM_SWEEP (the sweep's flags) and
# CHESSARM_OUT (default `sweep`) may be set in the environment.
#SBATCH --job-name=chessarm-tune
#SBATCH --array=0-7
#SBATCH --cpus-per-task=2
#SBATCH --output=chessarm-tune-%A_%a.log
set -euo pipefail
CHESSARM="${CHESSARM:-chessarm}"
SWEEP="${CHESSARM_SWEEP:---kp 25..2000:100 --kd 2..80:100}"
OUT="${CHESSARM_OUT:-sweep}"
# shellcheck disable=SC2086 # the sweep's flags are words
"$CHESSARM" tune $SWEEP --threads "${SLURM_CPUS_PER_TASK:-2}" --shard-from-env \
  --out "$OUT/shard-$SLURM_ARRAY_TASK_ID" --json
