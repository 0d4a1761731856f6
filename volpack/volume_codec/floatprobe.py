"""A float brick's tools measured on a central block of it first (session 31, flen31).

The default lossless encoder tries every float tool on every brick; most cannot win.
A :class:`Probe` codes a central block of the brick (half its slices, a quarter of its
rows, every column: an eighth of the voxels) with the four Lorenzo predictors, and, on
request, with another tool: the Lorenzo predictors coded in full are those within
``LORENZO_MARGIN`` of the block's best, and a tool's payload on the brick is estimated as
the full Lorenzo stream's times the tool's share of Lorenzo's bytes on the block (a
share, not a size: the block's edges and its models' learning cost every tool alike).
"""

from __future__ import annotations

import numpy as np

from . import floatpredict as fp

LORENZO_MARGIN = 0.01  # the predictors 1 % or less behind the block's best are coded in full
MIN_VOXELS = 1 << 14  # a smaller brick is coded as before (the block says little)


class Probe:
    """The block of ``brick`` and its Lorenzo streams' sizes; see the module."""

    def __init__(self, brick: np.ndarray) -> None:
        nz, ny, _ = brick.shape
        bz = nz // 2 if nz >= 16 else nz
        by = ny // 4 if ny >= 32 else (ny // 2 if ny >= 16 else ny)
        z0, y0 = (nz - bz) // 2, (ny - by) // 2
        self.block = brick[z0 : z0 + bz, y0 : y0 + by]
        self.sizes = {
            p: len(fp.encode_lorenzo(self.block, p))
            for p in fp.usable(brick.dtype)
            if bz > 1 or p in (fp.LORENZO2, fp.LORENZO2F)
        }
        self.predictor = min(self.sizes, key=self.sizes.get)

    @staticmethod
    def make(brick: np.ndarray) -> Probe | None:
        """A probe of ``brick``, or None where the block would be over a quarter of it."""
        nz, ny, _ = brick.shape
        if brick.size < MIN_VOXELS or (nz < 16 and ny < 16):
            return None
        return Probe(brick)

    def lorenzo(self) -> list[int]:
        """The Lorenzo predictors to code in full."""
        best = self.sizes[self.predictor]
        return [p for p, n in self.sizes.items() if n <= (1 + LORENZO_MARGIN) * best]

    def estimate(self, nbytes: int, coded: int) -> float:
        """A tool's payload on the brick, from ``nbytes`` on the block, where the Lorenzo
        stream coded in full has ``coded`` bytes (with its predictor byte)."""
        return coded * nbytes / self.sizes[self.predictor]
