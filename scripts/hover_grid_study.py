#!/usr/bin/env python3
"""Grid study of a CFD hover: the same case on several grids, the mean loads of every wingbeat and the
extrapolated value with its grid-convergence index (Roache's GCI as set out by Celik et al. 2008, J Fluids Eng
130:078001: observed order from three grids of unequal refinement ratios, safety factor 1.25).

    python3 scripts/hover_grid_study.py CASE.toml OUT_DIR --grid 8:400 --grid 12:900 --grid 16:800 [--cycles 3]
        [--flapstab ./build/apps/flapstab] [--threads 2] [--launcher "mpiexec -n 4"]

Each --grid is CELLS_PER_CHORD:STEPS_PER_CYCLE. For each grid the case file is copied into OUT_DIR with
[aero.cfd] cells_per_chord, steps_per_cycle and cycles replaced and fields and surfaces switched off, and run
with `flapstab cfd` (an interrupted study is resumed: a grid whose run.json says "complete" is not run again,
one with checkpoints is restarted). Then it prints, per grid, the mean lift (-F_z), F_x, pitch moment M_y about
O and wing power over each wingbeat (from forces.csv), and for the last wingbeat of the three finest grids
the observed order, the extrapolated value and the GCI of the finest grid. Exit status 2 for bad arguments.
`--launcher` runs each grid's flow over MPI ranks (the command is put before `flapstab cfd`, e.g.
"mpiexec -n 4"; threads per rank: --threads); a run interrupted on one rank count resumes on another.
`--self-test` checks the extrapolation on values of a known order (the test suite runs it).
"""
import argparse
import csv
import json
import math
import os
import re
import shlex
import subprocess
import sys


def set_key(text, key, value):
    """Replaces `key = ...` in the [aero.cfd] table (the line must exist there)."""
    start = text.find("[aero.cfd]")
    if start < 0:
        print("hover_grid_study: the case has no [aero.cfd] table (expected a CFD case)", file=sys.stderr)
        sys.exit(2)
    end = text.find("\n[", start + 1)
    end = len(text) if end < 0 else end
    table = text[start:end]
    new, n = re.subn(rf"(?m)^{key}\s*=.*$", f"{key} = {value}", table)
    if n == 0:
        new = table.rstrip("\n") + f"\n{key} = {value}\n"
    return text[:start] + new + text[end:]


