"""The coding order an entropy coder walks: which coefficient each position codes, the
subtree it roots (for zero-subtree flags), its parent and in-band neighbours (contexts) and
its subband class. :mod:`volpack.wavelet.sigmap` builds scans over a wavelet brick; the
coders here only walk them, so they know nothing of wavelets."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

N_CLASSES = 25  # subband classes a scan may name (context sets of the coders)


class Scan(NamedTuple):
    perm: np.ndarray  # int32 (N,): flat coefficient index coded at each scan position
    end: np.ndarray  # int32 (N,): end (exclusive) of the subtree rooted at each position
    parent: np.ndarray  # int32 (N,): scan position of the parent, -1 for roots
    cls: np.ndarray  # uint8 (N,): subband class, 0..N_CLASSES-1
    nbr: (
        np.ndarray
    )  # int32 (N, 3): scan positions of the z-1, y-1, x-1 neighbours in the band, -1 if none
