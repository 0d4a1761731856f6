#!/bin/bash
# Run every command of the README's tour (## A tour of the command line) as printed, in
# order, in a fresh folder, on files made from ~/.cache/volpack/data; one line per
# command with its exit status, then the last lines it printed.
#   results/cli/user27/tour.sh WORKTREE FOLDER
set -u
tree=$(realpath "$1"); dir=$2; D=~/.cache/volpack/data
mkdir -p "$dir" && cd "$dir" || exit 1
volpack() { PYTHONDONTWRITEBYTECODE=1 PYTHONPATH="$tree" nice -n 10 /work/venv/bin/python -m volpack "$@"; }
export -f volpack; export tree
# inputs under the tour's names: the head CT (InVesalius project) as ct.*, an MRI as head.nii.gz
volpack -q convert $D/Cranium.inv3 ct.nii.gz && volpack -q convert ct.nii.gz ct.nrrd \
  && volpack -q convert ct.nii.gz ct.npy && cp ct.npy vol.npy
volpack -q convert ct.nii.gz scan.raw && python3 - <<'PY'
import numpy as np  # the README's scan.raw is big-endian
np.fromfile("scan.raw", "<i2").astype(">i2").tofile("scan.raw")
PY
ln -sf $D/KmeansTest_T1UCharRaw.nii.gz head.nii.gz
ln -sf $D/ncarg_nc4uvt.nc era5.nc && ln -sf $D/example4d.nii.gz run.nii.gz
gunzip -c $D/liver.inr.gz > liver.inr
volpack -q convert $D/taylor_green_pressure.npy sim.h5:/T
volpack -q convert $D/taylor_green_u.npy map.nii.gz
volpack -q convert $D/brainsmall.den big.h5:/density
volpack -q compress ct.nii.gz t.vpk --max-error 3 && volpack -q decompress t.vpk ct_sz3.nii.gz && rm t.vpk
mkdir -p scans/a out && cp $D/JHU-WhiteMatter-labels-2mm.nii.gz scans/ && cp $D/KmeansTest_T1RawSkullStrip.nii.gz scans/a/
PYTHONPATH="$tree:$tree/tests" /work/venv/bin/python - <<'PY'
import meshio
from tetra_meshes import grid_mesh
m = grid_mesh(6)
meshio.write("mesh.vtu", meshio.Mesh(m.points, [("tetra", m.tets)],
             point_data={"temperature": m.points[:, 0] * 10 + m.points[:, 1]}))
PY
awk '/^## A tour of the command line/{f=1} f&&/^```$/{n++; if(n==2) exit; next} f&&n==1' \
  "$tree/README.md" | grep -v '^$' > tour.txt
n=0
while IFS= read -r line; do
  n=$((n+1)); cmd="${line%%  #*}"
  start=$(date +%s.%N)
  timeout 1200 bash -c "set -o pipefail; $cmd" < /dev/null > out_$n.txt 2>&1
  rc=$?
  printf '[%d] rc=%d %.0f s  %s\n' $n $rc "$(echo "$(date +%s.%N) - $start" | bc)" "$cmd"
  grep -v "compiling kernels" out_$n.txt | tail -2 | cut -c1-200 | sed 's/^/      /'
done < tour.txt
volpack serve --stop
