"""Float fields made by a solver here, for the lossy benchmark's CFD entries.

The Taylor-Green vortex is the standard test case of CFD codes (the high-order workshop's
case at Re 1600): ``u = sin x cos y cos z``, ``v = -cos x sin y cos z``, ``w = 0`` in a
periodic box of side 2 pi, which rolls up into small-scale turbulence by t ~ 9. This is a
pseudo-spectral incompressible Navier-Stokes solver (rotational form, 2/3 de-aliasing,
classical RK4), run on 64^3 points to t = 6: under-resolved for the peak dissipation at
t ~ 9, resolved enough at t = 6 that the fields carry fine vortex sheets beside smooth
regions, as CFD output does. The initial field gets a small seeded divergence-free
perturbation (5 % of the peak velocity, wavenumbers 1 to 4): the exact vortex keeps its
mirror symmetries for ever, so 90 % of its values repeat exactly, which a codec's
lossless back end (SZ3's zstd) turns into ratios no real flow gives.

    python scripts/simulate.py OUTDIR        # writes vorticity.npy, pressure.npy, u.npy
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

FIELDS = ("vorticity", "pressure", "u")


def taylor_green(
    n: int = 64, t_end: float = 6.0, re: float = 1600.0, dt: float = 0.02, noise: float = 0.05
):
    """``{name: float32 (z, y, x) array}`` of the vortex at ``t_end``."""
    return taylor_green_series(n, (t_end,), re, dt, noise)[0]


def taylor_green_series(
    n: int = 64, times=(6.0,), re: float = 1600.0, dt: float = 0.02, noise: float = 0.05
) -> list[dict[str, np.ndarray]]:
    """The fields of :func:`taylor_green` at each of ``times`` (ascending), from one run
    (the animation benchmark's time series)."""
    from scipy import fft

    x = np.arange(n) * (2 * np.pi / n)
    z3, y3, x3 = np.meshgrid(x, x, x, indexing="ij")
    u = np.stack([np.sin(x3) * np.cos(y3) * np.cos(z3), -np.cos(x3) * np.sin(y3) * np.cos(z3),
                  np.zeros_like(x3)])  # components (x, y, z) on a (z, y, x) grid
    k1 = fft.fftfreq(n, 1.0 / n)
    kr = fft.rfftfreq(n, 1.0 / n)
    kz, ky, kx = np.meshgrid(k1, k1, kr, indexing="ij")
    k = np.stack([kx, ky, kz])
    k2 = kx**2 + ky**2 + kz**2
    k2_safe = np.where(k2 == 0, 1.0, k2)
    keep = (np.abs(kx) < n / 3) & (np.abs(ky) < n / 3) & (np.abs(kz) < n / 3)
    nu = 1.0 / re

    def spec(f):
        return fft.rfftn(f, axes=(-3, -2, -1))

    def phys(f):
        return fft.irfftn(f, s=(n, n, n), axes=(-3, -2, -1))

    def curl(uh):
        return np.stack([1j * (k[1] * uh[2] - k[2] * uh[1]), 1j * (k[2] * uh[0] - k[0] * uh[2]),
                         1j * (k[0] * uh[1] - k[1] * uh[0])])

    def project(fh):
        return fh - k * (np.sum(k * fh, axis=0) / k2_safe)

    def rhs(uh):
        vel = phys(uh)
        w = phys(curl(uh))
        nl = np.stack([vel[1] * w[2] - vel[2] * w[1], vel[2] * w[0] - vel[0] * w[2],
                       vel[0] * w[1] - vel[1] * w[0]])
        return project(spec(nl) * keep) - nu * k2 * uh

    rng = np.random.default_rng(1600)
    shape = (3, *kx.shape)
    bump = (rng.standard_normal(shape) + 1j * rng.standard_normal(shape)) * (k2 <= 16) * (k2 > 0)
    bump = phys(project(bump))
    uh = spec(u + noise * bump / np.abs(bump).max())
    stops = [int(round(t / dt)) for t in times]
    out, step = [], 0
    for stop in stops:
        while step < stop:
            a = rhs(uh)
            b = rhs(uh + 0.5 * dt * a)
            c = rhs(uh + 0.5 * dt * b)
            d = rhs(uh + dt * c)
            uh = uh + dt / 6 * (a + 2 * b + 2 * c + d)
            step += 1
        out.append(_fields(uh, phys, spec, curl, k, k2_safe))
    return out


def _fields(uh, phys, spec, curl, k, k2_safe) -> dict[str, np.ndarray]:
    vel = phys(uh)
    w = phys(curl(uh))
    nl = np.stack([vel[1] * w[2] - vel[2] * w[1], vel[2] * w[0] - vel[0] * w[2],
                   vel[0] * w[1] - vel[1] * w[0]])
    big_p = phys(-1j * np.sum(k * spec(nl), axis=0) / k2_safe)  # p + |u|^2 / 2
    pressure = big_p - 0.5 * np.sum(vel * vel, axis=0)
    out = {
        "vorticity": np.sqrt(np.sum(w * w, axis=0)),
        "pressure": pressure,
        "u": vel[0],
    }
    return {name: np.ascontiguousarray(v, dtype=np.float32) for name, v in out.items()}


def write(folder: Path) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    for name, v in taylor_green().items():
        np.save(folder / name, v)
        (folder / name).with_suffix(".npy").rename(folder / name)  # member name as in datasets


if __name__ == "__main__":
    write(Path(sys.argv[1]))
