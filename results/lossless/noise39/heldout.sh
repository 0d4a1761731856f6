#!/bin/sh
# The held-out set, once: CODE=/work/main (the base library: main's volpack/ equals
# 651bd2c's) or CODE=. (this branch), OUT the jsonl written.
# Volumes: PYTHONPATH=. python results/kinds38/make.py D carp_u16 bunny_u16 mra_u16 and
# kinds39's make.py (main: results/kinds39/make.py) D us_u8 radar_u8 rock_u8.
CODE=$1; OUT=$2; D=${3:-/tmp/n39}
for f in k38/carp_u16 k38/bunny_u16 k38/mra_u16 k39/us_u8 k39/radar_u8 k39/rock_u8; do
  PYTHONPATH=$CODE /work/venv/bin/python -m volpack -q compare $D/$f.npy --peers --jpegxl-efforts 7,9,10 --json
done > $OUT
