"""Which coding the encoder keeps per brick of a cell: the flag byte, and for the long
fit (flag bit 3) its residual type (0-2: the lossless codec, 3: context coded, step 22;
4: static, step 23, since lossy20).

    python results/lossy/lossy19/kept_codings.py cam_u:1e-3,tgv_vorticity:1e-3
"""
import sys
from collections import Counter

from cells import cells

from volpack import api
from volpack.format.container import Reader
from volpack.format.sections import take_section

NAMES = {3: "context coded", 4: "static"}
for name, rel, a, e in cells(sys.argv[1]):
    blob = api.compress_array(a, max_error=e)
    kinds = Counter()
    with Reader(blob) as r:
        for _, _, p in r:
            kind = f"flags {p[0]}"
            if p[0] & 8 and not p[0] & (4 | 16 | 64 | 128):
                inner = take_section(memoryview(p), 1, "inner")[0]
                kind += " long fit, residual " + NAMES.get(inner[4], "lossless")
            kinds[kind] += 1
    print(f"{name} {rel} {len(blob)} B: " + ", ".join(f"{k} x{n}" for k, n in kinds.items()), flush=True)
