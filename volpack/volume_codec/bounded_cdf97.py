"""The bounded codec's float wavelet path: CDF 9/7 coefficients quantised with one step,
then the voxels that strayed past the bound moved back by whole bins (``formats/lossy-1.md``).

SPERR's recipe, measured on the climate and CFD fields of ``scripts/bench_lossy.py``: a
float wavelet spreads a coefficient's quantisation error thinly over many voxels, so a
step of 1.5 to 3 times the bound leaves only a small share of voxels past it, and those
cost less to correct than a finer step costs everywhere. Two choices are the encoder's,
made per brick and stored:

* the levels per axis: each axis is transformed fully or not at all. A field whose
  samples along one axis are nearly independent (daily weather maps stacked in time,
  thin slabs) codes shorter without transforming that axis: 104.9 against 60.9:1 on the
  500 hPa height at 1e-2 of its range;
* the decomposition: the Mallat (dyadic) layout or the separable one of
  :mod:`volpack.wavelet.packet` (each axis transformed on its own), by coded size at
  the first step. Fields smooth along some axes and rough along others code shorter
  separable: 26 % on the CAM zonal wind at 1e-2 of its range, 14 % on the cryo-EM map.
  Its levels per axis may be partial, chosen by the cost estimate axis by axis: one or
  two levels across latitude and levels code 6-11 % shorter than all or none on the
  climate fields at 1e-3 and 1e-4 of the range (cam_t, climate_t, cam_u, hgt_500);
* the step, among :data:`STEP_FACTORS` times the bound, by coded size: from 2E the
  search walks towards the shorter neighbour until the size grows again (three or four
  codings; the size is nearly unimodal in the step), then tries halfway to the
  neighbours either side of the shortest.

The corrections are a list of (voxel, whole bins of ``2E``) coded as a gap list or as a
sparse field (:mod:`volpack.volume_codec.bin_field`), whichever is shorter; a voxel
that rounding to the output dtype still leaves past the bound goes to the bounded
codec's exact corrections.
"""

from __future__ import annotations

import itertools
import math
import struct

import numpy as np

from ..errors import FormatError
from .floatcast import scale_in_place

STEP_FACTORS = (1.25, 1.5, 2.0, 2.5, 3.0, 4.0)
FIRST_FACTOR = 2  # index of 2E, where the step search starts
# The levels are chosen at this step factor, by a cost estimate of the quantised
# coefficients (bits of the magnitudes plus two per significant coefficient).
PROBE_FACTOR = 2.0
# Under the default effort (given the shortest other coding, session 29): the path's
# codings were at least 1.15 times its cost estimate's bytes on the 52 cells of the float
# corpus (tgv_u at 1e-5 of the range; 1.4-2.2 at 1e-2): none is made where this times
# the estimate is longer than the shortest. And the step search, which shortened its
# first step's coding by at most 12.3 % there (hgt_500 at 1e-2), stops after that step
# where it is this much longer than the shortest (results/lossy/enc29).
COST_FLOOR = 1.1
GIVE_UP = 1.2
# Quantised magnitudes stay below 2^50 (exact in float64 and int64); a brick whose
# coefficients would pass it is left to the other paths.
MAX_Q = 2.0**50
ORDERS = ("dfs", "line", "rows", "separable")
# The scans the encoder tries (at the first step; later steps keep the shortest): "rows"
# codes 2-6 % shorter than "line" at 1e-2 of the range and decodes 2-4x faster there
# (zero rows skipped); at tight bounds they are level. "dfs" is still decoded.
# "separable" is the rows scan over the separable decomposition (volpack.wavelet.packet).
TRIED_ORDERS = (1, 2, 3)
SEPARABLE = 3
HEADER = struct.Struct("<3BBd")  # levels z, y, x; scan order; step
# Outlier codings: a gap list, the dense field through the coefficient coder (decoded,
# no longer made: the bin field codes 2-20 % shorter and decodes 4-5x faster), the
# bin field.
OUTLIER_LIST, OUTLIER_FIELD, OUTLIER_BINS = 0, 1, 2


def _magnitudes(c: np.ndarray, step: float) -> np.ndarray:
    """``floor(|c| / step + 0.5)`` in one new float64 array (the same operations)."""
    q = np.abs(c)
    q /= step
    q += 0.5
    return np.floor(q, out=q)


def _quantize(c: np.ndarray, step: float) -> np.ndarray:
    q = _magnitudes(c, step)
    return np.copysign(q, c, out=q).astype(np.int64)


def _cost(c: np.ndarray, step: float) -> float:
    q = _magnitudes(c, step)
    nz = q[q > 0]
    return float(np.log2(nz).sum() + 2 * nz.size)


def _level_choices(full: tuple[int, int, int]):
    axes = [(0, f) if f else (0,) for f in full]
    return [lv for lv in itertools.product(*axes) if any(lv)]


