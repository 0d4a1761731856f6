"""Block motion estimation and (windowed) motion compensation between volumes.

A frame is cut into 8^3 blocks (the last block on an axis may be shorter). Each block has
a vector into a reference frame, in **quarter-voxel units**. Sub-voxel positions are
read from the reference upsampled twice along each axis (:func:`upsample`): half-voxel
samples come from an eight-tap interpolation filter (``HALF_TAPS``), which keeps
the detail that the mean of two neighbours would blur away, and quarter-voxel samples
are the mean of the two nearest samples of that half-voxel grid (as video codecs do).
Positions outside the reference take the value at its nearest border sample, in
estimation and compensation alike.

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
"""

from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np

from ._jit import kernel

BLOCK = 8
OVERLAP = 2  # 12^3 windows
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
    grid split by index parity, ``up[pz, py, px, i, j, k] = grid[2i + pz, 2j + py, 2k + px]``
    (:func:`upsample`), whose last odd entries repeat the border."""
    nz, ny, nx = up.shape[3], up.shape[4], up.shape[5]
    iz = _clampi(iz, 2 * nz)
    iy = _clampi(iy, 2 * ny)
    ix = _clampi(ix, 2 * nx)
    return up[iz & 1, iy & 1, ix & 1, iz >> 1, iy >> 1, ix >> 1]


@kernel(inline=True)
def _sample8(up, z4, y4, x4):
    """8 x the reference at the quarter-voxel position (z4, y4, x4) / 4, read from its
    half-voxel grid ``up`` (border clamped): one sample, or the mean of 2, 4 or 8."""
    z0 = z4 >> 1
    y0 = y4 >> 1
    x0 = x4 >> 1
    fz = z4 & 1
    fy = y4 & 1
    fx = x4 & 1
    s = 0.0
    for a in range(fz + 1):
        for b in range(fy + 1):
            for c in range(fx + 1):
                s += _half(up, z0 + a, y0 + b, x0 + c)
    return s * (8 >> (fz + fy + fx))


@kernel(inline=True)
def _on_grid(up, z0, z1, y0, y1, x0, x1, vz, vy, vx):
    """Whether every half-voxel grid sample the box ``[z0, z1) x [y0, y1) x [x0, x1)``
    reads through the sub-voxel vector is stored in ``up`` (no clamping needed)."""
    uz, uy, ux = 2 * up.shape[3], 2 * up.shape[4], 2 * up.shape[5]
    return (
        2 * z0 + (vz >> 1) >= 0
        and 2 * (z1 - 1) + (vz >> 1) + (vz & 1) < uz
        and 2 * y0 + (vy >> 1) >= 0
        and 2 * (y1 - 1) + (vy >> 1) + (vy & 1) < uy
        and 2 * x0 + (vx >> 1) >= 0
        and 2 * (x1 - 1) + (vx >> 1) + (vx & 1) < ux
    )


@kernel
def _block_sse(cur, ref, up, z0, y0, x0, vz, vy, vx, limit):
    """Squared error (in units of 1/64) of the block at (z0, y0, x0) against the
    reference moved by the quarter-voxel vector; stops early once past ``limit``."""
    nz, ny, nx = cur.shape
    ez = min(z0 + 8, nz)
    ey = min(y0 + 8, ny)
    ex = min(x0 + 8, nx)
    s = 0.0
    if ((vz | vy | vx) & 3) == 0:
        dz = vz >> 2
        dy = vy >> 2
        dx = vx >> 2
        inside = (
            z0 + dz >= 0
            and ez + dz <= nz
            and y0 + dy >= 0
            and ey + dy <= ny
            and x0 + dx >= 0
            and ex + dx <= nx
        )
        for z in range(z0, ez):
            for y in range(y0, ey):
                if inside:
                    for x in range(x0, ex):
                        d = np.float64(cur[z, y, x]) - np.float64(ref[z + dz, y + dy, x + dx])
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
    inside = _on_grid(up, z0, ez, y0, ey, x0, ex, vz, vy, vx)
    scale = np.float64(8 >> (fz + fy + fx))
    for z in range(z0, ez):
        for y in range(y0, ey):
            for x in range(x0, ex):
                if inside:
                    p = 0.0
                    for a in range(fz + 1):
                        za = z + ((hz + a) >> 1)
                        for b in range(fy + 1):
                            yb = y + ((hy + b) >> 1)
                            for c in range(fx + 1):
                                p += up[(hz + a) & 1, (hy + b) & 1, (hx + c) & 1, za, yb,
                                        x + ((hx + c) >> 1)]  # fmt: skip
                    p *= scale
                else:
                    p = _sample8(up, 4 * z + vz, 4 * y + vy, 4 * x + vx)
                d = 8.0 * cur[z, y, x] - p
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
    """Along the last axis: ``even`` copies ``src``, ``odd`` interpolates halfway to the
    next sample (border clamped); its last entry repeats the border sample."""
    n = src.shape[-1]
    nt = taps.size
    h = nt // 2
    for i in range(src.shape[0]):
        for j in range(src.shape[1]):
            row = src[i, j]
            e = even[i, j]
            o = odd[i, j]
            for x in range(n):
                e[x] = row[x]
            for x in range(n - 1):
                acc = 0.0
                if x + 1 - h >= 0 and x + nt - h < n:
                    for k in range(nt):
                        acc += taps[k] * row[x + 1 - h + k]
                else:
                    for k in range(nt):
                        acc += taps[k] * row[_clampi(x + 1 - h + k, n)]
                o[x] = acc
            o[n - 1] = row[n - 1]


@kernel
def _upsample_mid_kernel(src, taps, even, odd):
    """As :func:`_upsample_axis_kernel`, along the middle axis (rows stay contiguous)."""
    n = src.shape[1]
    nt = taps.size
    h = nt // 2
    acc = np.empty(src.shape[2], np.float64)
    for i in range(src.shape[0]):
        for y in range(n):
            even[i, y, :] = src[i, y, :]
        for y in range(n - 1):
            acc[:] = 0.0
            for k in range(nt):
                row = src[i, _clampi(y + 1 - h + k, n)]
                t = taps[k]
                for x in range(acc.size):
                    acc[x] += t * row[x]
            dst = odd[i, y]
            for x in range(acc.size):
                dst[x] = acc[x]
        odd[i, n - 1, :] = src[i, n - 1, :]


def upsample(ref: np.ndarray) -> np.ndarray:
    """The reference on its half-voxel grid, float32 (half the memory traffic of float64;
    each pass sums in float64), split by index parity: ``out[pz, py, px, i, j, k]`` is grid
    sample ``(2i + pz, 2j + py, 2k + px)``, so that a window moved by a sub-voxel vector
    reads contiguous rows. Even grid indices are the voxels, odd ones eight-tap
    interpolations between them; the odd index past the last voxel repeats it (the
    grid's border clamp). :func:`interleave` gives the ``(2z-1, 2y-1, 2x-1)`` grid."""
    a = np.ascontiguousarray(ref)
    nz, ny, nx = a.shape
    ox = np.empty((2, nz, ny, nx), np.float32)
    _upsample_axis_kernel(a, HALF_TAPS, ox[0], ox[1])
    oy = np.empty((2, 2, nz, ny, nx), np.float32)
    for px in range(2):
        _upsample_mid_kernel(ox[px], HALF_TAPS, oy[0, px], oy[1, px])
    del ox
    out = np.empty((2, 2, 2, nz, ny, nx), np.float32)
    for py in range(2):
        for px in range(2):
            flat = (1, nz, ny * nx)
            _upsample_mid_kernel(
                oy[py, px].reshape(flat), HALF_TAPS,
                out[0, py, px].reshape(flat), out[1, py, px].reshape(flat),
            )  # fmt: skip
    return out


def interleave(up: np.ndarray) -> np.ndarray:
    """The half-voxel grid ``(2z-1, 2y-1, 2x-1)`` from :func:`upsample`'s parity split."""
    nz, ny, nx = up.shape[3:]
    out = np.empty((2 * nz, 2 * ny, 2 * nx), up.dtype)
    for pz in range(2):
        for py in range(2):
            for px in range(2):
                out[pz::2, py::2, px::2] = up[pz, py, px]
    return out[:-1, :-1, :-1]


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
    """An anchor frame and, made when first needed, its half-voxel grid."""

    def __init__(self, frame: np.ndarray) -> None:
        frame = np.asarray(frame)
        if frame.ndim != 3 or frame.dtype.kind not in "iuf":
            raise ValueError(f"expected a numeric 3-D frame, found {frame.shape} {frame.dtype}")
        self.frame = np.ascontiguousarray(frame)
        self._up: np.ndarray | None = None

    @property
    def up(self) -> np.ndarray:
        if self._up is None:
            self._up = upsample(self.frame)
        return self._up


_NO_GRID = np.zeros((2, 2, 2, 1, 1, 1), np.float32)


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
        raise ValueError(f"expected a search method in {SEARCH_METHODS}, found {method!r}")
    if precision not in PRECISIONS:
        raise ValueError(f"expected a precision in {PRECISIONS}, found {precision!r}")
    radius = int(radius)
    if not 0 <= radius <= 64:
        raise ValueError(f"expected a search range of 0..64 voxels, found {radius}")
    if not (penalty >= 0 and math.isfinite(penalty)):
        raise ValueError(f"expected a penalty >= 0, found {penalty!r}")
    grid = block_grid(cur.shape)
    vec = np.zeros((*grid, 3), np.int64)
    sse = np.zeros(grid, np.float64)
    order = search_order(radius) if method == "exhaustive" else search_order(0)
    fine = PRECISIONS.index(precision)
    up = ref.up if fine else _NO_GRID
    pen = 16.0 * float(penalty)  # errors of 8x values (x64), per quarter voxel (/4)
    _estimate_kernel(
        cur, ref.frame, up, radius, pen, method == "exhaustive", fine, order, RING, vec, sse
    )
    return vec, sse


def _check_pair(cur, ref):
    cur = np.asarray(cur)
    if cur.ndim != 3 or cur.shape != ref.shape:
        raise ValueError(f"expected two 3-D frames of one shape, found {cur.shape} and {ref.shape}")
    if cur.dtype.kind not in "iuf":
        raise ValueError(f"expected numeric frames, found {cur.dtype}")
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
            np.ascontiguousarray(cur), prev.frame, prev.up if fine else _NO_GRID,
            nxt.frame, nxt.up if fine else _NO_GRID, fwd, bwd, e_bi,
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
def _add_block(out, ref, up, z0, z1, y0, y1, x0, x1, wz, wy, wx, vz, vy, vx, share, row):
    """``out += share * window * reference moved by the vector`` over one block's window;
    the fractional part of a vector is the same for the whole block, so the reads are
    direct unless the window reaches past the reference."""
    nz, ny, nx = ref.shape
    if ((vz | vy | vx) & 3) == 0:
        dz, dy, dx = vz >> 2, vy >> 2, vx >> 2
        inside = (
            z0 + dz >= 0
            and z1 + dz <= nz
            and y0 + dy >= 0
            and y1 + dy <= ny
            and x0 + dx >= 0
            and x1 + dx <= nx
        )
        for z in range(z0, z1):
            for y in range(y0, y1):
                w = share * wz[z - z0] * wy[y - y0]
                if inside:
                    for x in range(x0, x1):
                        out[z, y, x] += w * wx[x - x0] * ref[z + dz, y + dy, x + dx]
                else:
                    zi = _clampi(z + dz, nz)
                    yi = _clampi(y + dy, ny)
                    for x in range(x0, x1):
                        out[z, y, x] += w * wx[x - x0] * ref[zi, yi, _clampi(x + dx, nx)]
        return
    hz, hy, hx = vz >> 1, vy >> 1, vx >> 1
    fz, fy, fx = vz & 1, vy & 1, vx & 1
    inside = _on_grid(up, z0, z1, y0, y1, x0, x1, vz, vy, vx)
    mean = 1.0 / (1 << (fz + fy + fx))
    for z in range(z0, z1):
        for y in range(y0, y1):
            w = share * wz[z - z0] * wy[y - y0]
            if inside:  # the 1, 2, 4 or 8 grid samples added row by row, each contiguous
                for x in range(x0, x1):
                    row[x - x0] = 0.0
                for a in range(fz + 1):
                    za = z + ((hz + a) >> 1)
                    for b in range(fy + 1):
                        yb = y + ((hy + b) >> 1)
                        for c in range(fx + 1):
                            src = up[(hz + a) & 1, (hy + b) & 1, (hx + c) & 1, za, yb]
                            base = (hx + c) >> 1
                            for x in range(x0, x1):
                                row[x - x0] += src[x + base]
                for x in range(x0, x1):
                    out[z, y, x] += w * wx[x - x0] * (row[x - x0] * mean)
            else:
                for x in range(x0, x1):
                    p = 0.125 * _sample8(up, 4 * z + vz, 4 * y + vy, 4 * x + vx)
                    out[z, y, x] += w * wx[x - x0] * p


@kernel
def _compensate_kernel(ref0, up0, ref1, up1, mode, v0, v1, mean, zs, zw, ys, yw, xs, xw, out):
    """Block by block: add each block's weighted prediction over its window."""
    nz, ny, nx = out.shape
    nbz, nby, nbx = mode.shape
    out[:] = 0.0
    row = np.empty(xw.shape[1], np.float64)  # one row of grid sums
    for bz in range(nbz):
        z0, z1 = zs[bz], min(zs[bz] + zw.shape[1], nz)
        for by in range(nby):
            y0, y1 = ys[by], min(ys[by] + yw.shape[1], ny)
            for bx in range(nbx):
                x0, x1 = xs[bx], min(xs[bx] + xw.shape[1], nx)
                m = mode[bz, by, bx]
                if m == 3:
                    c = mean[bz, by, bx]
                    for z in range(z0, z1):
                        for y in range(y0, y1):
                            w = zw[bz, z - z0] * yw[by, y - y0] * c
                            for x in range(x0, x1):
                                out[z, y, x] += w * xw[bx, x - x0]
                    continue
                share = 0.5 if m == 2 else 1.0
                if m != 1:
                    _add_block(
                        out, ref0, up0, z0, z1, y0, y1, x0, x1, zw[bz], yw[by], xw[bx],
                        v0[bz, by, bx, 0], v0[bz, by, bx, 1], v0[bz, by, bx, 2], share, row,
                    )  # fmt: skip
                if m != 0:
                    _add_block(
                        out, ref1, up1, z0, z1, y0, y1, x0, x1, zw[bz], yw[by], xw[bx],
                        v1[bz, by, bx, 0], v1[bz, by, bx, 1], v1[bz, by, bx, 2], share, row,
                    )  # fmt: skip


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
        raise ValueError(f"expected compensation in {COMPENSATIONS}, found {compensation!r}")
    prev = _as_reference(prev)
    two = nxt is not None
    nxt = _as_reference(nxt) if two else prev
    if nxt.frame.shape != prev.frame.shape or nxt.frame.dtype != prev.frame.dtype:
        raise ValueError(
            f"expected anchors of one shape and dtype, found {prev.frame.shape} "
            f"{prev.frame.dtype} and {nxt.frame.shape} {nxt.frame.dtype}"
        )
    shape = prev.frame.shape
    if field.mode.shape != block_grid(shape):
        raise ValueError(
            f"expected a motion field of {block_grid(shape)} blocks, found {field.mode.shape}"
        )
    if not two and np.isin(field.mode, (MODE_BWD, MODE_BI)).any():
        raise ValueError("a block predicts from the next anchor, but none was given")
    # the half-voxel grids are made only for an anchor that a sub-voxel vector reads
    sub0 = ((field.fwd & 3) != 0).any(-1) & np.isin(field.mode, (MODE_FWD, MODE_BI))
    sub1 = ((field.bwd & 3) != 0).any(-1) & np.isin(field.mode, (MODE_BWD, MODE_BI))
    up0 = prev.up if sub0.any() else _NO_GRID
    up1 = nxt.up if sub1.any() else _NO_GRID
    tabs = [a for n in shape for a in block_windows(n, compensation == "windowed")]
    out = np.empty(shape, np.float64)
    _compensate_kernel(
        prev.frame, up0, nxt.frame, up1, field.mode, field.fwd, field.bwd, field.mean, *tabs, out
    )
    return out


# -- smoothing the prediction ------------------------------------------------------------

# Strengths k (in 64ths) of the filter [k, 64 - 2k, k] / 64 applied along each axis to a
# prediction. Content carried by a flow that also diffuses (a semi-Lagrangian simulation,
# a field resampled every step) blurs from frame to frame, which no vector predicts; on
# the advected test field a strength of 10-12 cuts the bytes of a P-frame three anchors
# on by 30 %, while sharp content (the moving head) keeps 0.
SMOOTHING = (0, 2, 4, 6, 8, 10, 12, 16)


@kernel
def _smooth_pass_kernel(src, axis, k, out):
    """One axis of the filter, border samples repeated: ``out = c x + s (left + right)``."""
    nz, ny, nx = src.shape
    c = (64.0 - 2.0 * k) / 64.0
    w = k / 64.0
    for z in range(nz):
        for y in range(ny):
            for x in range(nx):
                if axis == 0:
                    a = src[max(z - 1, 0), y, x]
                    b = src[min(z + 1, nz - 1), y, x]
                elif axis == 1:
                    a = src[z, max(y - 1, 0), x]
                    b = src[z, min(y + 1, ny - 1), x]
                else:
                    a = src[z, y, max(x - 1, 0)]
                    b = src[z, y, min(x + 1, nx - 1)]
                out[z, y, x] = c * src[z, y, x] + w * (a + b)


def smooth(pred: np.ndarray, k: int) -> np.ndarray:
    """``pred`` (float64, 3-D) filtered along x, then y, then z by ``[k, 64 - 2k, k] / 64``."""
    if k not in SMOOTHING:
        raise ValueError(f"expected a smoothing strength in {SMOOTHING}, found {k!r}")
    if k == 0:
        return pred
    a = np.ascontiguousarray(pred, np.float64)
    b, c = np.empty_like(a), np.empty_like(a)
    _smooth_pass_kernel(a, 2, k, b)
    _smooth_pass_kernel(b, 1, k, c)
    _smooth_pass_kernel(c, 0, k, b)
    return b
