"""The long fit's residual per brick of a cell at the encoder's shortest reach (shared by
this folder's probes; the cells and quantised voxels are lossy19's)."""
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "lossy19"))
from cells import cells, quantised  # noqa: E402

from volpack.volume_codec import bounded_longfit as lf  # noqa: E402


def residuals(arg):
    """``name:rel,...`` -> (name, rel, field, codec, q, (r, plan, weights)) per brick."""
    for name, rel, a, e in cells(arg):
        for codec, q, _ in quantised(a, e):
            reach = lf.tried_reaches(np.ascontiguousarray(q, np.int64))[-1]
            top = int(np.iinfo(q.dtype).max)
            yield name, rel, a, codec, q, lf.residuals(q, reach, top, prune=True)
