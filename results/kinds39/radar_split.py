"""Held-out radar_u8 (looked at after its run): would coding its no-data mask (255, 70 %
of the voxels) apart from the echo codes pay? One 20 x 128 x 128 brick, the lossless
codec: as it is, by tool; the mask alone plus the codes with 255 set to 0.

    PYTHONPATH=. python results/kinds39/radar_split.py DATA_DIR > results/kinds39/radar_split.txt
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from volpack.volume_codec.lossless import LosslessCodec

a = np.load(Path(sys.argv[1]) / "radar_u8.npy")
b = np.ascontiguousarray(a[:, :128, :128])
print(
    f"radar_u8: no data (255) {np.mean(a == 255):.1%}, no echo (0) {np.mean(a == 0):.1%}, echo codes {np.mean((a > 0) & (a < 255)):.1%}"
)
for t in ("auto", "predict", "wavelet"):
    print(f"  brick 20x128x128, tools={t}: {len(LosslessCodec(tools=t).encode(b)):,} B")
m = b == 255
nm = len(LosslessCodec().encode(m.astype(np.uint8)))
nv = len(LosslessCodec().encode(np.where(m, 0, b).astype(np.uint8)))
print(f"  split: the mask {nm:,} B + the codes with 255 -> 0 {nv:,} B = {nm + nv:,} B")