def _refine_levels(g, full, probe, best):
    """Separable layout: from the best all-or-nothing levels, each axis's level count
    in turn over ``0..full`` by the cost estimate, until no axis changes.

    The 1-D transforms along different axes commute (up to rounding, which the estimate
    does not mind), so the other two axes are transformed once per axis and only the
    varied one per candidate; the kept levels' coefficients are then made in the
    decoder's order."""
    from ..wavelet import cdf97, packet

    seen = {best[1]}
    lv0, moved = best[1], True
    while moved:
        moved = False
        for axis in range(3):
            base = None
            for v in range(full[axis] + 1):
                lv = best[1][:axis] + (v,) + best[1][axis + 1 :]
                if lv in seen or sum(n > 0 for n in lv) < 2:
                    continue
                seen.add(lv)
                if base is None:
                    base = packet.forward(g, lv[:axis] + (0,) + lv[axis + 1 :])
                c = cdf97.forward(base, tuple(v if a == axis else 0 for a in range(3)))
                cost = _cost(c, probe)
                if cost < best[0]:
                    best, moved = (cost, lv, None), True
    if best[1] == lv0:
        return best
    return best[0], best[1], packet.forward(g, best[1])


def plan(g: np.ndarray, max_error: float, max_levels: int | None):
    """The layouts :func:`encode` codes the float64 brick ``g`` in, and their least cost
    estimate (bits at the probe step); None where the path does not apply."""
    from ..wavelet import dwt3

    full = dwt3.levels_for_shape(g.shape, max_levels)
    choices = _level_choices(full)
    if not choices or not np.isfinite(g).all():
        return None
    probe = PROBE_FACTOR * max_error
    layouts = {}  # separable or not -> (levels, coefficients), the levels by cost estimate
    least = math.inf
    for sep in (False, True):
        best = None  # (cost, levels, coefficients): one candidate's array held at a time
        for lv in choices:
            if sep and sum(v > 0 for v in lv) < 2:
                continue  # one axis transformed: the two layouts are the same
            c = _transform(sep).forward(g, lv)
            cost = _cost(c, probe)
            if best is None or cost < best[0]:
                best = (cost, lv, c)
        if best is not None and sep:
            best = _refine_levels(g, full, probe, best)
        if best is not None:
            layouts[sep] = best[1:]
            least = min(least, best[0])
    return layouts, least


def encode(
    g: np.ndarray,
    max_error: float,
    coder: str,
    max_levels: int | None,
    size_of,
    shortest=None,
    planned=None,
):
    """Code the float64 brick ``g`` (masked voxels already filled in).

    ``size_of(inner, reconstruction)`` gives the payload size of a coding (corrections
    included; the reconstruction is the caller's to keep or change); the step search
    walks on it. Returns the inner sections of the steps tried (the shortest scan of
    each), or ``[]`` when the path does not apply (coefficients too large for the step).
    With ``shortest`` (the bytes of the shortest other coding) nothing is coded where
    the cost estimate says the path cannot come near it (COST_FLOOR), and the search
    stops after the first step where that step's coding is GIVE_UP times longer. ``planned``: :func:`plan`'s, if made.
    """
    from ..entropy import CODERS

    planned = plan(g, max_error, max_levels) if planned is None else planned
    if planned is None:
        return []
    layouts, least = planned
    if shortest is not None and COST_FLOOR * least / 8 > shortest:
        return []
    peak = max(float(np.abs(c).max(initial=0.0)) for _, c in layouts.values())

    orders = list(TRIED_ORDERS)  # all at the first step, then the shortest

    def coding(f):
        step = f * max_error
        if not (step > 0 and math.isfinite(step)) or peak / step >= MAX_Q:
            return None
        made = None
        for k in orders:
            sep = k == SEPARABLE
            if sep not in layouts:
                continue
            lv, c = layouts[sep]
            q = _quantize(c, step)
            rec = _transform(sep).inverse(q * step, lv, overwrite=True)
            body = CODERS[coder].encode(q, _scan(g.shape, lv, k))
            del q  # (the peak: a brick-sized array fewer while the caller checks)
            inner = HEADER.pack(*lv, k, step) + body
            size = size_of(inner, rec)
            del rec  # the caller has its candidate: only the bytes and size are kept
            if made is None or size < made[1]:
                made, kept = (inner, size), k
        orders[:] = [kept]
        return made

    tried = {}

    def size(f):
        if f not in tried:
            tried[f] = coding(f)
        return math.inf if tried[f] is None else tried[f][1]

    fs, i = STEP_FACTORS, FIRST_FACTOR
    if shortest is not None and size(fs[i]) > GIVE_UP * shortest:
        return [t[0] for t in tried.values() if t is not None]
    way = 1 if size(fs[i + 1]) < size(fs[i]) else -1
    while 0 <= i + way < len(fs) and size(fs[i + way]) < size(fs[i]):
        i += way
    # Then halfway to each neighbour: the size is flat near its minimum, not level
    # (cam_t at 1e-2 of its range: 1.5 % shorter at 1.75E than at 1.5E or 2E).
    for j in (i - 1, i + 1):
        if 0 <= j < len(fs):
            size((fs[i] + fs[j]) / 2)
    return [t[0] for t in tried.values() if t is not None]