def cycle_means(path, steps_per_cycle):
    with open(path) as f:
        rows = list(csv.reader(line for line in f if not line.startswith("#")))
    head, data = rows[0], rows[1:]

    def cols(suffixes):
        return [i for i, c in enumerate(head) if any(c.endswith(s) for s in suffixes)]

    fz, fx = cols(["_Fz_p_N", "_Fz_v_N"]), cols(["_Fx_p_N", "_Fx_v_N"])
    my, pw = cols(["_My_p_N_m", "_My_v_N_m"]), cols(["_P_W"])
    out = []
    for k in range(len(data) // steps_per_cycle):
        block = data[k * steps_per_cycle:(k + 1) * steps_per_cycle]

        def mean(idx):
            return sum(sum(float(r[i]) for i in idx) for r in block) / len(block)

        out.append({"lift_mN": -1e3 * mean(fz), "Fx_mN": 1e3 * mean(fx), "My_mNm": 1e3 * mean(my),
                    "power_mW": 1e3 * mean(pw)})
    return out


def gci(n, f):
    """n: cells per chord fine to coarse, f: values. Observed order, extrapolation, GCI (fraction) of the finest."""
    r21, r32 = n[0] / n[1], n[1] / n[2]
    e21, e32 = f[1] - f[0], f[2] - f[1]
    if e21 == 0 or e32 == 0:
        return None
    s = 1.0 if e32 / e21 > 0 else -1.0
    p = 2.0
    for _ in range(200):
        q = math.log((r21 ** p - s) / (r32 ** p - s))
        p = abs(math.log(abs(e32 / e21)) + q) / math.log(r21)
    ext = (r21 ** p * f[0] - f[1]) / (r21 ** p - 1)
    return p, ext, 1.25 * abs((f[0] - f[1]) / f[0]) / (r21 ** p - 1), s > 0


def self_test():
    """The extrapolation of values f = 14 - 30 h^2 and f = 14 - 3 h^1.2 (h = 1 / cells per chord) on the study's
    grids (16.15, 12.0, 8.2 cells per chord: unequal ratios) recovers the order and the limit to 1e-9."""
    n = [16.15, 12.0, 8.2]
    for p_true, c in ((2.0, -30.0), (1.2, -3.0)):
        f = [14 + c * (1 / k) ** p_true for k in n]
        p, ext, index, monotone = gci(n, f)
        if not (abs(p - p_true) < 1e-9 and abs(ext - 14) < 1e-9 and monotone and index > 0):
            print(f"hover_grid_study: self-test failed: order {p} (exact {p_true}), limit {ext} (exact 14)")
            return 1
    print("hover_grid_study: self-test passed (orders 2 and 1.2 and the limit recovered)")
    return 0


def main():
    if sys.argv[1:] == ["--self-test"]:
        return self_test()
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("case")
    ap.add_argument("out")
    ap.add_argument("--grid", action="append", required=True, help="CELLS_PER_CHORD:STEPS_PER_CYCLE")
    ap.add_argument("--cycles", type=int, default=3)
    ap.add_argument("--flapstab", default="./build/apps/flapstab")
    ap.add_argument("--threads", type=int, default=0)
    ap.add_argument("--launcher", default="", help='a command before flapstab cfd, e.g. "mpiexec -n 4"')
    a = ap.parse_args()
    try:
        grids = sorted(((float(g.split(":")[0]), int(g.split(":")[1])) for g in a.grid), reverse=True)
    except (ValueError, IndexError):
        print("hover_grid_study: --grid takes CELLS_PER_CHORD:STEPS_PER_CYCLE, e.g. 8:400", file=sys.stderr)
        return 2
    if not os.path.isfile(a.case):
        print(f"hover_grid_study: no case file {a.case}", file=sys.stderr)
        return 2
    base = open(a.case).read()
    if "[aero.cfd]" not in base:
        print(f"hover_grid_study: {a.case} has no [aero.cfd] table (expected a CFD case)", file=sys.stderr)
        return 2
    os.makedirs(a.out, exist_ok=True)
    env = dict(os.environ)
    if a.threads > 0:
        env["OMP_NUM_THREADS"] = str(a.threads)
    results = []
    for cpc, spc in grids:
        name = f"c{cpc:g}_t{spc}"
        text = base
        for key, value in (("cells_per_chord", f"{cpc:g}"), ("steps_per_cycle", spc), ("cycles", a.cycles),
                           ("fields_per_cycle", 0), ("surfaces_per_cycle", 0), ("checkpoints_per_cycle", 1)):
            text = set_key(text, key, value)
        case = os.path.join(a.out, name + ".toml")
        run = os.path.join(a.out, name)
        status = None
        if os.path.isfile(os.path.join(run, "run.json")):
            status = json.load(open(os.path.join(run, "run.json"))).get("status")
        if status != "complete":
            if not os.path.isfile(case) or open(case).read() != text:
                with open(case + ".tmp", "w") as f:
                    f.write(text)
                os.replace(case + ".tmp", case)
            cmd = shlex.split(a.launcher) + [a.flapstab, "cfd", case, "-o", run]
            if os.path.isdir(os.path.join(run, "checkpoints")):
                cmd.append("--restart")
            print("running:", " ".join(cmd), flush=True)
            rc = subprocess.call(cmd, env=env)
            if rc != 0:
                print(f"hover_grid_study: {name} stopped with status {rc}", file=sys.stderr)
                return rc
        info = json.load(open(os.path.join(run, "run.json")))
        chord_cells = info.get("grid", {}).get("cells_per_mean_chord", cpc)
        results.append((float(chord_cells), name, cycle_means(os.path.join(run, "forces.csv"), spc)))
    for n, name, cyc in results:
        print(f"{name} ({n:.1f} cells per mean chord):")
        for k, c in enumerate(cyc):
            print(f"  wingbeat {k + 1}: lift {c['lift_mN']:.4f} mN, F_x {c['Fx_mN']:.4f} mN, "
                  f"M_y {c['My_mNm']:.5f} mN m, wing power {c['power_mW']:.2f} mW")
    if len(results) >= 3:
        fine = results[:3]
        for key in ("lift_mN", "Fx_mN", "power_mW"):
            g = gci([r[0] for r in fine], [r[2][-1][key] for r in fine])
            if g is None:
                print(f"{key}: two grids agree exactly; no order")
                continue
            p, ext, index, monotone = g
            print(f"last wingbeat, {key}: observed order {p:.2f}, extrapolated {ext:.4f}, GCI of the finest grid "
                  f"{100 * index:.1f} %{'' if monotone else ' (oscillatory convergence: not reliable)'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
