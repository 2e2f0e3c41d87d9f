#!/bin/bash
# Slurm array job: N slices of one millcomp batch, then a merge job that waits for all of them.
#
#   sbatch --array=0-7 bench/cluster/batch-slurm.sh                  # 8 slices of the default plan below
#   sbatch --array=0-3 bench/cluster/batch-slurm.sh \
#     --doe "--design full --factors tilt_deg=20:40,upfeed_um=8:12 --seed 1" --controllers pid,mpc
#   sbatch --array=0-3 bench/cluster/batch-slurm.sh --scenarios my_scenarios.csv --controllers pid-tuned,mpc
#   sbatch --dependency=afterok:<array job id> --wrap \
#     "millcomp batch merge results/shard-* --out results/merged"
#
# Arguments after the script are `millcomp batch` options (--doe "ARGS" or --scenarios FILE, --controllers,
# --columns); this script adds --out, --json and --cache $MILLCOMP_RESULTS/cache (unless the arguments
# give --cache): the slices share one commissioning cache, so a commissioning another slice already made
# is read, not made again (slices that need one at the same moment both make it, and write the same
# model). Without arguments it runs the default plan: the design
#   --design fractional --factors tilt_deg=20:40,depth_um=60:100,upfeed_um=8:12,wearland_um=4:12,
#     stiffness_error_pct=-10:10,force_model_error_pct=5:25,noise_scale=0.5:2 --resolution 5 --seed 1
# (a 2^(7-1) fractional factorial: 64 scenarios) with --controllers pid,mpc, 128 runs.
# Slice K writes $MILLCOMP_RESULTS/shard-K/ (its results and runs/) and $MILLCOMP_RESULTS/shard-K.json (its
# summary); MILLCOMP_RESULTS defaults to `results` in the submission directory. `millcomp` is taken from
# PATH (sbatch passes the submitting shell's environment on).
#
# Every slice runs the same plan (same scenario file or --doe string, same controllers): the plan's
# fingerprint is stored in each slice's plan.json and `batch merge` refuses slices of different plans.
# millcomp reads SLURM_ARRAY_TASK_ID / SLURM_ARRAY_TASK_COUNT (and SLURM_ARRAY_TASK_MIN) itself, so no
# --shard is needed. A re-queued or restarted task resumes: finished runs in results/shard-K/runs/ are
# not run again. `bench/cluster/slurm-selftest` runs this script on a one-node Slurm cluster it starts.
#SBATCH --job-name=millcomp-batch
#SBATCH --cpus-per-task=2
#SBATCH --time=01:00:00
#SBATCH --output=millcomp-batch-%A_%a.out
set -euo pipefail

if [ -z "${SLURM_ARRAY_TASK_ID:-}" ]; then
  echo "batch-slurm.sh: not an array task (SLURM_ARRAY_TASK_ID is unset): submit it with sbatch --array=0-(N-1)" >&2
  exit 2
fi

if [ "$#" -eq 0 ]; then
  set -- \
    --doe "--design fractional --factors tilt_deg=20:40,depth_um=60:100,upfeed_um=8:12,wearland_um=4:12,stiffness_error_pct=-10:10,force_model_error_pct=5:25,noise_scale=0.5:2 --resolution 5 --seed 1" \
    --controllers pid,mpc
fi

results="${MILLCOMP_RESULTS:-results}"
mkdir -p "$results"
export RAYON_NUM_THREADS="${SLURM_CPUS_PER_TASK:-2}"
cache=(--cache "$results/cache")
for a in "$@"; do
  case "$a" in --cache | --cache=*) cache=() ;; esac
done
millcomp batch "$@" "${cache[@]}" \
  --out "$results/shard-${SLURM_ARRAY_TASK_ID}" \
  --json > "$results/shard-${SLURM_ARRAY_TASK_ID}.json"
