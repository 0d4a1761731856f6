"""Choosing a lossy codec for a volume: its value range, and the error bound that meets a
PSNR or ratio target.

A target is met by searching the error bound of :class:`volpack.volume_codec.lossy.BoundedCodec`:
PSNR falls and ratio rises as the bound grows (not strictly: the bins of a quantiser can
split a noise floor unevenly), so the search brackets the target geometrically, scoring
each bound on an evenly spread sample of bricks first and on the whole volume at the
end. It is deterministic: the same volume and target give the same bound.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from typing import Any

import numpy as np

from ..errors import OptionError
from ..metrics import psnr_from_sse
from ..parallel import ordered_map
from ..volume import Volume
from . import bricks
from .floatwave import FLOAT_WAVELETS, FloatWaveletCodec
from .lossy import EFFORTS, RD_WEIGHT, BoundedCodec, CoefCodec
from .protocol import check_choice
from .specials import sentinel, special_voxels

log = logging.getLogger(__name__)

PSNR_TOL = 0.5  # dB
RATIO_TOL = 0.05  # relative
# A ratio target is the file's (what `ls` shows), so the search counts the container too:
# about 220 bytes around one brick (header, summary with the search's record, index,
# preamble and footer) and 18 more a brick; measured 213-228 B on 1-brick --ratio files.
CONTAINER_BYTES = 220
BRICK_BYTES = 18
SAMPLE_BRICKS = 48
MAX_STEPS = 14
# Volumes below this are not tried with the Tucker codec (64^3 fields measured; in small
# bricks the factor matrices and their search cost more than they can save).
TUCKER_MIN_VOXELS = 1 << 16


# A float volume's value that looks like an undeclared fill (:func:`.specials.sentinel`)
# and stretches the range at least this many times over the other voxels' span makes a
# ``rel_error`` of that range a bound the other voxels barely feel (Hurricane Isabel's 1e35
# over land: 1e-3 of the range is 1e32, a temperature field comes back as one value;
# session 37, results/kinds37): the encoder says so, and how to keep the value out.
FILL_RANGE_WARN = 10.0
FILL_SAMPLE = 1 << 22  # voxels looked at for the fill value (every k-th: a large memory-
# mapped volume is not read whole; its range is then read slab by slab, as value_range's)


def fill_sets_range(data: np.ndarray, lo: float, hi: float) -> tuple[float, float, float, float] | None:
    """``(value, share of the voxels, lo, hi of the others)`` when a value of the float
    volume ``data`` (valid range ``lo..hi``) looks like an undeclared fill value and
    widens that range :data:`FILL_RANGE_WARN` times or more, else None. The value and its
    share come from every k-th voxel (all of them up to :data:`FILL_SAMPLE`)."""
    flat = np.asarray(data).reshape(-1)
    sample = np.ascontiguousarray(flat[:: max(1, flat.size // FILL_SAMPLE)])
    value = sentinel(sample, special_voxels(sample, None))
    if value is None:
        return None
    a, b = value_range(data, value)
    if not (hi - lo) >= FILL_RANGE_WARN * (b - a):
        return None
    return value, float(np.count_nonzero(sample == value)) / sample.size, a, b


def _warn_fill_range(data: np.ndarray, lo: float, hi: float, setting: str) -> None:
    """Log, after ``setting`` (what a relative bound or a PSNR target means on the range
    ``lo..hi``), the value :func:`fill_sets_range` finds setting that range, and how to
    keep it out; nothing where there is none."""
    found = fill_sets_range(data, lo, hi)
    if found is not None:
        v, share, a, b = found
        log.warning(
            "%s: the value %g on %.3g %% of the voxels sets that range (the others span "
            "%g..%g); if it marks missing data, give it as the fill value (--fill-value %g) "
            "to keep it out of the range and store it exactly",
            setting, v, 100 * share, a, b, v,
        )  # fmt: skip


def absolute_bound(what: str, target: float, rng: float) -> float:
    """The error bound in value units: ``max_error`` as it is, ``rel_error`` times the
    value range ``rng``."""
    return float(target) * (rng if what == "rel_error" else 1.0)


def exact_bound(
    vol, asked: dict[str, float], fill_value: float | None, effort: str
) -> tuple[bool, tuple[float, float] | None]:
    """Whether ``asked`` is an error bound under 1 on integer voxels (``max_error``, or
    ``rel_error`` of the value range), which no coding but the exact one meets: the
    lossless codec then codes the volume (with ``effort`` 'default' or 'max'), as it would
    without the bound, rather than the bounded codec's quantised voxels at its faster
    predictive version (3 % longer on an 8-bit scan). Also the value range when it was
    read (for :func:`plan`, so that the volume is scanned once). A ``rel_error`` of a
    float volume whose valid voxels are all one value is a bound of 0: coded exactly too
    (it was refused as lossless coding asked for by a lossy setting)."""
    if vol.dtype.kind not in "iuf" or effort == "fast" or len(asked) != 1:
        return False, None
    ((what, target),) = asked.items()
    if what not in ("max_error", "rel_error") or (vol.dtype.kind == "f" and what != "rel_error"):
        return False, None
    try:
        float(target)
    except (TypeError, ValueError):
        return False, None
    known = value_range(vol.data, fill_value) if what == "rel_error" else None
    if vol.dtype.kind == "f":
        return bool(known[0] == known[1] and float(target) > 0), known
    e = absolute_bound(what, target, known[1] - known[0] if known else 1.0)
    return math.isfinite(e) and 0 <= e < 1, known


def value_range(data: np.ndarray, fill_value: float | None) -> tuple[float, float]:
    """Smallest and largest valid voxel (finite, not the fill value), slab by slab so a
    memory-mapped volume is never loaded whole."""
    lo, hi = math.inf, -math.inf
    flat = data.reshape(-1, *data.shape[-2:])
    for i in range(0, flat.shape[0], 16):
        slab = np.asarray(flat[i : i + 16])
        ok = ~special_voxels(slab, fill_value)
        if ok.any():
            v = slab[ok]
            lo, hi = min(lo, float(v.min())), max(hi, float(v.max()))
    if lo > hi:  # nothing valid: any range will do
        lo = hi = 0.0
    return lo, hi


LATTICE_SAMPLE = 1 << 20  # values looked at first: most fields leave here
MODE_SHARE = 0.05  # of the valid voxels: a value this common is put on a bin centre
MODE_SAMPLE = 1 << 20  # voxels looked at for it (every k-th)


def modes(data: np.ndarray, fill_value: float | None) -> tuple[float, ...]:
    """The (at most two) values each held by at least MODE_SHARE of the valid voxels of a
    float volume, most common first, in an evenly strided sample: under a PSNR target
    :meth:`BoundedCodec.plan` puts them on bin centres (:func:`.lossy.on_bins`)."""
    flat = np.asarray(data).reshape(-1)
    v = np.asarray(flat[:: max(1, -(-flat.size // MODE_SAMPLE))])
    v = v[~special_voxels(v, fill_value)]
    if v.size == 0 or v.dtype.kind != "f":
        return ()
    u, c = np.unique(v, return_counts=True)
    order = np.argsort(-c, kind="stable")[:2]
    return tuple(float(u[i]) for i in order if c[i] >= MODE_SHARE * v.size)


def lattice(data: np.ndarray, fill_value: float | None, max_error: float) -> float | None:
    """The spacing ``g > 2 max_error`` of a grid ``lo + k g`` that every valid voxel of
    the float volume lies on, to within ``max_error / 4`` after rounding to its dtype
    (whole numbers: 1; a model's output stored to 0.1: 0.1), else None.

    Then bins of ``g`` instead of ``2 max_error`` give every voxel back (all but
    rounding): a scan saved as floats, GRIB-packed fields. The smallest gap between the
    distinct values is ``g`` or a multiple of it; ``g`` is refined as the whole span
    over the number of steps in it.
    """
    with np.errstate(all="ignore"):  # extremes overflow: inf, then no grid
        return _lattice(np.asarray(data).reshape(-1), fill_value, max_error)


def _lattice(flat: np.ndarray, fill_value: float | None, max_error: float) -> float | None:
    v = flat[:LATTICE_SAMPLE]
    v = v[~special_voxels(v, fill_value)]
    u = np.unique(v)
    if u.size < 2 or np.diff(u).min() <= 2 * max_error:
        return None  # a gap of at most 2E among these: no grid worth its bins
    v = flat[~special_voxels(flat, fill_value)].astype(np.float64)
    u = np.unique(v)
    gap = float(np.diff(u).min())
    if gap <= 2 * max_error:
        return None
    lo, span = float(u[0]), float(u[-1] - u[0])
    if not (math.isfinite(span) and math.isfinite(gap) and 0 < span / gap < 2**31):
        return None
    g = span / round(span / gap)
    rec = (np.rint((v - lo) / g) * g + lo).astype(flat.dtype).astype(np.float64)
    if g <= 2 * max_error or not np.abs(rec - v).max() <= max_error / 4:
        return None
    return g


def plan(
    vol: Volume,
    brick: tuple[int, int, int],
    workers: int,
    asked: dict[str, float],
    fill_value: float | None,
    inner: dict[str, Any],
    effort: str = "default",
    known_range: tuple[float, float] | None = None,
    start: float | None = None,
) -> tuple[Any, dict[str, Any] | None]:
    """Return ``(codec, search record or None)`` for one lossy setting in ``asked``;
    ``effort`` is the error-bounded encoder's (:class:`BoundedCodec`); ``known_range``
    the valid voxels' range if already read (:func:`value_range`); ``start`` the
    searched knob's first value for a PSNR or ratio target (a setting found for the same
    data in another layout), else the usual first guess."""
    ((what, target),) = asked.items()
    dtype = vol.dtype
    if dtype.kind not in "iuf":
        raise OptionError(f"expected integer or float voxels, found {dtype}")
    check_choice("effort", effort, EFFORTS)
    lo, hi = known_range if known_range is not None else value_range(vol.data, fill_value)
    rng = hi - lo
    inner = {k: v for k, v in inner.items() if v is not None}
    bounded_path = what in ("max_error", "rel_error") or (
        what in ("psnr", "ratio") and (dtype.kind == "f" or fill_value is not None)
    )
    if effort != "default" and (inner.get("wavelet") in FLOAT_WAVELETS or not bounded_path):
        raise OptionError(
            f"effort={effort!r} applies to error-bounded coding (max_error, rel_error, or "
            f"psnr/ratio on floats), found {what}={target!r}"
            + (f" with wavelet={inner['wavelet']!r}" if "wavelet" in inner else "")
        )
    if inner.get("wavelet") in FLOAT_WAVELETS:
        return _plan_float_wavelet(vol, brick, workers, what, target, fill_value, inner, rng)
    if what in ("quality", "threshold"):
        if dtype.kind == "f" or fill_value is not None:
            raise OptionError(
                f"{what}= works on integer volumes without a fill value; use max_error= "
                f"(or rel_error=, psnr=, ratio=) for {dtype} data"
            )
        if dtype.itemsize > 4:
            raise OptionError(f"{what}= takes 8 to 32-bit integers, found {dtype}")
        return CoefCodec(value_range=max(rng, 1.0), **{what: target}, **inner), None

    grid = None  # the data's own grid, for an error bound (not searched for a target)

    # under a PSNR target each brick's coding is chosen by rate and distortion (RD_WEIGHT),
    # and the field's most common values sit on bin centres (an error bound keeps its bins)
    rd = RD_WEIGHT if what == "psnr" else None
    held = modes(vol.data, fill_value) if what == "psnr" and dtype.kind == "f" else ()

    def bounded(e: float) -> BoundedCodec:
        return BoundedCodec.plan(
            dtype, lo, hi, e, grid, held, fill=fill_value, effort=effort, rd=rd, **inner
        )

    if what in ("max_error", "rel_error"):
        e = absolute_bound(what, target, rng)
        if not (e >= 0 and math.isfinite(e)):
            raise OptionError(f"expected a non-negative finite {what}, found {target!r}")
        if what == "rel_error" and dtype.kind == "f" and fill_value is None and e > 0:
            _warn_fill_range(
                vol.data, lo, hi, f"rel_error {target:g} of the range {lo:g}..{hi:g} is a bound of {e:g}"
            )
        if e == 0 and dtype.kind == "f":
            raise OptionError(
                "an error bound of 0 on float voxels is lossless coding: leave out the lossy "
                "settings (floats are then stored exactly)"
            )
        if dtype.kind == "f" and e > 0:
            grid = lattice(vol.data, fill_value, e)
        try:
            return bounded(e if e > 0 else 0.25), None
        except OptionError:  # too many bins: unless a fill value (1e20, ...) spans them
            if fill_value is not None or dtype.kind != "f":
                raise
            fill_value = sentinel(np.asarray(vol.data), None)
            if fill_value is None:
                raise
            lo, hi = value_range(vol.data, fill_value)
            grid = lattice(vol.data, fill_value, e)
            return bounded(e), None
    if what == "psnr":
        if not target > 0:
            raise OptionError(f"expected a positive psnr in dB, found {target!r}")
        if dtype.kind == "f" and fill_value is None:  # its peak is the range, as rel_error's
            _warn_fill_range(
                vol.data, lo, hi, f"psnr {target:g} dB is measured against the range {lo:g}..{hi:g}"
            )
    elif what == "ratio":
        if not target > 1:
            raise OptionError(f"expected a ratio above 1, found {target!r}")
    else:
        raise OptionError(f"unknown lossy setting {what!r}")
    if dtype.kind in "iu" and dtype.itemsize <= 4 and fill_value is None:
        # Integers: quantise the coefficients (a better PSNR per bit than a bound).
        def make(step: float) -> CoefCodec:
            return CoefCodec(value_range=max(rng, 1.0), step=step, **inner)

        return _warned(
            _search(vol, brick, workers, what, float(target), make, max(rng, 1.0), "step", start=start)
        )
    sizes: dict[float, int] = {}
    codec, record = _search(
        vol, brick, workers, what, float(target), bounded, max(rng, 1e-300), "error_bound", sizes,
        start=start,
    )
    tucker = what == "psnr" and dtype.kind == "f" and fill_value is None
    tucker = tucker and math.prod(vol.shape[-3:]) >= TUCKER_MIN_VOXELS
    if not (tucker and effort == "default" and not inner):
        return _warned((codec, record))
    if not np.isfinite(np.asarray(vol.data)).all():
        return _warned((codec, record))
    return _warned(_tucker_or(vol, brick, workers, what, float(target), rng, codec, record, sizes))


def _tucker_or(vol, brick, workers, what, target, rng, codec, record, sizes):
    """The Tucker codec where it reaches the PSNR target too and codes the volume shorter
    than the error-bounded codec's setting (``sizes``: its whole-volume sizes by bound).
    Ratio targets stay with the bounded codec (equal bytes: the choice would need the
    PSNR of both, which that search does not measure)."""
    from .tucker import TuckerCodec

    def make(step: float) -> TuckerCodec:
        return TuckerCodec(value_range=max(rng, 1e-300), step=step)

    t_sizes: dict[float, int] = {}
    # A step Q leaves at most Q^2 / 12 of error per voxel (most of the core is zero, with
    # less): start at twice the bound of the same PSNR.
    t_codec, t_record = _search(
        vol, brick, workers, what, target, make, max(rng, 1e-300), "step", t_sizes, 2.0
    )
    ours, theirs = t_sizes.get(t_record["step"]), sizes.get(record["error_bound"])
    if ours is None or theirs is None or abs(t_record["reached"] - target) > PSNR_TOL:
        return codec, record
    if ours >= theirs:
        return codec, record
    t_record["codec"] = "tucker"
    t_record["bytes"] = {"tucker": ours, "error_bound": theirs}
    return t_codec, t_record


def _closest(whole: list[tuple[float, float]], what: str, target: float) -> tuple[float, float]:
    """The whole-volume try to keep when the search ended without meeting the target: the
    nearest within the tolerance, else the nearest on the target's safe side (a PSNR at or
    above it, a file no larger than the ratio asks), else the nearest. The PSNR of an
    integer volume can jump past the tolerance between two neighbouring settings (a uint8
    clip: 49.48 to 50.93 dB at a step of 0.94); a user who asked 50 dB gets 50.93."""

    def off(m: float) -> float:
        return abs(m - target) if what == "psnr" else abs(math.log(m / target))

    tol = PSNR_TOL if what == "psnr" else math.log1p(RATIO_TOL)
    for keep in (
        lambda m: off(m) <= tol,
        lambda m: m >= target,
        lambda m: True,
    ):
        kept = [(off(m), e, m) for e, m in whole if keep(m)]
        if kept:
            _, e, m = min(kept)
            return e, m
    raise AssertionError("no whole-volume try")


def _missed(what: str, target: float, reached: float) -> bool:
    """Whether a search's kept setting is outside the target's tolerance (a ratio by
    either of the two rules the search accepts one by)."""
    if what == "psnr":
        return abs(reached - target) > PSNR_TOL
    return (
        abs(reached / target - 1) > RATIO_TOL
        and abs(math.log(reached / target)) > math.log1p(RATIO_TOL)
    )


def _warned(found: tuple[Any, dict[str, Any]]) -> tuple[Any, dict[str, Any]]:
    """``found`` (a codec and its search record), after a warning where the setting kept
    misses the target. Given for the record the caller keeps, not for each search made:
    the Tucker codec's own search missing a target said so even where the bounded codec's
    setting, which met it, was kept (session 38: "kept 41.32" for a file of 40.33 dB)."""
    record = found[1]
    what, target, reached = record["target"], record["value"], record["reached"]
    if _missed(what, target, reached):
        log.warning(
            "%s %g: not reached within %s by any setting tried; kept %s",
            what, target, f"{PSNR_TOL} dB" if what == "psnr" else f"{RATIO_TOL:.0%}",
            "an exact coding" if reached == math.inf else f"{reached:.4g}",
        )  # fmt: skip
    return found


def _undominated(
    best: tuple[float, float], whole: list[tuple[float, float]], sizes: dict[float, int]
) -> tuple[float, float]:
    """``best`` (a knob value and the PSNR it reached), or where another whole-volume try
    of ``whole`` codes no longer and reaches no lower PSNR (``sizes``: their bytes), the
    shortest of those, then the highest PSNR. PSNR is not monotone in the knob (a brick's
    coding changes with the bound), so the try the search ended on can be beaten in both
    by one made before it."""
    if best[0] not in sizes:
        return best
    won = [
        (sizes[e], -m, e)
        for e, m in whole
        if e in sizes and sizes[e] <= sizes[best[0]] and m >= best[1]
    ]
    if not won:
        return best
    _, m, e = min(won)
    return e, -m


def _search(
    vol, brick, workers, what, target, make: Callable, rng: float, knob: str, sizes=None,
    first: float = 1.0, start: float | None = None,
):
    """Search ``make``'s knob for the target; ``sizes`` (if given) gets the payload bytes
    of every whole-volume try by knob value, ``first`` scales the first guess and
    ``start`` (if given) replaces it."""
    data = vol.data
    frames = data[None] if data.ndim == 3 else data
    every = [
        (t, sl) for t in range(frames.shape[0]) for _, sl in bricks.iter_bricks(data.shape, brick)
    ]
    pick = np.linspace(0, len(every) - 1, min(SAMPLE_BRICKS, len(every))).round().astype(int)
    sample = [every[i] for i in sorted(set(pick.tolist()))]
    container = CONTAINER_BYTES + BRICK_BYTES * len(every)
    whole_sizes = {} if sizes is None else sizes  # payload bytes of each whole-volume try

    def score(e: float, tasks) -> float:
        c = make(e)

        def one(task):
            t, sl = task
            b = np.ascontiguousarray(frames[(t, *sl)])
            payload, _, sse, n = c.encode_measured(b)
            return len(payload), sse, n, b.nbytes

        size = sse = n = raw = 0
        for a, b2, c2, d in ordered_map(one, tasks, workers):
            size, sse, n, raw = size + a, sse + b2, n + c2, raw + d
        if tasks is every:
            whole_sizes[e] = size
        if what == "ratio":  # the file's ratio: the sample carries its share of the container
            return raw / max(size + container * raw / frames.nbytes, 1)
        return psnr_from_sse(sse, n, rng)

    def ok(m: float) -> bool:
        if what == "psnr":
            return abs(m - target) <= PSNR_TOL * 0.8
        return abs(m / target - 1) <= RATIO_TOL * 0.8

    # Uniform quantisation with bound E has MSE E^2 / 3: the first guess for a PSNR.
    e = rng * math.sqrt(3) * 10 ** (-target / 20) if what == "psnr" else rng * 1e-3
    e = e * first if start is None else start
    # Larger bounds: PSNR down, ratio up. ``low``/``high`` bracket the bound sought.
    low = high = None
    tried: list[tuple[float, float, str]] = []
    best = None
    for step in range(MAX_STEPS):
        tasks = sample if step < MAX_STEPS // 2 and len(sample) < len(every) else every
        m = score(e, tasks)
        scope = "sample" if tasks is sample else "all"
        tried.append((e, m, scope))
        if ok(m):
            if scope == "all":
                best = (e, m)
                break
            m_all = score(e, every)  # confirm on the whole volume
            tried.append((e, m_all, "all"))
            if (
                ok(m_all)
                or (what == "psnr" and abs(m_all - target) <= PSNR_TOL)
                or (what == "ratio" and abs(m_all / target - 1) <= RATIO_TOL)
            ):
                best = (e, m_all)
                break
            m = m_all
        need_larger = (m > target) if what == "psnr" else (m < target)
        if need_larger:
            low = e
        else:
            high = e
        if low is not None and high is not None:
            e = math.sqrt(low * high)
        elif what == "psnr" and math.isfinite(m):
            e = e * 10 ** ((m - target) / 20)
        else:
            e = e * 4 if need_larger else e / 4
        e = min(max(e, rng * 1e-9), rng * 4)
    if best is None:
        whole = [(e, m) for e, m, s in tried if s == "all"]
        if not whole:
            m_all = score(e, every)
            tried.append((e, m_all, "all"))
            whole = [(e, m_all)]
        best = _closest(whole, what, target)
    if what == "psnr":
        best = _undominated(best, [(e, m) for e, m, s in tried if s == "all"], whole_sizes)
    record = {
        "target": what,
        "value": target,
        knob: best[0],
        "reached": best[1],
        "steps": [{knob: a, what: b, "scope": sc} for a, b, sc in tried],
    }
    return make(best[0]), record


def _plan_float_wavelet(vol, brick, workers, what, target, fill_value, inner, rng):
    """The PyWavelets comparison filters: quality, or a PSNR/ratio search of the step."""
    if what not in ("quality", "psnr", "ratio") or fill_value is not None:
        raise OptionError(
            f"the float wavelets {', '.join(FLOAT_WAVELETS)} take quality=, psnr= or ratio= "
            "(no error bound, no fill value); use an integer wavelet for max_error="
        )
    opts = {"wavelet": inner["wavelet"], "coder": inner.get("coder", "arith")}
    if what == "quality":
        return FloatWaveletCodec(value_range=max(rng, 1e-30), quality=int(target), **opts), None

    def make(step: float) -> FloatWaveletCodec:
        return FloatWaveletCodec(value_range=max(rng, 1e-30), step=step, **opts)

    return _warned(_search(vol, brick, workers, what, float(target), make, max(rng, 1e-30), "step"))
