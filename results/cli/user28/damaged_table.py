# ruff: noqa: E402
"""The README's damaged-input table, header rows, as the command line now prints them
(session 28: the file named before a .vpk's structural error).

    PYTHONPATH=. python results/cli/user28/damaged_table.py      (from the repository root)
"""

import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, "tests")
from test_hardening import _rewrite as rewrite  # header fields replaced, checksums redone

from volpack import api

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
