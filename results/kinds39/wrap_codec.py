"""phase_f32 through the whole lossy codec, wrapped (as made) against the oracle
unwrapped field (the generator's phase before wrapping, inside the head; the same
random phase outside), at the same absolute bound E = rel x 2 pi: an upper limit on
what any unwrapping inside volpack could save.

    PYTHONPATH=. python results/kinds39/wrap_codec.py DATA_DIR > results/kinds39/wrap_codec.txt
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
from wrap_ab import oracle  # noqa: E402  (wrap_ab's oracle; its own measure runs on import)

import volpack.api as api  # noqa: E402

a = np.load(Path(sys.argv[1]) / "phase_f32.npy")
un = oracle.astype(np.float32)
print(f"oracle unwrapped range {un.min():.1f}..{un.max():.1f} rad (the dipole's singularity)")
for rel in (1e-3, 1e-4):
    e = rel * float(a.max() - a.min())
    w, u = len(api.compress_array(a, max_error=e)), len(api.compress_array(un, max_error=e))
    print(
        f"rel {rel:g} (E {e:.4g} rad): wrapped {w:,} B, oracle unwrapped {u:,} B ({w / u:.4f}x fewer)"
    )
