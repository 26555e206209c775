#!/bin/bash
# One CFD run (flapstab cfd) over the MPI ranks of a SLURM job: the grid split into z slabs, one per task, and the
# run's files written by rank 0 into OUT, as one process writes them (docs/user-guide.md, "One flow over several MPI
# ranks"). A run cut short by the time limit continues from its newest checkpoint on any number of tasks:
#
#   sbatch scripts/slurm_cfd.sh data/cases/hawkmoth_cfd.toml out/hawkmoth_cfd
#   sbatch --ntasks=16 scripts/slurm_cfd.sh data/cases/hawkmoth_cfd.toml out/hawkmoth_cfd --restart
#
# FLAPSTAB_COMMAND=fly runs a free flight coupled to the solver instead (flapstab fly with model = "cfd": every flow
# of it over the job's tasks; the same command continues a flight cut short, a larger --wingbeats extends it):
#
#   sbatch --export=ALL,FLAPSTAB_COMMAND=fly scripts/slurm_cfd.sh data/examples/fly_hawkmoth_cfd.toml out/fly
#
# Arguments after OUT go to flapstab cfd (--restart, --cycles N, --steps N, --dry-run) or flapstab fly (--wingbeats N,
# --dof SET). Each slab needs at least 5
# z planes (the run says how many tasks the grid takes when there are too many). Each task uses --cpus-per-task
# OpenMP threads. Open MPI's mpirun takes the job's tasks from SLURM and tells every process the job's size, by
# which flapstab cfd knows it is one rank of a run; with srun instead, use `srun --mpi=pmi2` (PMI_SIZE). Outside
# SLURM the script starts 2 ranks (FLAPSTAB_MPIRUN_FLAGS: extra mpirun options, e.g. --allow-run-as-root).
#SBATCH --job-name=flapstab-cfd
#SBATCH --ntasks=8
#SBATCH --cpus-per-task=2
#SBATCH --mem-per-cpu=2G
#SBATCH --time=12:00:00
set -euo pipefail
usage="usage: [FLAPSTAB_COMMAND=cfd|fly] sbatch slurm_cfd.sh CASE.toml OUT [flapstab cfd or fly options]"
case_file=${1:?$usage}
out=${2:?$usage}
shift 2
command=${FLAPSTAB_COMMAND:-cfd}
if [ "$command" != cfd ] && [ "$command" != fly ]; then
  echo "slurm_cfd.sh: FLAPSTAB_COMMAND is '$command'; expected cfd or fly" >&2
  echo "$usage" >&2
  exit 2
fi
export OMP_NUM_THREADS=${SLURM_CPUS_PER_TASK:-1}
flapstab=${FLAPSTAB:-flapstab}
# shellcheck disable=SC2086  # the flags are words
exec mpirun ${FLAPSTAB_MPIRUN_FLAGS:-} -n "${SLURM_NTASKS:-2}" --bind-to none \
  "$flapstab" "$command" "$case_file" -o "$out" "$@"
