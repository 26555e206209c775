#!/usr/bin/env bash
# Strong scaling of the decomposed Navier-Stokes step on this machine: the same steps (n^3 Taylor-Green, or the
# flapping hawkmoth with `hawkmoth` for n) on one rank with 1 and with 2 OpenMP threads, and on 2 ranks of 1 thread
# each, alternated `rounds` times (the machines are shared and noisy: compare the medians).
# Usage: bench/mpi_scaling.sh [build dir] [n | hawkmoth] [steps] [rounds]
set -euo pipefail
build=${1:-build}; n=${2:-96}; steps=${3:-20}; rounds=${4:-3}
bin="$build/bench/bench_mpi_scaling"
[ -x "$bin" ] || { echo "mpi_scaling: $bin not found (configure with -DFLAPSTAB_BUILD_BENCH=ON and build it)" >&2; exit 1; }
run() { OMP_NUM_THREADS=$1 OMP_WAIT_POLICY=passive mpiexec --allow-run-as-root -n "$2" --bind-to "$3" "$bin" "$n" "$steps"; }
for r in $(seq "$rounds"); do
  echo "# round $r"
  run 1 1 core
  run 2 1 none
  run 1 2 core
done
