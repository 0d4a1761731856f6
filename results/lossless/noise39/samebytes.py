"""Bytes of corpus volumes under the default lossless codec: size, sha256 and the
bricks' payloads (run once with the base code, PYTHONPATH=/work/main, once with this
branch's, and compare).

    PYTHONPATH=. python results/lossless/noise39/samebytes.py ct_head mri_ch2better
"""

from __future__ import annotations

import hashlib
import sys

sys.path.append(".")  # (after PYTHONPATH: the code it names is what runs)
from scripts import datasets  # noqa: E402
from volpack import api  # noqa: E402
from volpack.format.container import Reader  # noqa: E402

for name in sys.argv[1:]:
    a = datasets.load(name)[0]
    b = api.compress_array(a)
    with Reader(b) as r:
        tools = r.summary.get("tools", {})
    print(
        f"{name} {a.shape} {a.dtype}: {len(b)} B sha256 {hashlib.sha256(b).hexdigest()[:16]} {tools}",
        flush=True,
    )
