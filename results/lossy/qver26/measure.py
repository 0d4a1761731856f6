"""qver26 step 1: file size of the default effort with the quantised voxels' lossless
version patched (6 = main, 7, 8), one worker; the files are kept in OUT for info/decode."""
import sys, time
from pathlib import Path

import numpy as np

sys.path.insert(0, "scripts")
import datasets  # noqa: E402

from volpack import api  # noqa: E402
from volpack.volume_codec import lossy  # noqa: E402

fields = sys.argv[1].split(",")
versions = [int(v) for v in sys.argv[2].split(",")]
out = Path(sys.argv[3])
out.mkdir(parents=True, exist_ok=True)
rels = (1e-2, 1e-3, 1e-4, 1e-5)
print("field,rel,version,bytes,encode_s", flush=True)
for name in fields:
    if name.endswith(".npy"):
        a = np.load(name)
        name = Path(name).stem
    else:
        a = datasets.load(name)[0]
    for rel in rels:
        for v in versions:
            lossy.QUANTISED_VERSION = v
            t = time.perf_counter()
            blob = api.compress_array(a, rel_error=rel, workers=1)
            dt = time.perf_counter() - t
            (out / f"{name}-{rel:g}-v{v}.vpk").write_bytes(blob)
            print(f"{name},{rel:g},{v},{len(blob)},{dt:.1f}", flush=True)
