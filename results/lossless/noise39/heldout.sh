#!/bin/sh
# The held-out set, once: CODE the library's directory (/work/main: the base library,
# main's volpack/ equals 651bd2c's; or this worktree), OUT the jsonl written, then any
# further compare options (--peers --jpegxl-efforts 7,9,10 for the peers).
# Run from /tmp: python -m puts the working directory first on sys.path, so a run from
# the worktree would import the worktree's volpack whatever PYTHONPATH says (it did, in
# heldout_peers.jsonl: its volpack lines are from mid-edit code; its peers' are valid).
# Volumes: PYTHONPATH=. python results/kinds38/make.py D carp_u16 bunny_u16 mra_u16 and
# kinds39's make.py (main: results/kinds39/make.py) D us_u8 radar_u8 rock_u8.
CODE=$1; OUT=$2; shift 2; D=/tmp/n39
cd /tmp || exit 1
for f in k38/carp_u16 k38/bunny_u16 k38/mra_u16 k39/us_u8 k39/radar_u8 k39/rock_u8 k38/lobster_u8; do
  PYTHONPATH=$CODE /work/venv/bin/python -m volpack -q compare $D/$f.npy --json "$@"
done > $OUT
