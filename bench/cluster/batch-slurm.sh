#!/bin/bash
# Slurm array job: N slices of one millcomp batch, then a merge job that waits for all of them.
#
#   sbatch --array=0-7 bench/cluster/batch-slurm.sh            # 8 slices (0-based task ids)
#   sbatch --dependency=afterok:<array job id> --wrap \
#     "millcomp batch merge results/shard-* --out results/merged"
#
# Every slice runs the same plan (same scenario file or --doe string, same controllers): the plan's
# fingerprint is stored in each slice's plan.json and `batch merge` refuses slices of different plans.
# millcomp reads SLURM_ARRAY_TASK_ID / SLURM_ARRAY_TASK_COUNT (and SLURM_ARRAY_TASK_MIN) itself, so no
# --shard is needed. A re-queued or restarted task resumes: finished runs in results/shard-K/runs/ are
# not run again.
#SBATCH --job-name=millcomp-batch
#SBATCH --cpus-per-task=2
#SBATCH --time=01:00:00
#SBATCH --output=logs/millcomp-batch-%A_%a.out
set -euo pipefail

DESIGN="--design fractional --factors tilt_deg=20:40,depth_um=60:100,upfeed_um=8:12,wearland_um=4:12,stiffness_error_pct=-10:10,force_model_error_pct=5:25,noise_scale=0.5:2 --resolution 5 --seed 1"

export RAYON_NUM_THREADS="${SLURM_CPUS_PER_TASK:-2}"
millcomp batch \
  --doe "$DESIGN" \
  --controllers pid,mpc \
  --out "results/shard-${SLURM_ARRAY_TASK_ID}" \
  --json > "results/shard-${SLURM_ARRAY_TASK_ID}.json"
