"""What the measuring scripts here share: a field and a relative bound from the command
line (plus ``extra`` (flag, type, default) options), volpack's path checked."""

import argparse
import sys

import numpy as np

import volpack


def field_and_bound(*extra):
    """(arguments, voxels, absolute bound) of ``FIELD.npy [--rel R] [extra...]``."""
    ap = argparse.ArgumentParser()
    ap.add_argument("field")
    ap.add_argument("--rel", type=float, default=1e-3)
    for flag, kind, default in extra:
        ap.add_argument(flag, type=kind, default=default)
    a = ap.parse_args()
    print(volpack.__file__, file=sys.stderr)
    x = np.load(a.field)
    return a, x, a.rel * float(x.max() - x.min())
