"""Quantised normals: one 16-bit code per voxel, computed once per volume, lit per frame.

Shading needs ``|n.v|`` at every shaded segment. Reading it from the per-voxel gradient
volume (:func:`volpack.render.prepared.gradient_volume`) costs 24 reads, a square root
and a division per sample; taking it on the fly, six trilinear samples. Here each voxel
instead holds the direction of its world gradient (central differences, one voxel either
way, edges clamped, divided by the spacing) as a code: the direction folded onto the
half sphere ``n_z >= 0`` (the headlight is two-sided, ``n`` and ``-n`` light alike),
mapped onto the octahedron and its square ``(u, v)`` quantised to :data:`LEVELS` steps a
side (at most 0.6 degree off). Code 0 is a vanishing (or non-finite) gradient, which is
left unshaded. A frame turns the codes into a table of two lighting factors, diffuse
``ka + kd |n.v|`` and specular ``ks |n.v|^shininess`` (``(1, 0)`` for code 0), for its
view direction, once (65 026 entries, 0.5 MB); a sample interpolates the factors of
its eight corner voxels trilinearly: eight 16-bit reads and sixteen table reads, no
square root (VTK's fixed-point ray caster shades the same way).

The table holds one view direction, so this serves orthographic frames (every ray
parallel); perspective frames and multiresolution selections read gradients as before.
Codes take 2 bytes a voxel (a 256^3 volume 32 MB, the benchmark's 301 x 370 x 316 MRI
70 MB) within the prepared volume's gradient budget (1 GiB by default: 512 M voxels,
about 800^3); over it (a 1024^3 volume takes 2 GiB) the renderer falls back to
gradients on the fly. The codes are built on first use for the chunks of
:data:`CHUNK`^3 voxels that the frame's visible bricks (and the segments that straddle
into them) can reach, in an array the operating system hands out zeroed page by page,
so a transfer function that shows a small part of a large volume computes and touches
only that part; a later frame that shows more computes the rest.
"""

from __future__ import annotations

import math

import numpy as np

from .._jit import kernel, read_only
from ..parallel import ordered_map

#: Quantisation steps per side of the octahedral square (codes 1 .. LEVELS^2).
LEVELS = 255
#: Edge of the chunks normals are computed by.
CHUNK = 16
_DECODED = None  # unit normals of codes 1..LEVELS^2 (float64, (LEVELS^2 + 1, 3))


@kernel(inline=True)
def _encode(gz, gy, gx):
    """The code of the world gradient (gz, gy, gx): 0 when it vanishes or is not finite.
    Without branches, so that a row's codes vectorise (four voxels an instruction); the
    folding, the divisions and the rounding are those of a scalar computation, operation
    for operation (no fused multiply-adds), so every code is the same on any CPU."""
    s = abs(gz) + abs(gy) + abs(gx)
    neg = gz < 0.0  # two-sided lighting: fold onto n_z >= 0
    px = (-gx if neg else gx) / s
    py = (-gy if neg else gy) / s
    half = 0.5 * (LEVELS - 1)
    qu = np.floor((px + py + 1.0) * half + 0.5)  # a float: int64 conversions do not vectorise
    qv = np.floor((px - py + 1.0) * half + 0.5)
    code = 1.0 + qu * LEVELS + qv  # an integer of at most LEVELS^2: exact in float64
    return np.uint16(np.int32(code if s > 0.0 and s < np.inf else 0.0))


@kernel(inline=True)
def _code_row(c, zm, zp, ym, yp, out, x0, x1, sz, sy, sx, clamp):
    """Codes of row voxels ``x0 .. x1 - 1``: ``c`` the row, ``zm .. yp`` its neighbour
    rows (already clamped), ``sz, sy, sx`` the differences' scales; ``clamp`` for the
    row's first and last voxel, whose x neighbours are clamped to the row."""
    nx = c.shape[0]
    for x in range(x0, x1):
        xm, xp = x - 1, x + 1
        if clamp:
            xm, xp = max(xm, 0), min(xp, nx - 1)
        # in float64: unsigned differences would wrap
        gz = (np.float64(zp[x]) - np.float64(zm[x])) * sz
        gy = (np.float64(yp[x]) - np.float64(ym[x])) * sy
        gx = (np.float64(c[xp]) - np.float64(c[xm])) * sx
        out[x] = _encode(gz, gy, gx)


