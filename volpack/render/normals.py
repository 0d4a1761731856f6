"""Quantised normals: one 16-bit code per voxel, computed once when first read, lit per frame.

Shading needs ``|n.v|`` at every shaded segment. Reading it from the per-voxel gradient
volume (:func:`volpack.render.prepared.gradient_volume`) costs 24 reads, a square root
and a division per sample; taking it on the fly, six trilinear samples. Here each voxel
instead holds the direction of its world gradient (central differences, one voxel either
way, edges clamped, divided by the spacing) as a code: the direction folded onto the
half sphere ``n_z >= 0`` (the headlight is two-sided, ``n`` and ``-n`` light alike),
mapped onto the octahedron and its square ``(u, v)`` quantised to :data:`LEVELS` steps a
side (at most 0.6 degree off). A vanishing (or non-finite) gradient has a code of its
own and is left unshaded. A frame turns the codes into a table of two lighting factors,
diffuse ``ka + kd |n.v|`` and specular ``ks |n.v|^shininess`` (``(1, 0)`` for no
gradient), for its view direction, once (65 027 entries, 0.5 MB); a sample interpolates the factors of
its eight corner voxels trilinearly: eight 16-bit reads and sixteen table reads, no
square root (VTK's fixed-point ray caster shades the same way).

The table holds one view direction, so this serves orthographic frames (every ray
parallel); perspective frames read gradients as before. Codes take 2 bytes a voxel (a
256^3 volume 32 MB, the benchmark's 301 x 370 x 316 MRI 70 MB) within the prepared
volume's gradient budget (1 GiB by default: 512 M voxels, about 800^3); over it (a
1024^3 volume takes 2 GiB) the renderer falls back to gradients on the fly.

A code array stores ``1 +`` the code, so that 0 means "not computed yet": it starts as
an array the operating system hands out zeroed page by page, and the ray caster
computes a voxel's code the first time a shaded sample reads it (:func:`code_at`, the
arithmetic of the whole-volume kernel, so the value does not depend on who computed
it or when; threads that race on a voxel write the same number). Only the voxels next
to shaded samples are computed and touched: on the MRI walk of the benchmark a first
frame read about a tenth of the codes that the visible bricks' chunks held, which is
what was computed before. :meth:`NormalCodes.ensure` still computes whole chunks (a
walk's node bricks, tests).
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import kernel, read_only
from ..parallel import ordered_map

#: Quantisation steps per side of the octahedral square (stored codes 2 .. LEVELS^2 + 1).
LEVELS = 255
#: Edge of the chunks normals are computed by.
CHUNK = 16
_DECODED = None  # unit normals of codes 1..LEVELS^2 (float64, (LEVELS^2 + 1, 3))


@kernel(inline=True)
def _encode(gz, gy, gx):
    """The stored code of the world gradient (gz, gy, gx): 1 when it vanishes or is not
    finite (0 is "not computed yet")."""
    s = abs(gz) + abs(gy) + abs(gx)
    if not (s > 0.0 and s < np.inf):
        return np.uint16(1)
    if gz < 0.0:  # two-sided lighting: fold onto n_z >= 0
        gy, gx = -gy, -gx
    px = gx / s
    py = gy / s
    half = 0.5 * (LEVELS - 1)
    qu = int(math.floor((px + py + 1.0) * half + 0.5))
    qv = int(math.floor((px - py + 1.0) * half + 0.5))
    return np.uint16(2 + qu * LEVELS + qv)


@kernel(inline=True)
def _voxel_code(vol, z, y, x, inv2):
    """The stored code of voxel (z, y, x) of ``vol``; ``inv2``: the world scale
    ``1 / (2 spacing)`` of the voxel differences."""
    nz, ny, nx = vol.shape
    zm, zp = max(z - 1, 0), min(z + 1, nz - 1)
    ym, yp = max(y - 1, 0), min(y + 1, ny - 1)
    xm, xp = max(x - 1, 0), min(x + 1, nx - 1)
    # in float64: unsigned differences would wrap
    gz = (np.float64(vol[zp, y, x]) - np.float64(vol[zm, y, x])) * inv2[0]
    gy = (np.float64(vol[z, yp, x]) - np.float64(vol[z, ym, x])) * inv2[1]
    gx = (np.float64(vol[z, y, xp]) - np.float64(vol[z, y, xm])) * inv2[2]
    return _encode(gz, gy, gx)


@kernel(nrt=False)
def code_at(vol, z, y, x, inv2):
    """:func:`_voxel_code` as a call of its own: the ray caster's march, compiled with
    fused multiply-adds, calls it, so that a code it computes is the one this module's
    kernels compute (no fused rounding)."""
    return _voxel_code(vol, z, y, x, inv2)


@kernel
def _normals_kernel(vol, chunks, inv2, out):
    """Stored codes of the voxels of each chunk ``chunks[k] = (cz, cy, cx)``."""
    nz, ny, nx = vol.shape
    for k in range(chunks.shape[0]):
        z0, y0, x0 = chunks[k, 0] * CHUNK, chunks[k, 1] * CHUNK, chunks[k, 2] * CHUNK
        for z in range(z0, min(z0 + CHUNK, nz)):
            for y in range(y0, min(y0 + CHUNK, ny)):
                for x in range(x0, min(x0 + CHUNK, nx)):
                    out[z, y, x] = _voxel_code(vol, z, y, x, inv2)


@kernel
def _mark_chunks(visible, brick, reach, need):
    """``need[c] = True`` for every chunk within ``reach`` voxels of a visible brick."""
    nbz, nby, nbx = visible.shape
    ncz, ncy, ncx = need.shape
    for bz in range(nbz):
        for by in range(nby):
            for bx in range(nbx):
                if not visible[bz, by, bx]:
                    continue
                z0 = max(bz * brick - reach, 0) // CHUNK
                z1 = min((bz + 1) * brick + reach, ncz * CHUNK - 1) // CHUNK
                y0 = max(by * brick - reach, 0) // CHUNK
                y1 = min((by + 1) * brick + reach, ncy * CHUNK - 1) // CHUNK
                x0 = max(bx * brick - reach, 0) // CHUNK
                x1 = min((bx + 1) * brick + reach, ncx * CHUNK - 1) // CHUNK
                for cz in range(z0, z1 + 1):
                    for cy in range(y0, y1 + 1):
                        for cx in range(x0, x1 + 1):
                            need[cz, cy, cx] = True


class NormalCodes:
    """The per-voxel stored codes of one (filled) volume, 0 until computed: by the ray
    caster voxel by voxel as samples read them, or by :meth:`ensure` chunk by chunk."""

    def __init__(self, vol: np.ndarray, spacing) -> None:
        self.vol = read_only(vol)  # one compiled signature for every caller
        self.inv2 = np.array([0.5 / float(s) for s in spacing], np.float64)
        self.codes = np.zeros(vol.shape, np.uint16)  # zero pages until written
        self.done = np.zeros(tuple(-(-n // CHUNK) for n in vol.shape), np.bool_)

    def forget(self, box) -> None:
        """The voxels of ``box`` (three slices) changed: their codes are computed again."""
        self.codes[box] = 0
        self.done[tuple(slice(s.start // CHUNK, -(-s.stop // CHUNK)) for s in box)] = False

    def ensure(self, visible: np.ndarray | None, brick: int, reach: float, workers: int = 1):
        """Compute the chunks within ``reach`` voxels of the ``visible`` bricks (every
        chunk when ``visible`` is None) not computed yet; return the code array."""
        if visible is None:
            need = np.ones(self.done.shape, np.bool_)
        else:
            need = np.zeros(self.done.shape, np.bool_)
            _mark_chunks(np.ascontiguousarray(visible), int(brick),
                         int(math.ceil(reach)) + 1, need)  # fmt: skip
        todo = np.argwhere(need & ~self.done).astype(np.int64)
        if len(todo):
            # C-ordered parts (argwhere's result is not): the kernel keeps one signature
            parts = [np.ascontiguousarray(p)
                     for p in np.array_split(todo, max(1, min(len(todo), 4 * workers)))]
            for _ in ordered_map(lambda c: _normals_kernel(self.vol, c, self.inv2, self.codes),
                                 parts, workers=workers):  # fmt: skip
                pass
            self.done |= need
        return self.codes


def normal_codes(vol: np.ndarray, spacing) -> np.ndarray:
    """The codes of every voxel of ``vol`` (a node brick of a walkthrough's atlas)."""
    return NormalCodes(np.ascontiguousarray(vol), spacing).ensure(None, CHUNK, 0.0)


def decoded() -> np.ndarray:
    """Unit normal (z, y, x) of every stored code (rows 0, not computed, and 1, the
    vanishing gradient, are zero)."""
    global _DECODED
    if _DECODED is None:
        q = np.arange(LEVELS * LEVELS)
        u = (q // LEVELS) * (2.0 / (LEVELS - 1)) - 1.0
        v = (q % LEVELS) * (2.0 / (LEVELS - 1)) - 1.0
        px, py = 0.5 * (u + v), 0.5 * (u - v)
        n = np.stack([1.0 - np.abs(px) - np.abs(py), py, px], axis=1)
        n /= np.linalg.norm(n, axis=1, keepdims=True)
        _DECODED = np.concatenate([np.zeros((2, 3)), n])
    return _DECODED


def light_table(view, ka: float, kd: float, ks: float, shininess: float) -> np.ndarray:
    """``(codes, 2)`` float32: diffuse and specular factor of each stored code for the
    unit world view vector ``view`` (z, y, x); codes 0 and 1 (no gradient) are
    ``(1, 0)``, unshaded (the ray caster computes a 0 before it reads it)."""
    ndv = np.abs(decoded() @ np.asarray(view, np.float64))
    tab = np.empty((len(ndv), 2), np.float32)
    tab[:, 0] = ka + kd * ndv
    tab[:, 1] = ks * ndv**shininess
    tab[:2] = (1.0, 0.0)
    return tab
