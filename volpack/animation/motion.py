"""Block motion estimation and (windowed) motion compensation between volumes.

A frame is cut into 8^3 blocks (the last block on an axis may be shorter). Each block has
a vector into a reference frame, in **quarter-voxel units**. Sub-voxel positions are
read from the reference upsampled twice along each axis (:func:`upsample`): half-voxel
samples come from an eight-tap interpolation filter (``HALF_TAPS``), which keeps
the detail that the mean of two neighbours would blur away, and a quarter-voxel sample
is the mean of the two grid samples at the ends of the diagonal of the grid box around
it (as video codecs form diagonal quarter samples; the mean over the whole box would read
up to eight). Positions outside the reference take the value at its nearest border
sample, in estimation and compensation alike. The grid is stored split by index parity
with a clamped margin (:func:`upsample`), so a moved window reads contiguous rows.

Estimation minimises the squared error of each block against the shifted reference:

``fast``
    starts from the zero vector (and from the vectors of the neighbouring blocks already
    estimated), steps 8, 4, 2, 1 voxels around the best vector so far, then walks to a
    local minimum one voxel at a time; static regions stop at once (zero error).
``exhaustive``
    tries every whole-voxel vector within the search range, nearest first, so of equal
    errors the shortest vector wins.

Both then try the 26 half-voxel vectors around the best whole one, and optionally the
26 quarter-voxel vectors around the best half one.

Compensation builds the prediction of every voxel from the blocks whose windows cover
it. In ``windowed`` mode each block's window is its 8^3 core widened by 2 voxels on each
side (12^3), weighted by a separable cosine fall-off (sin^2 rise over 4 voxels, flat,
cos^2 fall over 4); the windows of neighbouring blocks overlap so that the weights sum to
one at every voxel, and neighbouring blocks with different vectors blend rather than
leave an edge for the wavelet to pay for. ``block`` mode uses the 8^3 cores alone.

Each block predicts in one of four modes: from the previous anchor (``MODE_FWD``), from
the next anchor (``MODE_BWD``), from the mean of both (``MODE_BI``), or as a constant,
the block's own mean (``MODE_INTRA``: new content that no vector predicts).

It stays one file of about 1,000 lines on purpose: estimation and compensation read the
same parity-split upsampled grid through the same inline sampling kernels, and the
encoder's search must predict exactly as the decoder's compensation does.
"""

from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np

from .._jit import kernel
from ..errors import OptionError
from . import shift

BLOCK = 8
OVERLAP = 2  # 12^3 windows
# Margin (voxels per side) of the stored half-voxel grid, holding the border-clamped
# values: a window moved a few voxels past the frame still reads contiguous rows (on the
# advected test field 8 % of the blocks' windows reach past the frame, 0.03 % past 4).
MARGIN = 4
# The prediction arithmetic a stream was coded with (animation header ``motion.rule``):
# quarter-voxel samples are the mean of the two grid samples at the ends of the box
# diagonal, and a bidirectional block adds ``w (S0 + S1) / 2`` in one term.
RULE = "diagonal"
MODE_FWD, MODE_BWD, MODE_BI, MODE_INTRA = 0, 1, 2, 3
SEARCH_METHODS = ("fast", "exhaustive")
COMPENSATIONS = ("windowed", "block")
DEFAULT_RADIUS = 15


@dataclasses.dataclass(frozen=True)
class MotionField:
    """Per block: the mode, the vectors (quarter-voxel units) into the previous (``fwd``) and
    next (``bwd``) anchor, and the constant of intra blocks."""

    mode: np.ndarray  # (nbz, nby, nbx) uint8
    fwd: np.ndarray  # (nbz, nby, nbx, 3) int64
    bwd: np.ndarray  # (nbz, nby, nbx, 3) int64
    mean: np.ndarray  # (nbz, nby, nbx) float64

    def counts(self) -> dict[str, int]:
        """How many blocks chose each mode (what the encoder reports)."""
        names = ("forward", "backward", "bidirectional", "intra")
        return {n: int(np.count_nonzero(self.mode == i)) for i, n in enumerate(names)}