def decode(inner: bytes | memoryview, shape: tuple[int, int, int], coder: str, max_levels):
    """The reconstruction (float64) of an inner section made by :func:`encode`."""
    from ..entropy import CODERS
    from ..wavelet import dwt3

    inner = memoryview(inner)
    if len(inner) < HEADER.size:
        raise FormatError("cdf97 brick payload: the header is cut short")
    *lv, k, step = HEADER.unpack_from(inner)
    if k >= len(ORDERS) or not (step > 0 and math.isfinite(step)):
        raise FormatError(f"cdf97 brick payload: bad order {k} or step {step!r}")
    full = dwt3.levels_for_shape(shape, max_levels)
    partial = k == SEPARABLE  # any level count per axis; else none or all
    if any(not (0 <= v <= f if partial else v in (0, f)) for v, f in zip(lv, full)) or (
        sum(v > 0 for v in lv) < (2 if partial else 1)
    ):
        raise FormatError(f"cdf97 brick payload: levels {tuple(lv)} do not fit {full}")
    lv = tuple(lv)
    q = np.empty(shape, np.int64)
    CODERS[coder].decode(bytes(inner[HEADER.size :]), _scan(shape, lv, k), q)
    return _transform(k == SEPARABLE).inverse(scale_in_place(q, step), lv, overwrite=True)


def _transform(separable: bool):
    """The module whose ``forward`` / ``inverse`` make the decomposition."""
    from ..wavelet import cdf97, packet

    return packet if separable else cdf97


def _scan(shape, lv, k: int):
    from ..wavelet import packet, sigmap

    if k == SEPARABLE:
        return packet.scan(tuple(shape), tuple(lv))
    return sigmap.scan(tuple(shape), tuple(lv), ORDERS[k])


def add_bins(rec: np.ndarray, idx: np.ndarray, r: np.ndarray, bin_width: float) -> None:
    """``rec.flat[idx] += r * bin_width`` in double precision: the decoder's last step."""
    flat = rec.reshape(-1)
    flat[idx] += r * bin_width


def pack_outliers(idx: np.ndarray, r: np.ndarray, shape) -> bytes:
    """The bins ``r`` (int, nonzero) to add at the flat voxels ``idx`` (increasing): a gap
    list (zstd) or a bin field, whichever is shorter."""
    from ..format.deflate import deflate
    from . import bin_field

    field = np.zeros(math.prod(shape), np.int64)
    field[idx] = r
    best = bytes([OUTLIER_BINS]) + bin_field.encode(field.reshape(shape))
    if idx.size * 6 < len(best):  # sparse enough that a list may pay
        gaps = np.diff(idx, prepend=-1) - 1
        listed = deflate(gaps.astype("<u4").tobytes() + r.astype("<i4").tobytes())
        if len(listed) + 1 < len(best):
            best = bytes([OUTLIER_LIST]) + listed
    return best


def apply_outliers(body: bytes | memoryview, rec: np.ndarray, bin_width: float, coder: str):
    """Add the bins of :func:`pack_outliers` to ``rec`` (float64, C order) in place."""
    from ..entropy import CODERS
    from ..format.deflate import inflate
    from ..wavelet import sigmap
    from . import bin_field

    body = memoryview(body)
    n = rec.size
    if len(body) < 1 or body[0] not in (OUTLIER_LIST, OUTLIER_FIELD, OUTLIER_BINS):
        raise FormatError("cdf97 brick payload: unknown outlier coding")
    if body[0] == OUTLIER_BINS:
        bin_field.add_decoded(body[1:], rec, bin_width)
        return
    if body[0] == OUTLIER_FIELD:
        field = np.empty(rec.shape, np.int64)
        CODERS[coder].decode(bytes(body[1:]), sigmap.scan(rec.shape, (0, 0, 0), "line"), field)
        idx = np.flatnonzero(field)
        r = field.reshape(-1)[idx]
    else:
        raw = inflate(body[1:], 8 * n, "cdf97 brick outliers")
        k = len(raw) // 8
        if 8 * k != len(raw):
            raise FormatError("cdf97 brick payload: the outlier list has a ragged length")
        gaps = np.frombuffer(raw[: 4 * k], "<u4").astype(np.int64)
        idx = np.cumsum(gaps + 1) - 1
        if k and idx[-1] >= n:
            raise FormatError("cdf97 brick payload: an outlier points outside the brick")
        r = np.frombuffer(raw[4 * k :], "<i4").astype(np.int64)
    add_bins(rec, idx, r, bin_width)
