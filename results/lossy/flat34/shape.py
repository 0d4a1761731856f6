"""Brick shapes for a 1800x3600 field (synthetic random fields of ab.py): (1, 2048, 2048)
against (1, 1024, 4096) and the whole field, bytes at 1e-2 and 1e-4 of the range.

Run: PYTHONPATH=. python results/lossy/flat34/shape.py
"""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from trial import grf  # noqa: E402

from volpack import api  # noqa: E402

SHAPES = ((1, 2048, 2048), (1, 1024, 4096), (1, 1800, 3600))
for label, a in (
    ("s4", grf((1800, 3600), -4.0, 3)[None]),
    ("s3", grf((1800, 3600), -3.0, 2)[None]),
):
    for rel in (1e-2, 1e-4):
        sizes = [
            (br, len(api.compress_array(a, rel_error=rel, workers=2, brick=br))) for br in SHAPES
        ]
        print(label, rel, sizes, flush=True)
