#!/bin/sh
# Every volume of make.py through `volpack compare --peers` (default effort), JSON per run.
# Usage: sh results/unseen28/run.sh DATADIR   (DATADIR holds make.py's .npy files)
set -e
d=${1:-.}
here=$(dirname "$0")
mkdir -p "$here/lossless" "$here/lossy"
for f in ct_x16 ct_u16off ct_i32 ct_f32int ct_f64int mri_even mri_T mri_thin bs_noise dip_be mri_scaled; do
  volpack -q compare "$d/$f.npy" --peers --jpegxl-efforts 7,9,10 --json > "$here/lossless/$f.json"
done
for f in turb orbital mixing; do
  for e in 1e-2 1e-3 1e-4 1e-5; do
    volpack -q compare "$d/$f.npy" --rel-error $e --peers --json > "$here/lossy/$f-$e.json"
  done
done
