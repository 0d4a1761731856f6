#!/bin/sh
# volpack -q compare F.npy --rel-error E --peers --json at 1e-2..1e-5 for each field named
# (results/lossy/rough28/F.npy); JSON to results/lossy/rough28/json/F_E.json.
cd "$(dirname "$0")/../../.." || exit 1
for f in "$@"; do
  for e in 1e-2 1e-3 1e-4 1e-5; do
    PYTHONDONTWRITEBYTECODE=1 nice -n 10 /work/venv/bin/python -m volpack -q compare \
      results/lossy/rough28/$f.npy --rel-error $e --peers --json \
      > results/lossy/rough28/json/${f}_$e.json
  done
done