def block_grid(shape: tuple[int, ...]) -> tuple[int, int, int]:
    """Blocks per axis for a ``(z, y, x)`` frame."""
    return tuple(-(-int(n) // BLOCK) for n in shape[-3:])  # type: ignore[return-value]


# -- sampling and block errors -----------------------------------------------------------


@kernel(inline=True)
def _clampi(i, n):
    if i < 0:
        return 0
    if i >= n:
        return n - 1
    return i


@kernel(inline=True)
def _half(up, iz, iy, ix):
    """The half-voxel grid sample at index (iz, iy, ix), border clamped. ``up`` holds the
    grid split by index parity, with ``MARGIN`` clamped samples on every side:
    ``up[pz, py, px, i, j, k] = grid[2(i - M) + pz, 2(j - M) + py, 2(k - M) + px]``
    (:func:`upsample`)."""
    iz = _clampi(iz + 2 * MARGIN, 2 * up.shape[3])
    iy = _clampi(iy + 2 * MARGIN, 2 * up.shape[4])
    ix = _clampi(ix + 2 * MARGIN, 2 * up.shape[5])
    return up[iz & 1, iy & 1, ix & 1, iz >> 1, iy >> 1, ix >> 1]


@kernel(inline=True)
def _unit(up):
    """The value of one unit of a stored grid sample: 1/64 for the int16 grids of 8-bit
    frames (fixed point, :func:`upsample`), 1 for float32 grids."""
    return 0.015625 if up.itemsize == 2 else 1.0


@kernel(inline=True)
def _sample8(up, z4, y4, x4):
    """8 x the reference at the quarter-voxel position (z4, y4, x4) / 4, read from its
    half-voxel grid ``up`` (border clamped): the grid sample there, or the mean of the
    two grid samples at the ends of the box diagonal through it."""
    z0 = z4 >> 1
    y0 = y4 >> 1
    x0 = x4 >> 1
    s = np.float64(_half(up, z0, y0, x0))  # sums in float64, as the row reads do
    if ((z4 | y4 | x4) & 1) == 0:
        return (8.0 * _unit(up)) * s
    return (4.0 * _unit(up)) * (s + _half(up, z0 + (z4 & 1), y0 + (y4 & 1), x0 + (x4 & 1)))


@kernel(inline=True)
def _on_grid(up, z0, z1, y0, y1, x0, x1, vz, vy, vx):
    """Whether every half-voxel grid sample the box ``[z0, z1) x [y0, y1) x [x0, x1)``
    reads through the sub-voxel vector is stored in ``up`` (no clamping needed)."""
    m = 2 * MARGIN
    uz, uy, ux = 2 * up.shape[3] - m, 2 * up.shape[4] - m, 2 * up.shape[5] - m
    return (
        2 * z0 + (vz >> 1) >= -m
        and 2 * (z1 - 1) + (vz >> 1) + (vz & 1) < uz
        and 2 * y0 + (vy >> 1) >= -m
        and 2 * (y1 - 1) + (vy >> 1) + (vy & 1) < uy
        and 2 * x0 + (vx >> 1) >= -m
        and 2 * (x1 - 1) + (vx >> 1) + (vx & 1) < ux
    )


@kernel(inline=True)
def _inside(ref, up, z0, z1, y0, y1, x0, x1, vz, vy, vx):
    """Whether the box moved by the vector reads only stored samples (no clamping)."""
    if ((vz | vy | vx) & 3) == 0:
        nz, ny, nx = ref.shape
        dz, dy, dx = vz >> 2, vy >> 2, vx >> 2
        return (
            z0 + dz >= 0
            and z1 + dz <= nz
            and y0 + dy >= 0
            and y1 + dy <= ny
            and x0 + dx >= 0
            and x1 + dx <= nx
        )
    return _on_grid(up, z0, z1, y0, y1, x0, x1, vz, vy, vx)


@kernel(inline=True)
def _grid_row(up, z, y, hz, hy, hx):
    """The row of stored grid samples holding grid index (2z + hz, 2y + hy, 2x + hx) at
    position ``x + (hx >> 1) + MARGIN``."""
    return up[hz & 1, hy & 1, hx & 1, z + (hz >> 1) + MARGIN, y + (hy >> 1) + MARGIN]


@kernel
def _block_sse(cur, ref, up, z0, y0, x0, vz, vy, vx, limit):
    """Squared error (in units of 1/64) of the block at (z0, y0, x0) against the
    reference moved by the quarter-voxel vector; stops early once past ``limit``."""
    nz, ny, nx = cur.shape
    ez = min(z0 + 8, nz)
    ey = min(y0 + 8, ny)
    ex = min(x0 + 8, nx)
    s = 0.0
    inside = _inside(ref, up, z0, ez, y0, ey, x0, ex, vz, vy, vx)
    if ((vz | vy | vx) & 3) == 0:
        dz = vz >> 2
        dy = vy >> 2
        dx = vx >> 2
        for z in range(z0, ez):
            for y in range(y0, ey):
                if inside:
                    c = cur[z, y, x0:ex]
                    r = ref[z + dz, y + dy, x0 + dx : ex + dx]
                    for i in range(ex - x0):
                        d = np.float64(c[i]) - np.float64(r[i])
                        s += 64.0 * d * d
                else:
                    zi = _clampi(z + dz, nz)
                    yi = _clampi(y + dy, ny)
                    for x in range(x0, ex):
                        d = np.float64(cur[z, y, x]) - np.float64(ref[zi, yi, _clampi(x + dx, nx)])
                        s += 64.0 * d * d
            if s > limit:
                return s
        return s
    # on the half-voxel grid voxel z reads 2z + (vz >> 1), and its neighbour if vz is odd
    hz, hy, hx = vz >> 1, vy >> 1, vx >> 1
    fz, fy, fx = vz & 1, vy & 1, vx & 1
    quarter = (fz | fy | fx) != 0
    scale = (4.0 if quarter else 8.0) * _unit(up)
    m = ex - x0
    b0, b1 = x0 + (hx >> 1) + MARGIN, x0 + ((hx + fx) >> 1) + MARGIN
    for z in range(z0, ez):
        for y in range(y0, ey):
            c = cur[z, y, x0:ex]
            if not inside:
                for i in range(m):
                    d = 8.0 * c[i] - _sample8(up, 4 * z + vz, 4 * y + vy, 4 * (x0 + i) + vx)
                    s += d * d
                continue
            # rows of the two ends of the diagonal (one sample if there is none), loops
            # without branches (the sum runs in x order as before: the same errors)
            src0 = _grid_row(up, z, y, hz, hy, hx)[b0 : b0 + m]
            if quarter:
                src1 = _grid_row(up, z, y, hz + fz, hy + fy, hx + fx)[b1 : b1 + m]
                for i in range(m):
                    d = 8.0 * c[i] - (np.float64(src0[i]) + src1[i]) * scale
                    s += d * d
            else:
                for i in range(m):
                    d = 8.0 * c[i] - np.float64(src0[i]) * scale
                    s += d * d
        if s > limit:
            return s
    return s


@kernel
def _try(cur, ref, up, z0, y0, x0, cz, cy, cx, lim, pen, best, bv):
    """Try the vector (cz, cy, cx) (quarter units): its cost is the block's squared error
    plus ``pen`` per quarter voxel of length (so flat or noisy blocks keep short vectors);
    keep it in ``bv`` if it beats ``best``. Vectors outside +-``lim`` are skipped.
    Returns the best cost."""
    if abs(cz) > lim or abs(cy) > lim or abs(cx) > lim:
        return best
    extra = pen * (abs(cz) + abs(cy) + abs(cx))
    if extra >= best:
        return best
    s = _block_sse(cur, ref, up, z0, y0, x0, cz, cy, cx, best - extra) + extra
    if s < best:
        bv[0] = cz
        bv[1] = cy
        bv[2] = cx
        return s
    return best


@kernel
def _estimate_kernel(cur, ref, up, radius, pen, exhaustive, fine, order, ring, out_v, out_sse):
    nbz, nby, nbx = out_sse.shape
    lim = 4 * radius
    bv = np.zeros(3, np.int64)
    for bz in range(nbz):
        for by in range(nby):
            for bx in range(nbx):
                z0 = bz * 8
                y0 = by * 8
                x0 = bx * 8
                bv[:] = 0
                best = _block_sse(cur, ref, up, z0, y0, x0, 0, 0, 0, np.inf)
                if best > 0.0 and exhaustive:
                    for k in range(order.shape[0]):
                        best = _try(
                            cur, ref, up, z0, y0, x0, order[k, 0], order[k, 1], order[k, 2],
                            lim, pen, best, bv,
                        )  # fmt: skip
                elif best > 0.0:
                    # neighbours' vectors (whole part) as starting points
                    for nb in range(3):
                        pz, py, px = bz - (nb == 0), by - (nb == 1), bx - (nb == 2)
                        if pz >= 0 and py >= 0 and px >= 0:
                            best = _try(
                                cur, ref, up, z0, y0, x0,
                                (out_v[pz, py, px, 0] >> 2) * 4,
                                (out_v[pz, py, px, 1] >> 2) * 4,
                                (out_v[pz, py, px, 2] >> 2) * 4,
                                lim, pen, best, bv,
                            )  # fmt: skip
                    step = 1
                    while step * 2 <= radius // 2:
                        step *= 2
                    while step >= 1 and best > 0.0:
                        cz, cy, cx = bv[0], bv[1], bv[2]
                        for k in range(ring.shape[0]):
                            best = _try(
                                cur, ref, up, z0, y0, x0,
                                cz + 4 * step * ring[k, 0],
                                cy + 4 * step * ring[k, 1],
                                cx + 4 * step * ring[k, 2],
                                lim, pen, best, bv,
                            )  # fmt: skip
                        step //= 2
                    for _ in range(4 * radius + 1):  # walk to a local minimum
                        cz, cy, cx = bv[0], bv[1], bv[2]
                        for k in range(ring.shape[0]):
                            best = _try(
                                cur, ref, up, z0, y0, x0,
                                cz + 4 * ring[k, 0], cy + 4 * ring[k, 1], cx + 4 * ring[k, 2],
                                lim, pen, best, bv,
                            )  # fmt: skip
                        if best == 0.0 or (bv[0] == cz and bv[1] == cy and bv[2] == cx):
                            break
                # sub-voxel refinement: half voxels (fine >= 1), then quarter (fine 2)
                for level in range(fine):
                    if best == 0.0:
                        break
                    d = 2 >> level
                    cz, cy, cx = bv[0], bv[1], bv[2]
                    for k in range(ring.shape[0]):
                        best = _try(
                            cur, ref, up, z0, y0, x0,
                            cz + d * ring[k, 0], cy + d * ring[k, 1], cx + d * ring[k, 2],
                            lim + 3, pen, best, bv,
                        )  # fmt: skip
                out_v[bz, by, bx, 0] = bv[0]
                out_v[bz, by, bx, 1] = bv[1]
                out_v[bz, by, bx, 2] = bv[2]
                out_sse[bz, by, bx] = best / 64.0


# The half-sample interpolation filter (the eight taps of HEVC's luma filter): on the head
# MRI moved by half a voxel it predicts with 0.45x the RMS error of the two-voxel mean
# (six taps: 0.50x; a 12-tap Lanczos 0.38x for 50 % more work).
HALF_TAPS = np.array([-1.0, 4.0, -11.0, 40.0, 40.0, -11.0, 4.0, -1.0]) / 64.0


@kernel
def _upsample_axis_kernel(src, taps, even, odd):
    """Along the last axis, into rows of ``n + 2 MARGIN``: ``even`` holds ``src``, ``odd``
    the interpolations halfway to the next sample (border clamped); the last odd sample
    and the margins hold the clamped border samples."""
    n = src.shape[-1]
    nt = taps.size
    h = nt // 2
    # interior outputs [lo, hi) read no clamped sample: eight shifted slices of the row,
    # summed per output in tap order (vectorised across the row)
    lo, hi = h - 1, max(n - nt + h, h - 1)
    for i in range(src.shape[0]):
        for j in range(src.shape[1]):
            row = src[i, j]
            e = even[i, j]
            o = odd[i, j]
            for x in range(MARGIN):
                e[x] = row[0]
                o[x] = row[0]
                e[MARGIN + n + x] = row[n - 1]
                o[MARGIN + n + x] = row[n - 1]
            for x in range(n):
                e[MARGIN + x] = row[x]
            for x in range(min(lo, n - 1)):
                a = 0.0
                for k in range(nt):
                    a += taps[k] * row[_clampi(x + 1 - h + k, n)]
                o[MARGIN + x] = a
            m = hi - lo
            s0, s1, s2, s3 = (
                row[lo - 3 : hi - 3],
                row[lo - 2 : hi - 2],
                row[lo - 1 : hi - 1],
                row[lo:hi],
            )
            s4, s5, s6, s7 = (
                row[lo + 1 : hi + 1],
                row[lo + 2 : hi + 2],
                row[lo + 3 : hi + 3],
                row[lo + 4 : hi + 4],
            )
            dst = o[MARGIN + lo : MARGIN + hi]
            for x in range(m):
                dst[x] = _taps8(taps, s0[x], s1[x], s2[x], s3[x], s4[x], s5[x], s6[x], s7[x])
            for x in range(max(hi, lo), n - 1):
                a = 0.0
                for k in range(nt):
                    a += taps[k] * row[_clampi(x + 1 - h + k, n)]
                o[MARGIN + x] = a
            o[MARGIN + n - 1] = row[n - 1]


@kernel(inline=True)
def _put(dst, vals):
    """``dst[:] = vals[:dst.size]``; into an int16 grid as fixed point: 64ths, rounded
    half to even, clamped to the int16 range."""
    if dst.itemsize == 2:
        for x in range(dst.size):
            dst[x] = min(max(np.rint(vals[x] * 64.0), -32768.0), 32767.0)
    else:
        for x in range(dst.size):
            dst[x] = vals[x]


@kernel(inline=True)
def _taps8(t, a0, a1, a2, a3, a4, a5, a6, a7):
    """``sum_k t[k] a_k`` accumulated from 0 in tap order, in float64."""
    v = 0.0
    v += t[0] * np.float64(a0)
    v += t[1] * np.float64(a1)
    v += t[2] * np.float64(a2)
    v += t[3] * np.float64(a3)
    v += t[4] * np.float64(a4)
    v += t[5] * np.float64(a5)
    v += t[6] * np.float64(a6)
    v += t[7] * np.float64(a7)
    return v


@kernel
def _upsample_mid_kernel(src, taps, even, odd):
    """As :func:`_upsample_axis_kernel`, along the middle axis: each output row is summed
    in one pass over its eight source rows (contiguous; for the z pass, whole planes)."""
    n = src.shape[1]
    fixed = odd.itemsize == 2
    for i in range(src.shape[0]):
        for y in range(MARGIN):
            _put(even[i, y], src[i, 0])
            _put(odd[i, y], src[i, 0])
            _put(even[i, MARGIN + n + y], src[i, n - 1])
            _put(odd[i, MARGIN + n + y], src[i, n - 1])
        for y in range(n):
            _put(even[i, MARGIN + y], src[i, y])
        for y in range(n - 1):
            s0, s1 = src[i, _clampi(y - 3, n)], src[i, _clampi(y - 2, n)]
            s2, s3 = src[i, _clampi(y - 1, n)], src[i, y]
            s4, s5 = src[i, _clampi(y + 1, n)], src[i, _clampi(y + 2, n)]
            s6, s7 = src[i, _clampi(y + 3, n)], src[i, _clampi(y + 4, n)]
            d = odd[i, MARGIN + y]
            for x in range(d.size):
                v = _taps8(taps, s0[x], s1[x], s2[x], s3[x], s4[x], s5[x], s6[x], s7[x])
                if fixed:  # as _put: int16 64ths
                    d[x] = min(max(np.rint(v * 64.0), -32768.0), 32767.0)
                else:
                    d[x] = v
        _put(odd[i, MARGIN + n - 1], src[i, n - 1])


def upsample(ref: np.ndarray) -> np.ndarray:
    """The reference on its half-voxel grid, float32 (half the memory traffic of float64;
    each pass sums in float64), split by index parity and widened by ``MARGIN`` samples of
    border-clamped values on every side: ``out[pz, py, px, i, j, k]`` is grid sample
    ``(2(i - M) + pz, 2(j - M) + py, 2(k - M) + px)`` clamped to the grid, so that a
    window moved by a sub-voxel vector reads contiguous rows. Even grid indices are the
    voxels, odd ones eight-tap interpolations between them. :func:`interleave` gives the
    ``(2z-1, 2y-1, 2x-1)`` grid (float64).

    For 8-bit frames the last pass stores int16 64ths instead (:func:`_put`, read back
    through :func:`_unit`): half the bytes of float32, which compensation, bound by
    memory traffic, reads 35-40 % faster; a 64th of a grey level is far below what an
    8-bit residual codes, and the voxels themselves stay exact."""
    a = np.ascontiguousarray(ref)
    nz, ny, nx = a.shape
    mz, my, mx = (n + 2 * MARGIN for n in a.shape)
    ox = np.empty((2, nz, ny, mx), np.float32)
    _upsample_axis_kernel(a, HALF_TAPS, ox[0], ox[1])
    oy = np.empty((2, 2, nz, my, mx), np.float32)
    for px in range(2):
        _upsample_mid_kernel(ox[px], HALF_TAPS, oy[0, px], oy[1, px])
    del ox
    out = np.empty((2, 2, 2, mz, my, mx), np.int16 if a.dtype.itemsize == 1 else np.float32)
    for py in range(2):
        for px in range(2):
            src, dst = (1, nz, my * mx), (1, mz, my * mx)
            _upsample_mid_kernel(
                oy[py, px].reshape(src), HALF_TAPS,
                out[0, py, px].reshape(dst), out[1, py, px].reshape(dst),
            )  # fmt: skip
    return out


def interleave(up: np.ndarray) -> np.ndarray:
    """The half-voxel grid ``(2z-1, 2y-1, 2x-1)`` (float64 values) from :func:`upsample`'s
    parity split."""
    m = MARGIN
    nz, ny, nx = (n - 2 * m for n in up.shape[3:])
    out = np.empty((2 * nz, 2 * ny, 2 * nx), np.float64)
    for pz in range(2):
        for py in range(2):
            for px in range(2):
                out[pz::2, py::2, px::2] = up[pz, py, px, m : m + nz, m : m + ny, m : m + nx]
    return out[:-1, :-1, :-1] * (1 / 64 if up.dtype == np.int16 else 1.0)


@functools.lru_cache(maxsize=8)
def search_order(radius: int) -> np.ndarray:
    """Every whole-voxel vector within +-``radius`` (quarter units), nearest first, then
    by ``(z, y, x)``: the order exhaustive search tries them, so ties go to the shortest."""
    r = np.arange(-radius, radius + 1)
    v = np.stack(np.meshgrid(r, r, r, indexing="ij"), -1).reshape(-1, 3)
    key = (v * v).sum(1)
    idx = np.lexsort((v[:, 2], v[:, 1], v[:, 0], key))
    out = np.ascontiguousarray(4 * v[idx], dtype=np.int64)
    out.flags.writeable = False
    return out


RING = search_order(1)[1:] // 4  # the 26 unit neighbours, nearest first (whole units)

PRECISIONS = ("whole", "half", "quarter")


class Reference:
    """An anchor frame and, made when first needed, its half-voxel grid and spectrum."""

    def __init__(self, frame: np.ndarray, exact: np.ndarray | None = None) -> None:
        frame = np.asarray(frame)
        if frame.ndim != 3 or frame.dtype.kind not in "iuf":
            raise OptionError(f"expected a numeric 3-D frame, found {frame.shape} {frame.dtype}")
        self.frame = np.ascontiguousarray(frame)
        # the decoded frame itself where ``frame`` has its special voxels filled
        # (volpack.animation.specials)
        self.exact = self.frame if exact is None else exact
        self._up: np.ndarray | None = None
        self._spec: np.ndarray | None = None

    @property
    def up(self) -> np.ndarray:
        if self._up is None:
            self._up = upsample(self.frame)
        return self._up

    @property
    def spectrum(self) -> np.ndarray:
        """The padded half spectrum that whole-frame shifts read (:mod:`volpack.animation.shift`)."""
        if self._spec is None:
            self._spec = shift.spectrum(self.frame)
        return self._spec

    def grid(self, needed) -> np.ndarray:
        """The half-voxel grid if ``needed``, else an empty one of the same kind (so the
        kernels compile once per frame dtype)."""
        if needed:
            return self.up
        return _NO_GRID16 if self.frame.dtype.itemsize == 1 else _NO_GRID


_NO_GRID = np.zeros((2, 2, 2, 1, 1, 1), np.float32)
_NO_GRID16 = np.zeros((2, 2, 2, 1, 1, 1), np.int16)  # for 8-bit frames: one kernel type
_EXACT = tuple(np.dtype(t) for t in ("u1", "i1", "u2", "i2", "f4"))


def _as_reference(ref) -> Reference:
    return ref if isinstance(ref, Reference) else Reference(ref)


def estimate(
    cur: np.ndarray,
    ref: np.ndarray | Reference,
    *,
    radius: int = DEFAULT_RADIUS,
    method: str = "fast",
    precision: str = "half",
    penalty: float = 0.0,
) -> tuple[np.ndarray, np.ndarray]:
    """Best vector of every 8^3 block of ``cur`` into ``ref``.

    ``precision`` is the finest step tried (whole, half or quarter voxels). ``penalty``
    is added to a block's squared error per voxel of vector length (L1), so that where
    many vectors fit about equally well (flat or noisy regions) the short one wins and
    costs few bits. Returns ``(vectors, cost)``: ``(nbz, nby, nbx, 3)`` int64 in
    quarter-voxel units and each block's squared error plus penalty.
    """
    ref = _as_reference(ref)
    cur = _check_pair(cur, ref.frame)
    if method not in SEARCH_METHODS:
        raise OptionError(f"expected a search method in {SEARCH_METHODS}, found {method!r}")
    if precision not in PRECISIONS:
        raise OptionError(f"expected a precision in {PRECISIONS}, found {precision!r}")
    radius = int(radius)
    if not 0 <= radius <= 64:
        raise OptionError(f"expected a search range of 0..64 voxels, found {radius}")
    if not (penalty >= 0 and math.isfinite(penalty)):
        raise OptionError(f"expected a penalty >= 0, found {penalty!r}")
    grid = block_grid(cur.shape)
    vec = np.zeros((*grid, 3), np.int64)
    sse = np.zeros(grid, np.float64)
    order = search_order(radius) if method == "exhaustive" else search_order(0)
    fine = PRECISIONS.index(precision)
    up = ref.grid(fine)
    pen = 16.0 * float(penalty)  # errors of 8x values (x64), per quarter voxel (/4)
    _estimate_kernel(
        cur, ref.frame, up, radius, pen, method == "exhaustive", fine, order, RING, vec, sse
    )
    return vec, sse


def _check_pair(cur, ref):
    cur = np.asarray(cur)
    if cur.ndim != 3 or cur.shape != ref.shape:
        raise OptionError(
            f"expected two 3-D frames of one shape, found {cur.shape} and {ref.shape}"
        )
    if cur.dtype.kind not in "iuf":
        raise OptionError(f"expected numeric frames, found {cur.dtype}")
    return np.ascontiguousarray(cur)


@kernel(inline=True)
def _read(ref, up, z, y, x, vz, vy, vx):
    """8 x the reference seen from voxel (z, y, x) through the quarter-voxel vector."""
    if ((vz | vy | vx) & 3) == 0:
        nz, ny, nx = ref.shape
        return (
            8.0
            * ref[
                _clampi(z + (vz >> 2), nz), _clampi(y + (vy >> 2), ny), _clampi(x + (vx >> 2), nx)
            ]
        )
    return _sample8(up, 4 * z + vz, 4 * y + vy, 4 * x + vx)


@kernel
def _bi_sse_kernel(cur, ref0, up0, ref1, up1, v0, v1, out):
    nz, ny, nx = cur.shape
    nbz, nby, nbx = out.shape
    for bz in range(nbz):
        for by in range(nby):
            for bx in range(nbx):
                az, ay, ax = v0[bz, by, bx, 0], v0[bz, by, bx, 1], v0[bz, by, bx, 2]
                cz, cy, cx = v1[bz, by, bx, 0], v1[bz, by, bx, 1], v1[bz, by, bx, 2]
                s = 0.0
                for z in range(bz * 8, min(bz * 8 + 8, nz)):
                    for y in range(by * 8, min(by * 8 + 8, ny)):
                        for x in range(bx * 8, min(bx * 8 + 8, nx)):
                            p = _read(ref0, up0, z, y, x, az, ay, ax)
                            p += _read(ref1, up1, z, y, x, cz, cy, cx)
                            d = 8.0 * cur[z, y, x] - 0.5 * p
                            s += d * d
                out[bz, by, bx] = s / 64.0


@kernel
def _block_stats_kernel(cur, count, total, squares):
    nz, ny, nx = cur.shape
    for z in range(nz):
        for y in range(ny):
            for x in range(nx):
                v = np.float64(cur[z, y, x])
                b = (z >> 3, y >> 3, x >> 3)
                count[b] += 1.0
                total[b] += v
                squares[b] += v * v


def block_means(cur: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(count, sum, sum of squares)`` of every block's voxels."""
    grid = block_grid(cur.shape)
    out = [np.zeros(grid, np.float64) for _ in range(3)]
    _block_stats_kernel(np.ascontiguousarray(cur), *out)
    return out[0], out[1], out[2]


def choose_modes(
    cur: np.ndarray,
    prev: np.ndarray | Reference,
    nxt: np.ndarray | Reference | None,
    *,
    radius: int = DEFAULT_RADIUS,
    method: str = "fast",
    precision: str = "half",
    penalty: float = 0.0,
    mean_unit: float = 1.0,
) -> MotionField:
    """Estimate vectors into ``prev`` (and ``nxt`` for a B-frame) and pick each block's
    mode by its squared error: inter from either anchor, their mean, or intra (the
    block's mean, rounded to a multiple of ``mean_unit``) where no vector predicts it
    better."""
    opts = {"radius": radius, "method": method, "precision": precision, "penalty": penalty}
    prev = _as_reference(prev)
    fwd, e_fwd = estimate(cur, prev, **opts)
    cands = [e_fwd]
    if nxt is not None:
        nxt = _as_reference(nxt)
        bwd, e_bwd = estimate(cur, nxt, **opts)
        e_bi = np.zeros_like(e_fwd)
        fine = precision != "whole"
        _bi_sse_kernel(
            np.ascontiguousarray(cur), prev.frame, prev.grid(fine),
            nxt.frame, nxt.grid(fine), fwd, bwd, e_bi,
        )  # fmt: skip
        cands += [e_bwd, e_bi]
    else:
        bwd = np.zeros_like(fwd)
        cands += [np.full_like(e_fwd, np.inf)] * 2
    n, s, s2 = block_means(cur)
    q = np.rint(s / n / mean_unit)
    m = q * mean_unit
    cands.append(np.maximum(s2 - 2 * m * s + n * m * m, 0.0))
    # argmin keeps the first of equal errors: inter before intra
    mode = np.argmin(np.stack(cands), axis=0).astype(np.uint8)
    fwd[(mode == MODE_BWD) | (mode == MODE_INTRA)] = 0
    bwd[(mode == MODE_FWD) | (mode == MODE_INTRA)] = 0
    q[mode != MODE_INTRA] = 0
    return MotionField(mode, fwd, bwd, q * mean_unit)


# -- compensation --------------------------------------------------------------------


def _window_weight(u: int) -> float:
    """The 1-D window over its 12 positions: sin^2 rise, flat core, cos^2 fall."""
    rise = 2 * OVERLAP
    if u < rise:
        return math.sin(math.pi * (u + 0.5) / (2 * rise)) ** 2
    if u < BLOCK:
        return 1.0
    return math.cos(math.pi * (u - BLOCK + 0.5) / (2 * rise)) ** 2


@functools.lru_cache(maxsize=32)
def window_table(n: int, windowed: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """For each position along an axis of ``n`` voxels: the (up to) two blocks whose
    windows cover it and their weights, which sum to one. At the volume's faces the
    missing neighbour's share goes to the block that is there."""
    nb = -(-n // BLOCK)
    blocks = np.zeros((n, 2), np.int64)
    weights = np.zeros((n, 2), np.float64)
    for c in range(n):
        b0, o = divmod(c, BLOCK)
        blocks[c] = b0
        weights[c, 0] = 1.0
        if not windowed:
            continue
        u = o + OVERLAP
        other = b0 - 1 if u < 2 * OVERLAP else b0 + 1 if u >= BLOCK else -1
        if 0 <= other < nb:
            w0 = _window_weight(u)
            weights[c] = (w0, _window_weight(u + BLOCK if other < b0 else u - BLOCK))
            blocks[c, 1] = other
    for a in (blocks, weights):
        a.flags.writeable = False
    return blocks, weights


@kernel
def _add_block(out, ref, up, z0, z1, y0, y1, x0, x1, wz, wy, wx, vz, vy, vx):
    """``out += window * S`` over one block's window, S the anchor moved by the vector
    (a voxel, a grid sample, or the mean of the two grid samples at the ends of the box
    diagonal). The fractional part of a vector is the same for the whole block, so the
    reads are contiguous rows unless the window reaches past the stored samples. (Rows
    are taken as 1-D slices: numba vectorises those loops, not ones over 3-D indices,
    twice as fast.)"""
    nz, ny, nx = ref.shape
    m = x1 - x0
    inside = _inside(ref, up, z0, z1, y0, y1, x0, x1, vz, vy, vx)
    if ((vz | vy | vx) & 3) == 0:
        dz, dy, dx = vz >> 2, vy >> 2, vx >> 2
        for z in range(z0, z1):
            for y in range(y0, y1):
                w = wz[z - z0] * wy[y - y0]
                dst = out[z, y, x0:x1]
                if inside:
                    src = ref[z + dz, y + dy, x0 + dx : x1 + dx]
                    for i in range(m):
                        dst[i] += w * wx[i] * src[i]
                else:
                    row = ref[_clampi(z + dz, nz), _clampi(y + dy, ny)]
                    for i in range(m):
                        dst[i] += w * wx[i] * row[_clampi(x0 + i + dx, nx)]
        return
    hz, hy, hx = vz >> 1, vy >> 1, vx >> 1
    fz, fy, fx = vz & 1, vy & 1, vx & 1
    quarter = (fz | fy | fx) != 0
    u = _unit(up)
    b0, b1 = x0 + (hx >> 1) + MARGIN, x0 + ((hx + fx) >> 1) + MARGIN
    for z in range(z0, z1):
        for y in range(y0, y1):
            w = wz[z - z0] * wy[y - y0]
            dst = out[z, y, x0:x1]
            if not inside:
                for i in range(m):
                    p = 0.125 * _sample8(up, 4 * z + vz, 4 * y + vy, 4 * (x0 + i) + vx)
                    dst[i] += w * wx[i] * p
                continue
            src0 = _grid_row(up, z, y, hz, hy, hx)[b0 : b0 + m]
            if quarter:
                src1 = _grid_row(up, z, y, hz + fz, hy + fy, hx + fx)[b1 : b1 + m]
                for i in range(m):
                    dst[i] += w * wx[i] * (u * (0.5 * (np.float64(src0[i]) + np.float64(src1[i]))))
            else:
                for i in range(m):
                    dst[i] += w * wx[i] * (u * np.float64(src0[i]))


@kernel
def _add_pair(out, ref0, up0, ref1, up1, z0, z1, y0, y1, x0, x1, wz, wy, wx, a, b, exact):
    """``out += window * (S0 + S1) / 2`` over one bidirectional block's window, in one
    pass: contiguous rows when both vectors stay within the stored samples, a clamped
    read per voxel otherwise. Grid rows serve whole vectors too where the grid holds the
    anchor's voxels exactly (``exact``: 8/16-bit or float32 frames), so that a block
    mixing a whole and a sub-voxel vector reads rows as well."""
    m = x1 - x0
    sub0 = ((a[0] | a[1] | a[2]) & 3) != 0
    sub1 = ((b[0] | b[1] | b[2]) & 3) != 0
    on0 = (sub0 or exact) and _on_grid(up0, z0, z1, y0, y1, x0, x1, a[0], a[1], a[2])
    on1 = (sub1 or exact) and _on_grid(up1, z0, z1, y0, y1, x0, x1, b[0], b[1], b[2])
    if on0 and on1:
        # the two ends of each diagonal (the same row twice where there is no box)
        hz, hy, hx, gz, gy, gx = a[0] >> 1, a[1] >> 1, a[2] >> 1, b[0] >> 1, b[1] >> 1, b[2] >> 1
        fz, fy, fx, ez, ey, ex = a[0] & 1, a[1] & 1, a[2] & 1, b[0] & 1, b[1] & 1, b[2] & 1
        c0, c1 = x0 + (hx >> 1) + MARGIN, x0 + ((hx + fx) >> 1) + MARGIN
        d0, d1 = x0 + (gx >> 1) + MARGIN, x0 + ((gx + ex) >> 1) + MARGIN
        quarter = (fz | fy | fx | ez | ey | ex) != 0
        u = _unit(up0)  # both anchors' grids are of one kind (one frame dtype)
        for z in range(z0, z1):
            for y in range(y0, y1):
                w = wz[z - z0] * wy[y - y0]
                dst = out[z, y, x0:x1]
                p0 = _grid_row(up0, z, y, hz, hy, hx)[c0 : c0 + m]
                q0 = _grid_row(up1, z, y, gz, gy, gx)[d0 : d0 + m]
                if quarter:
                    p1 = _grid_row(up0, z, y, hz + fz, hy + fy, hx + fx)[c1 : c1 + m]
                    q1 = _grid_row(up1, z, y, gz + ez, gy + ey, gx + ex)[d1 : d1 + m]
                    for i in range(m):
                        s0 = u * (0.5 * (np.float64(p0[i]) + np.float64(p1[i])))
                        s1 = u * (0.5 * (np.float64(q0[i]) + np.float64(q1[i])))
                        dst[i] += w * wx[i] * (0.5 * (s0 + s1))
                else:  # the same sums: 0.5 (a + a) is a exactly
                    for i in range(m):
                        s = u * np.float64(p0[i]) + u * np.float64(q0[i])
                        dst[i] += w * wx[i] * (0.5 * s)
        return
    in0 = _inside(ref0, up0, z0, z1, y0, y1, x0, x1, a[0], a[1], a[2])
    in1 = _inside(ref1, up1, z0, z1, y0, y1, x0, x1, b[0], b[1], b[2])
    if in0 and in1 and not sub0 and not sub1:
        az, ay, ax, bz, by, bx = a[0] >> 2, a[1] >> 2, a[2] >> 2, b[0] >> 2, b[1] >> 2, b[2] >> 2
        for z in range(z0, z1):
            for y in range(y0, y1):
                w = wz[z - z0] * wy[y - y0]
                dst = out[z, y, x0:x1]
                p = ref0[z + az, y + ay, x0 + ax : x1 + ax]
                q = ref1[z + bz, y + by, x0 + bx : x1 + bx]
                for i in range(m):
                    dst[i] += w * wx[i] * (0.5 * (np.float64(p[i]) + np.float64(q[i])))
        return
    for z in range(z0, z1):
        for y in range(y0, y1):
            w = wz[z - z0] * wy[y - y0]
            for i in range(m):
                x = x0 + i
                s0 = 0.125 * _read(ref0, up0, z, y, x, a[0], a[1], a[2])
                s1 = 0.125 * _read(ref1, up1, z, y, x, b[0], b[1], b[2])
                out[z, y, x] += w * wx[i] * (0.5 * (s0 + s1))


@kernel
def _compensate_kernel(
    ref0, up0, ref1, up1, exact, mode, v0, v1, mean, zs, zw, ys, yw, xs, xw, out
):
    """Block by block: add each block's weighted prediction over its window."""
    nz, ny, nx = out.shape
    nbz, nby, nbx = mode.shape
    out[:] = 0.0
    for bz in range(nbz):
        z0, z1 = zs[bz], min(zs[bz] + zw.shape[1], nz)
        for by in range(nby):
            y0, y1 = ys[by], min(ys[by] + yw.shape[1], ny)
            for bx in range(nbx):
                x0, x1 = xs[bx], min(xs[bx] + xw.shape[1], nx)
                m = mode[bz, by, bx]
                a, b = v0[bz, by, bx], v1[bz, by, bx]
                if m == 0:
                    _add_block(
                        out, ref0, up0, z0, z1, y0, y1, x0, x1, zw[bz], yw[by], xw[bx],
                        a[0], a[1], a[2],
                    )  # fmt: skip
                elif m == 1:
                    _add_block(
                        out, ref1, up1, z0, z1, y0, y1, x0, x1, zw[bz], yw[by], xw[bx],
                        b[0], b[1], b[2],
                    )  # fmt: skip
                elif m == 2:
                    _add_pair(
                        out, ref0, up0, ref1, up1, z0, z1, y0, y1, x0, x1,
                        zw[bz], yw[by], xw[bx], a, b, exact,
                    )  # fmt: skip
                else:
                    c = mean[bz, by, bx]
                    for z in range(z0, z1):
                        for y in range(y0, y1):
                            w = zw[bz, z - z0] * yw[by, y - y0] * c
                            for x in range(x0, x1):
                                out[z, y, x] += w * xw[bx, x - x0]


@functools.lru_cache(maxsize=32)
def block_windows(n: int, windowed: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Per block along an axis of ``n`` voxels: where its window starts and its weight
    at each of the (up to 12) positions from there (:func:`window_table` regrouped)."""
    blocks, weights = window_table(n, windowed)
    nb = -(-n // BLOCK)
    reach = OVERLAP if windowed else 0
    starts = np.maximum(np.arange(nb, dtype=np.int64) * BLOCK - reach, 0)
    wts = np.zeros((nb, BLOCK + 2 * reach), np.float64)
    for c in range(n):
        for i in range(2):
            if weights[c, i] > 0:
                b = blocks[c, i]
                wts[b, c - starts[b]] += weights[c, i]
    for a in (starts, wts):
        a.flags.writeable = False
    return starts, wts


def compensate(
    field: MotionField,
    prev: np.ndarray | Reference,
    nxt: np.ndarray | Reference | None = None,
    *,
    compensation: str = "windowed",
) -> np.ndarray:
    """The prediction (float64) of a frame from its anchors and motion field."""
    if compensation not in COMPENSATIONS:
        raise OptionError(f"expected compensation in {COMPENSATIONS}, found {compensation!r}")
    prev = _as_reference(prev)
    two = nxt is not None
    nxt = _as_reference(nxt) if two else prev
    if nxt.frame.shape != prev.frame.shape or nxt.frame.dtype != prev.frame.dtype:
        raise OptionError(
            f"expected anchors of one shape and dtype, found {prev.frame.shape} "
            f"{prev.frame.dtype} and {nxt.frame.shape} {nxt.frame.dtype}"
        )
    shape = prev.frame.shape
    if field.mode.shape != block_grid(shape):
        raise OptionError(
            f"expected a motion field of {block_grid(shape)} blocks, found {field.mode.shape}"
        )
    if not two and np.isin(field.mode, (MODE_BWD, MODE_BI)).any():
        raise OptionError("a block predicts from the next anchor, but none was given")
    # the half-voxel grids are made only for an anchor that a sub-voxel vector reads
    sub0 = ((field.fwd & 3) != 0).any(-1) & np.isin(field.mode, (MODE_FWD, MODE_BI))
    sub1 = ((field.bwd & 3) != 0).any(-1) & np.isin(field.mode, (MODE_BWD, MODE_BI))
    up0, up1 = prev.grid(sub0.any()), nxt.grid(sub1.any())
    # both grids built and holding the voxels exactly (float32 holds 8/16-bit integers)
    exact = bool(sub0.any() and sub1.any()) and prev.frame.dtype in _EXACT
    tabs = [a for n in shape for a in block_windows(n, compensation == "windowed")]
    out = np.empty(shape, np.float64)
    _compensate_kernel(
        prev.frame,
        up0,
        nxt.frame,
        up1,
        exact,
        field.mode,
        field.fwd,
        field.bwd,
        field.mean,
        *tabs,
        out,
    )
    return out


# -- smoothing the prediction ------------------------------------------------------------

# Strengths k (in 64ths) of the filter [k, 64 - 2k, k] / 64 applied along each axis to a
# prediction. Content carried by a flow that also diffuses (a semi-Lagrangian simulation,
# a field resampled every step) blurs from frame to frame, which no vector predicts; on
# the advected test field a strength of 10-12 cuts the bytes of a P-frame three anchors
# on by 30 %, while sharp content (the moving head) keeps 0.
SMOOTHING = (0, 2, 4, 6, 8, 10, 12, 16)


@kernel(inline=True)
def _smooth_plane(src, c, w, tmp, dst):
    """One z-plane filtered along x into ``tmp``, then along y into ``dst``."""
    ny, nx = src.shape
    for y in range(ny):
        row, t = src[y], tmp[y]
        for x in range(nx):
            t[x] = c * row[x] + w * (row[max(x - 1, 0)] + row[min(x + 1, nx - 1)])
    for y in range(ny):
        lo, mid, hi, d = tmp[max(y - 1, 0)], tmp[y], tmp[min(y + 1, ny - 1)], dst[y]
        for x in range(nx):
            d[x] = c * mid[x] + w * (lo[x] + hi[x])


@kernel
def _smooth_kernel(src, k, out):
    """The filter along x, then y, then z in one sweep over z: each plane filtered along
    x and y once into a ring of three, from which the z pass writes ``out`` (the same
    arithmetic as three whole passes, a sixth of the memory traffic)."""
    nz, ny, nx = src.shape
    c = (64.0 - 2.0 * k) / 64.0
    w = k / 64.0
    tmp = np.empty((ny, nx), np.float64)
    ring = np.empty((3, ny, nx), np.float64)
    _smooth_plane(src[0], c, w, tmp, ring[0])
    if nz > 1:
        _smooth_plane(src[1], c, w, tmp, ring[1])
    for z in range(nz):
        if 2 <= z + 1 < nz:  # make plane z + 1 where z - 2, no longer needed, was
            _smooth_plane(src[z + 1], c, w, tmp, ring[(z + 1) % 3])
        lo = ring[max(z - 1, 0) % 3]
        mid = ring[z % 3]
        hi = ring[min(z + 1, nz - 1) % 3]
        for y in range(ny):
            a, m, b, d = lo[y], mid[y], hi[y], out[z, y]
            for x in range(nx):
                d[x] = c * m[x] + w * (a[x] + b[x])


def smooth(pred: np.ndarray, k: int) -> np.ndarray:
    """``pred`` (float64, 3-D) filtered along x, then y, then z by ``[k, 64 - 2k, k] / 64``,
    border samples repeated."""
    if k not in SMOOTHING:
        raise OptionError(f"expected a smoothing strength in {SMOOTHING}, found {k!r}")
    if k == 0:
        return pred
    a = np.ascontiguousarray(pred, np.float64)
    out = np.empty_like(a)
    _smooth_kernel(a, k, out)
    return out
