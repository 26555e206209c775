#!/bin/bash
# A derivative campaign on a SLURM cluster: the runs of one CFD derivative table (or stability / analyze) shared
# between the tasks of one job. Every task runs the same command into the same output directory; the tasks claim
# runs through lock files in OUT/cfd_runs (docs/user-guide.md, "Campaigns"), so OUT must be on a file system the
# nodes share and that supports flock (NFS; Lustre mounted with -o flock).
#
#   sbatch scripts/slurm_campaign.sh data/cases/fruitfly_cfd.toml out/fruitfly_cfd
#
# 6 tasks suit a one-plane table (6 runs: [derivatives] columns = "longitudinal"), 12 the whole table. Each task
# uses --cpus-per-task threads for its solver. The hover from rest is made by one task while the others wait; a
# task that is killed (time limit) leaves its run to be resumed by a rerun of this script.
#
# Flows too large for one task: RANKS_PER_FLOW=K runs the tasks as one MPI job (mpirun) in groups of K ranks, each
# flow over its group's K ranks (the grid in z slabs; --ntasks a multiple of K), the groups sharing the runs:
#
#   RANKS_PER_FLOW=4 sbatch --ntasks=8 scripts/slurm_campaign.sh data/cases/hawkmoth_cfd.toml out/hawkmoth_cfd
#
# Outside SLURM that starts 2 ranks (FLAPSTAB_MPIRUN_FLAGS: extra mpirun options, e.g. --allow-run-as-root).
#SBATCH --job-name=flapstab-campaign
#SBATCH --ntasks=6
#SBATCH --cpus-per-task=4
#SBATCH --mem-per-cpu=2G
#SBATCH --time=12:00:00
set -euo pipefail
case_file=${1:?usage: sbatch slurm_campaign.sh CASE.toml OUT [command: derivatives | stability | analyze]}
out=${2:?usage: sbatch slurm_campaign.sh CASE.toml OUT [command]}
command=${3:-derivatives}
export OMP_NUM_THREADS=${SLURM_CPUS_PER_TASK:-1}
flapstab=${FLAPSTAB:-flapstab}
# Each task's progress in its own log; the results are written by every task (the same files, atomically).
mkdir -p "$out"
if [ -n "${RANKS_PER_FLOW:-}" ]; then
  # Each group's rank 0 logs (the other ranks' logs stay empty) and writes the results.
  # shellcheck disable=SC2086  # the flags are words
  exec mpirun ${FLAPSTAB_MPIRUN_FLAGS:-} -n "${SLURM_NTASKS:-2}" --bind-to none bash -c \
    "'$flapstab' $command '$case_file' -o '$out' --ranks-per-flow $RANKS_PER_FLOW \
     > '$out/campaign_rank'\${OMPI_COMM_WORLD_RANK:-\${PMI_RANK:-0}}.log 2>&1"
fi
# srun gives each task its own cores, which the solver's threads keep to (under mpirun --bind-to none above they
# would all start on the first core).
export OMP_PROC_BIND=close OMP_PLACES=cores
srun --kill-on-bad-exit=0 bash -c \
  "'$flapstab' $command '$case_file' -o '$out' > '$out/campaign_task'\${SLURM_PROCID}.log 2>&1"
