"""The README's damaged-input table, header rows, as the command line now prints them
(session 28: the file named before a .vpk's structural error).

    python results/cli/user28/damaged_table.py      (from the repository root)
"""

import io
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from volpack import api
from volpack.format.container import Reader, Writer


def rewrite(src: bytes, **fields) -> bytes:
    """``src`` with header ``fields`` replaced (checksums recomputed), as
    tests/test_hardening.py makes them."""
    with Reader(src) as r:
        hdr, summ = dict(r.header), r.summary
        chunks = [(t, n, r.read(t, n), e.error) for (t, n), e in zip(r.keys(), r.entries)]
    hdr.update(fields)
    buf = io.BytesIO()
    w = Writer(buf, hdr)
    for t, n, p, e in chunks:
        w.write(t, n, p, e)
    w.close(summ)
    return buf.getvalue()


ROWS = [
    ("spacing", None),
    ("spacing", [1e308, 1, 1]),
    ("shape", {}),
    ("shape", [2**31, 2**31, 2**31]),
    ("codec", {"id": "wavelet", "wavelet": 53}),
]

stream = api.compress_array((np.arange(6 * 7 * 8) % 13).reshape(6, 7, 8).astype(np.uint8))
with tempfile.TemporaryDirectory() as d:
    for field, value in ROWS:
        bad = Path(d) / "bad.vpk"
        bad.write_bytes(rewrite(stream, **{field: value}))
        for cmd in (["decompress", "bad.vpk", "o.npy"], ["info", "bad.vpk"]):
            r = subprocess.run([sys.executable, "-m", "volpack", *cmd], cwd=d,
                               capture_output=True, text=True)  # fmt: skip
            print(f"{field}={value!r:38} {cmd[0]:10} exit {r.returncode}: {r.stderr.strip()}")
