#!/usr/bin/env bash
# Cost of the CFD stability chain: the fruit fly's longitudinal derivative table at 12 cells per mean chord
# (data/cases/fruitfly_cfd.toml: Re 100, 1.44 M cells, 400 steps per wingbeat; the hover from rest, the continued
# hover and the 6 perturbed runs, trim included as configured). Target: under one hour on a 2-core machine.
#
#   bash bench/cfd_stability_fruitfly.sh [BUILD_DIR] [OUT_DIR]
#
# Prints the study's plan, the progress of every run, its cost per stage (the table at the end of the report) and
# the whole-process wall time (and the peak memory where GNU time is installed). A killed benchmark resumes with the same command (the finished runs
# are kept in OUT_DIR/cfd_runs); delete OUT_DIR for a timing from scratch. Record the result, with the machine's
# ns per cell per step from the plan line, in docs/validation.md ("CFD stability chain").
set -euo pipefail
build=${1:-build}
out=${2:-out/bench_fruitfly_cfd}
here=$(cd "$(dirname "$0")/.." && pwd)
mkdir -p "$(dirname "$out")"
start=$(date +%s)
runner=()
[ -x /usr/bin/time ] && runner=(/usr/bin/time -v)  # peak memory where GNU time is installed (Debian package "time")
"${runner[@]}" "$build/apps/flapstab" derivatives "$here/data/cases/fruitfly_cfd.toml" -o "$out" 2> >(tee "$out.log" >&2) \
  || { echo "cfd_stability_fruitfly: flapstab failed (see $out.log)" >&2; exit 1; }
end=$(date +%s)
echo "cfd_stability_fruitfly: whole process $((end - start)) s; results in $out/derivatives.json, log in $out.log"
grep -E "Maximum resident set size" "$out.log" || true