@kernel(nrt=False)
def _normals_kernel(vol, runs, inv2, out):
    """Codes of the voxels of each run of chunks ``runs[k] = (cz, cy, cx0, cx1)`` (chunks
    ``cx0 .. cx1 - 1`` along x), a row at a time: a run's rows are long enough to
    vectorise, a chunk's 16 voxels are not; ``inv2``: the world scale
    ``1 / (2 spacing)`` of the voxel differences."""
    nz, ny, nx = vol.shape
    sz, sy, sx = inv2[0], inv2[1], inv2[2]
    for k in range(runs.shape[0]):
        z0, y0 = runs[k, 0] * CHUNK, runs[k, 1] * CHUNK
        x0, x1 = runs[k, 2] * CHUNK, min(runs[k, 3] * CHUNK, nx)
        xa = min(max(x0, 1), x1)  # the voxels whose x neighbours are in the volume
        xb = max(min(x1, nx - 1), xa)
        for z in range(z0, min(z0 + CHUNK, nz)):
            zm, zp = max(z - 1, 0), min(z + 1, nz - 1)
            for y in range(y0, min(y0 + CHUNK, ny)):
                ym, yp = max(y - 1, 0), min(y + 1, ny - 1)
                c, o = vol[z, y], out[z, y]
                a, b, d, e = vol[zm, y], vol[zp, y], vol[z, ym], vol[z, yp]
                _code_row(c, a, b, d, e, o, x0, xa, sz, sy, sx, True)
                _code_row(c, a, b, d, e, o, xa, xb, sz, sy, sx, False)
                _code_row(c, a, b, d, e, o, xb, x1, sz, sy, sx, True)


def chunk_runs(chunks: np.ndarray) -> np.ndarray:
    """``(cz, cy, cx0, cx1)`` rows: the chunks ``(cz, cy, cx)`` (sorted, as
    ``np.argwhere`` gives them) merged where they follow each other along x."""
    c = np.asarray(chunks, np.int64).reshape(-1, 3)
    new = np.ones(len(c), bool)
    new[1:] = (c[1:, 0] != c[:-1, 0]) | (c[1:, 1] != c[:-1, 1]) | (c[1:, 2] != c[:-1, 2] + 1)
    start = np.flatnonzero(new)
    stop = np.append(start[1:], len(c))
    return np.column_stack([c[start], c[stop - 1, 2] + 1]).astype(np.int64)


def _split_runs(runs: np.ndarray, parts: int) -> list[np.ndarray]:
    """``runs`` cut into at most ``parts`` C-ordered pieces of about equal chunk counts."""
    cum = np.cumsum(runs[:, 3] - runs[:, 2])
    cuts = np.searchsorted(cum, cum[-1] * np.arange(1, parts) / parts, side="right")
    return [np.ascontiguousarray(p) for p in np.split(runs, np.unique(cuts)) if len(p)]


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
    """The per-voxel codes of one (filled) volume, computed chunk by chunk on demand
    (into ``out``, a zeroed uint16 array of the volume's shape, when given)."""

    def __init__(self, vol: np.ndarray, spacing, out: np.ndarray | None = None) -> None:
        self.vol = read_only(vol)  # one compiled signature for every caller
        self.inv2 = np.array([0.5 / float(s) for s in spacing], np.float64)
        ok = (out is not None and out.shape == vol.shape and out.dtype == np.uint16
              and out.flags.c_contiguous and out.flags.writeable)  # fmt: skip
        self.codes = out if ok else np.zeros(vol.shape, np.uint16)  # zero pages until written
        self.done = np.zeros(tuple(-(-n // CHUNK) for n in vol.shape), np.bool_)

    def stale(self, box) -> None:
        """The voxels of ``box`` (three slices) changed: the chunks it reaches are
        computed again when next needed."""
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
        todo = np.argwhere(need & ~self.done)
        if len(todo):
            # C-ordered parts (the kernel keeps one signature) of about equal work
            parts = _split_runs(chunk_runs(todo), 4 * workers)
            for _ in ordered_map(lambda r: _normals_kernel(self.vol, r, self.inv2, self.codes),
                                 parts, workers=workers):  # fmt: skip
                pass
            self.done |= need
        return self.codes


def normal_codes(vol: np.ndarray, spacing) -> np.ndarray:
    """The codes of every voxel of ``vol`` (a node brick of a walkthrough's atlas)."""
    return NormalCodes(np.ascontiguousarray(vol), spacing).ensure(None, CHUNK, 0.0)


def decoded() -> np.ndarray:
    """Unit normal (z, y, x) of every code (row 0, the vanishing code, is zero)."""
    global _DECODED
    if _DECODED is None:
        q = np.arange(LEVELS * LEVELS)
        u = (q // LEVELS) * (2.0 / (LEVELS - 1)) - 1.0
        v = (q % LEVELS) * (2.0 / (LEVELS - 1)) - 1.0
        px, py = 0.5 * (u + v), 0.5 * (u - v)
        n = np.stack([1.0 - np.abs(px) - np.abs(py), py, px], axis=1)
        n /= np.linalg.norm(n, axis=1, keepdims=True)
        _DECODED = np.concatenate([np.zeros((1, 3)), n])
    return _DECODED


def light_table(view, ka: float, kd: float, ks: float, shininess: float) -> np.ndarray:
    """``(codes, 2)`` float32: diffuse and specular factor of each code for the unit
    world view vector ``view`` (z, y, x); code 0 (no gradient) is ``(1, 0)``, unshaded."""
    ndv = np.abs(decoded() @ np.asarray(view, np.float64))
    tab = np.empty((len(ndv), 2), np.float32)
    tab[:, 0] = ka + kd * ndv
    tab[:, 1] = ks * ndv**shininess
    tab[0] = (1.0, 0.0)
    return tab
