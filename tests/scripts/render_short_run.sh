#!/usr/bin/env bash
# Two steps of the shipped hawkmoth CFD case (its initial outputs hold fields and surfaces), then the standard
# ParaView views; fails unless the three images exist and are not empty.
set -euo pipefail
flapstab="$1" pvpython="$2" source="$3" dir="$4"
rm -rf "$dir"
"$flapstab" cfd "$source/data/cases/hawkmoth_cfd.toml" -o "$dir" --steps 2 -q
"$pvpython" "$source/scripts/paraview_views.py" "$dir" -o "$dir/views" --size 640 400
for f in q_isosurface surface_pressure vorticity_slice; do
  test -s "$dir/views/$f.png" || { echo "missing $dir/views/$f.png"; exit 1; }
done
