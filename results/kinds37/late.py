"""Volumes made after mode 7 (mirrored halves) was final, to check it on data it was not
developed on (session 37; hydrogen_u8, which it was found on, is no longer held out).

    PYTHONPATH=. python results/kinds37/late.py DIR

nucleon_u8 (41^3, as Open SciVis's nucleon: two nucleons' densities on a grid centred
between them), silicium_u8 (98x34x34, as Open SciVis's silicium: a crystal's electron
density, atoms on a lattice symmetric about the box's centre), neghip_like_u8 (64^3: a
potential of 40 charges placed at random, no symmetry: mode 7 must not change its
bytes), orbital_192_u8 (192^3, a hydrogen-like density bigger than one brick: the limit
of a per-brick mode, it turned out: its density is symmetric under (x, y) -> (-x, -y)
only, a half turn, not a mirror), orbital_f32 (96^3 float32, the same density unrounded,
coded exactly) and, added after the first five were run, hydrogen_192_u8 (make.py's
hydrogen on 192^3: mirrored along z and y, in more than one brick).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np


def grid(shape, half):
    return np.meshgrid(*(np.linspace(-h, h, n) for n, h in zip(shape, half)), indexing="ij")


def u8(f):
    return np.rint(255 * (f - f.min()) / (f.max() - f.min())).astype(np.uint8)


def nucleon_u8(rng):
    z, y, x = grid((41, 41, 41), (3.0, 3.0, 3.0))
    d = sum(np.exp(-((z - s) ** 2 + y**2 + x**2) / 0.6) for s in (-0.9, 0.9))
    return u8(d)


def silicium_u8(rng):
    z, y, x = grid((98, 34, 34), (14.0, 5.0, 5.0))
    d = np.zeros(z.shape)
    for cz in np.arange(-13.5, 13.6, 2.7):
        for cy in (-2.5, 0.0, 2.5):
            for cx in (-2.5, 0.0, 2.5):
                d += np.exp(-((z - cz) ** 2 + (y - cy) ** 2 + (x - cx) ** 2) / 0.5)
    return u8(d)


def neghip_like_u8(rng):
    z, y, x = grid((64, 64, 64), (1.0, 1.0, 1.0))
    v = np.zeros(z.shape)
    for _ in range(40):
        c = rng.uniform(-0.8, 0.8, 3)
        q = rng.choice((-1.0, 1.0))
        v += q / (np.sqrt((z - c[0]) ** 2 + (y - c[1]) ** 2 + (x - c[2]) ** 2) + 0.08)
    return u8(np.clip(v, -40, 40))


def _orbital(n):
    z, y, x = grid((n, n, n), (20.0, 20.0, 20.0))
    r = np.sqrt(x**2 + y**2 + z**2) + 1e-9
    psi = r * np.exp(-r / 2) * (z / r) / 8 + 0.3 * r**2 * np.exp(-r / 3) * (x * y / r**2) / 81
    return psi**2


def orbital_192_u8(rng):
    p = _orbital(192)
    return np.rint(255 * p / p.max()).astype(np.uint8)


def orbital_f32(rng):
    return _orbital(96).astype(np.float32)


def hydrogen_192_u8(rng):
    """make.py's hydrogen density on 192^3: mirrored along z and y, more than one brick."""
    z, y, x = grid((192, 192, 192), (20.0, 20.0, 20.0))
    r = np.sqrt(x**2 + y**2 + z**2) + 1e-9
    psi = (
        r**2 * np.exp(-r / 3) * (3 * (z / r) ** 2 - 1) / 81.0
        + 0.4 * r * np.exp(-r / 2) * (x / r) / 8.0
    )
    p = psi**2
    return np.rint(255.0 * p / p.max()).astype(np.uint8)


MAKERS = [nucleon_u8, silicium_u8, neghip_like_u8, orbital_192_u8, orbital_f32, hydrogen_192_u8]


def main() -> None:
    d = Path(sys.argv[1])
    d.mkdir(parents=True, exist_ok=True)
    for i, f in enumerate(MAKERS):
        a = f(np.random.default_rng(3790 + i))
        np.save(d / f"{f.__name__}.npy", a)
        print(f.__name__, a.shape, a.dtype, flush=True)


if __name__ == "__main__":
    main()
