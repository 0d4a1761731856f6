import sys, time
from pathlib import Path
import numpy as np
sys.path.insert(0, "scripts")
import datasets
from volpack import api
out = Path(sys.argv[2]); out.mkdir(parents=True, exist_ok=True)
print("field,rel,version,bytes,encode_s", flush=True)
for name in sys.argv[1].split(","):
    a = np.load(name) if name.endswith(".npy") else datasets.load(name)[0]
    name = Path(name).stem
    for rel in (1e-2, 1e-3, 1e-4, 1e-5):
        t = time.perf_counter()
        blob = api.compress_array(a, rel_error=rel, workers=1)
        dt = time.perf_counter() - t
        (out / f"{name}-{rel:g}-vA.vpk").write_bytes(blob)
        print(f"{name},{rel:g},A,{len(blob)},{dt:.1f}", flush=True)
