"""The encoder's files unchanged: each item's default-effort .vpk made again by the tree
on PYTHONPATH, against the one the base tree made (pfd32's capture.py's cache, by
PFD32_DATA). Prints one line an item: same / DIFFERENT, sizes.

    PFD32_DATA=/tmp/ldec36/data PYTHONPATH=. python results/lossless/ldec36/same_bytes.py ct_head ...
"""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "pfd32"))
import capture  # noqa: E402

from volpack import api  # noqa: E402

for item in sys.argv[1:]:
    a, e = capture.array(item)
    assert e is None
    new = bytes(api.compress_array(a))
    old = capture.blob(item)
    print(item, "same" if new == old else "DIFFERENT", len(old), len(new), flush=True)
