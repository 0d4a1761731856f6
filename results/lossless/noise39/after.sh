#!/bin/sh
# With this branch's code, once: the held-out set without peers (the peers' files are
# those of heldout_base.jsonl: the same inputs), lobster with every peer, the
# same-bytes check of two corpus volumes (base code and this branch), the decode A/B.
D=/tmp/n39; R=results/lossless/noise39
for f in k38/carp_u16 k38/bunny_u16 k38/mra_u16 k39/us_u8 k39/radar_u8 k39/rock_u8; do
  PYTHONPATH=. /work/venv/bin/python -m volpack -q compare $D/$f.npy --json
done > $R/heldout_after.jsonl
PYTHONPATH=. /work/venv/bin/python -m volpack -q compare $D/k38/lobster_u8.npy --peers --jpegxl-efforts 7,9,10 --json > $R/lobster_after.json
VOLPACK_CACHE_DIR=/work/cache/noise39-base PYTHONPATH=/work/main /work/venv/bin/python $R/samebytes.py ct_head mri_ch2better > $R/samebytes_base.txt
PYTHONPATH=. /work/venv/bin/python $R/samebytes.py ct_head mri_ch2better > $R/samebytes_after.txt
