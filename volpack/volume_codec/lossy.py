"""Lossy brick codecs: an error bound kept on every voxel, and the thesis's knobs.

``BoundedCodec`` (``--max-error``, ``--rel-error``, ``--psnr``, ``--ratio``)
    The voxels are quantised before the transform: ``q = round((x - lo) / step)`` with
    ``step = 2E`` (floats) or integer bins of ``2e + 1`` values (integers, ``e =
    floor(E)``), so the reconstruction ``lo + q * step`` is within ``E`` of every voxel.
    The integer field ``q`` is then coded by the lossless wavelet codec; floats are also
    coded by the float CDF 9/7 (:mod:`.bounded_cdf97`), by prediction from decoded
    voxels (:mod:`.bounded_interp`) and, where their values are coarse (a packed field
    on a lattice per slice), exactly by the lossless codec, and the shortest coding kept. The encoder
    rebuilds the brick exactly as the decoder will and checks every voxel; any voxel
    that rounding to the output dtype pushed past ``E`` is stored exactly in a correction
    list, so the bound holds always. NaN, +-Inf and a declared fill value are taken out
    into a mask (their exact bytes stored), and their places are filled with the
    neighbouring quantised value so they do not disturb the transform.
``CoefCodec`` (``--quality``, ``--threshold``)
    The method's own lossy modes on integer voxels: the lifting coefficients are
    thresholded or dead-zone quantised in the units of an orthonormal transform (the
    integer lifting is not orthonormal, so each subband gets its own step). The error is
    measured and recorded, not bounded.

Both report, per brick, the largest error and the squared error sum; the container keeps
the first in its index. Payloads are specified in ``formats/lossy-1.md``.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from typing import Any, ClassVar

import numpy as np

from ..errors import FormatError, OptionError
from ..format.deflate import deflate, inflate
from ..format.sections import put_section, take_section
from .codec import (
    CODER_NAMES,
    MODE_CODED,
    MODE_CONSTANT,
    MODE_RAW,
    ORDER_NAMES,
    WAVELET_NAMES,
    WaveletCodec,
)
from .protocol import (
    BrickCodec,
    Measured,
    as_stored,
    check_choice,
    constant_value,
    from_stored,
    storage_dtype,
)
from .specials import fill_masked, sentinel, special_mask

# The bounded payload's flag byte (formats/lossy-1.md, `bounded`).
FLAG_MASK, FLAG_CORRECTIONS, FLAG_COEF, FLAG_RESIDUALS = 1, 2, 4, 8
FLAG_CDF97, FLAG_OUTLIERS = 16, 32  # the float wavelet path (bounded_cdf97)
FLAG_INTERP = 64  # the interpolation path (bounded_interp)
FLAG_EXACT = 128  # the brick stored exactly by the lossless codec (alone)
_KNOWN_FLAGS = (
    FLAG_MASK | FLAG_CORRECTIONS | FLAG_COEF | FLAG_RESIDUALS | FLAG_CDF97 | FLAG_OUTLIERS
    | FLAG_INTERP | FLAG_EXACT
)  # fmt: skip
# The exact path is tried on a float brick whose values are coarse next to the bins:
# on lattices (one per z slice) whose median step is at least EXACT_MIN_STEP bins of 2E,
# or with at most EXACT_MAX_DISTINCT of its voxels distinct and fewer distinct values
# than bins over their span. Elsewhere it did not win on the float corpus of
# scripts/bench_lossy.py, and it costs more than the other paths together.
EXACT_MIN_STEP = 0.5
EXACT_MAX_DISTINCT = 0.125
# ... and wherever byte-shuffled zstd at level 3 (a quick stand-in for the lossless float
# tools, which code 1.03-4.5x shorter than it) comes within EXACT_PROXY of the shortest
# bounded coding: tight bounds on fields whose values repeat or carry fewer bits than
# their type, which no lattice test sees (a cryo-EM map taken at every second voxel, at
# 1e-5 of its range: 18,792 bytes bounded, 14,835 exact; results/lossy/exact33). 0: off.
EXACT_PROXY = 2.0
# Orthonormal coefficient step of the bounded codec's coefficient path, in units of the
# error allowed on its grid (measured best on the head CT and the z-map).
COEF_STEP = 2.0
QUALITIES = (255, 127, 63, 31, 15)
# Decoding speed tiers of the bounded payloads (results/lossy/lossy11/speed): the
# interpolation walk with static rANS bins and raw quantised voxels; the wavelet paths
# (quantised voxels, float CDF 9/7, coefficients) and the walk with adaptive bins; the
# quantised voxels through the lossless codec's predictors, a chain of adaptive binary
# decisions per voxel (a third to a half of the speed of the wavelet on them).
TIER_FAST, TIER_MID, TIER_SLOW = 0, 1, 2
# A coding of a slower tier is kept only where it is this share of the bytes shorter
# than the best of the faster tiers (chosen by measurement: formats/lossy-1.md and the
# README's lossy11 section). The encoder's rule alone: the decoder reads any coding.
SLOW_MIN_SAVING = 0.02
EFFORTS = ("default", "fast", "max")  # of the error-bounded encoder
# Under effort 'fast' a coding that decodes slower is kept only where it saves a share
# of the bytes of the faster one that grows with its cost: the interpolation path's
# adaptive bins (1.3-1.8x the static coding's decode time where most bins are 0,
# 2.5-3.5x at tight bounds; on the six fields of the README's fast23 section they saved
# 4-9 % at 1e-3..1e-5 of the range, 9-29 % at 1e-2, and the static coding alone fell
# below SZ3's ratio where they saved 16 % or more: eta_u and cam_t at 1e-2) and the exact
# path (the lossless float tools: 5x the fast codec's decode time on eta_u's quantised
# voxels, for 15 % of the bytes). Chosen on those fields: no held-out set.
FAST_ADAPTIVE_SAVING = 0.15
# Since session 25 the exact path under 'fast' is coded by the fast codec too
# (:mod:`.fastexact`), kept where it is shorter than the other paths; the lossless
# codec's exact payload is then kept only where the bytes it saves pay for its modelled
# extra decode time at FAST_BYTES_PER_NS: a model of a voxel's decode, not a measured
# time (the same brick gives the same bytes). The lossless exact path decoded its
# lattices at 62-70 ns a voxel, the fast one at 7-12 (sst_monthly, contour_t; README
# fastpath25); the rate is the fast codec's own for its zstd mode (fast.ZSTD_RATE, 4 KB
# a millisecond of decode).
EXACT_LOSSLESS_NS = 60.0
EXACT_FAST_NS = 10.0
FAST_BYTES_PER_NS = 0.004
# ... and a float brick's interpolation path against its quantised voxels by the fast
# codec (the walk with static bins took 1.1-2.3x the fast codec's time at 1e-3..1e-5 of
# the range, where the fast codec codes within 5 % of it, often shorter; at 1e-2 the
# interpolation is 2-35 % shorter). 5 % left eta_u at 1e-3 below SZ3's ratio (the
# interpolation 4.4 % shorter); chosen on the README's fast23 fields, no held-out set.
FAST_INTERP_SAVING = 0.04
# Under effort 'fast' the interpolation path's bins are coded grouped
# (bounded_interp.GROUPED), static or adaptive, in that order of decoding speed, each
# kept only where it saves its share of the shortest of those before it: the static bins
# (1.4-1.7x the grouped decode time) FAST_ADAPTIVE_SAVING, the adaptive ones (2-3.5x)
# FAST_ADAPTIVE_OVER_GROUPED. They save 17.7 % on cam_t and 16.5 % on xray_1jzv at 1e-2
# of the range (grouped: 0.42x and 0.67x SZ3's decode speed, at or above its ratio) and
# 24 % on contour_t at 1e-2, held out, which fell below SZ3's ratio with 25 % (22.7
# against 23.9): chosen after seeing it. Then FAST_INTERP_SAVING against the fast codec,
# whatever the coding: the grouped walk decodes slower than it at tight bounds (tgv_u at
# 1e-3: 0.46x SZ3's speed against 0.48x; xray_1jzv at 1e-4: 0.48x against 0.59x).
# README: fastbins24.
FAST_ADAPTIVE_OVER_GROUPED = 0.22
FAST_BIN_SAVINGS = (0.0, FAST_ADAPTIVE_SAVING, FAST_ADAPTIVE_OVER_GROUPED)
# The long fitted predictor of the quantised voxels is tried only where the shortest
# other coding spends this many bits a voxel (tight bounds; see _longfit).
LONGFIT_MIN_BITS = 1.0
# ... and coded only where its residuals' zeroth-order entropy is at most this share of
# the shortest other coding (the lossless codec codes them up to 15 % below it: cam_u).
LONGFIT_MAX_ENTROPY = 1.2
# The default effort's selection (session 29, results/lossy/enc29): the codings are made
# in an order that finds a short one early, and the costly ones whose estimate (or first
# step) is far from the shortest so far are not made. False: every coding of every path
# made, as before (the exhaustive mode the tests compare with).
PRUNE = True
# The lossless codec's predictive tool (a chain of adaptive decisions per voxel, the
# costliest coding of the quantised voxels and of the long fit's residual) is run on the
# whole array only where its estimate, its ratio to the wavelet's bytes on the central
# half of the slices times the wavelet's bytes of the whole, is below this times the
# shortest coding so far: the ratio on those slices was within 3 % of the whole's on six
# fields of the corpus at 1e-2, 1e-3 and 1e-5 of the range, and a predictive coding
# (the slow tier) is kept only where it is SLOW_MIN_SAVING shorter than a faster one.
# 1.05 made it more often, for no byte on the 52 cells (1.15x the exhaustive speed,
# against 1.24x: results/lossy/enc29).
PREDICT_GATE = 1.01
SAMPLE_MIN_SLICES = 8  # thinner arrays are coded whole

# The quantised voxels' inner section under effort 'fast': this byte, then a `fast` codec
# payload (formats/fast-1.md) of them: MED prediction and static rANS decode 3-10x faster
# than the wavelet and its adaptive coder and code as short on the head CT, and on float
# fields at 1e-3..1e-5 of the range within a few per cent of the interpolation path, at
# up to twice its speed (a lossless payload's mode byte is 0-4 for these integer voxels,
# so the two cannot be confused).
QVOX_FAST = 6
# ... coded with the fast codec's far context rule alone (qvox26): on the six tuning fields
# the near rule was kept in 9 of 25 cells (ct_head at every bound, md_water at every one),
# where it saved 0.8-4.4 % of the bytes of its bricks and cost 0.35-2.4 ns a voxel of
# decode (10-40 % of the kernel's time); at fastpath25's rate (FAST_BYTES_PER_NS) it paid
# for its time in 2 of the 9 (0.0042 and 0.0058 bytes a ns), so it is not tried.
FAST_NEAR = False
# The lossless codec's version for the quantised voxels: their streams stay as they were
# before version 7 (its texture bias), so the lossy goldens are unchanged.
QUANTISED_VERSION = 6
# Under a PSNR target (``rd`` > 0) a brick's coding is chosen by rate and distortion, not
# by size alone: the least ``bytes + rd * sse / max_error**2``. The bound's own knob sets
# the rate: a uniform quantiser of bins 2E leaves E^2 / 3 a voxel and saves a bit a voxel
# each time E halves, so at E a squared error of one unit costs 3 / (2 ln 2 E^2) bits,
# 3 / (16 ln 2) bytes in units of E^2. A size-chosen coding gave isabel_qcloud's zeros back
# as other values within the bound above ~2.6e-4 of its range of 7.7e-3, and the PSNR
# jumped about with the bound (session 37, results/lossy/psnr37/qcloud_sweep.txt).
RD_WEIGHT = 3.0 / (16.0 * math.log(2.0))


# -- error-bounded quantisation ---------------------------------------------------------


@dataclasses.dataclass(frozen=True, eq=False, repr=False)
class BoundedCodec(BrickCodec):
    """Every valid voxel decodes to within ``max_error`` of its input.

    Build it with :meth:`plan` from the volume's valid value range; ``step`` and ``lo``
    are shared by all bricks and stored in the header.
    """

    codec_id: ClassVar[str] = "bounded"
    lossless: ClassVar[bool] = False
    max_error: float
    lo: float
    step: float
    integer: bool
    qdtype: str
    value_range: float = 0.0  # of the valid voxels: the PSNR peak
    fill: float | None = None
    wavelet: str = "53"
    # New streams: per coefficient stream the fastest coder that costs (almost) no
    # ratio (volpack.entropy.choose); streams made before it name "arith".
    coder: str = "auto"
    order: str = "dfs"
    max_levels: int | None = None
    # How hard the encoder looks (the decoder never needs it): 'default' makes every
    # coding of a brick and keeps the shortest, a slower-decoding one only where it
    # saves SLOW_MIN_SAVING; 'fast' makes one or two (integers: the quantised voxels by
    # the fast codec; floats: those and the interpolation path, two predictors); 'max'
    # keeps the shortest whatever its decoding speed, the lossless codec's predictive
    # tool with its local fit (version 9).
    effort: str = "default"
    # Encoder only, as effort: > 0 keeps the coding of least bytes + rd * sse / max_error^2
    # (RD_WEIGHT under a PSNR target) instead of the shortest; streams without it keep
    # their bytes (not in the config when 0).
    rd: float = 0.0

    @classmethod
    def plan(
        cls,
        dtype: Any,
        lo: float,
        hi: float,
        max_error: float,
        grid: float | None = None,
        modes: tuple[float, ...] = (),
        **inner: Any,
    ) -> BoundedCodec:
        """``grid``: every valid voxel of the float volume is within ``max_error`` of
        ``lo + k * grid`` for a whole ``k`` (whole numbers, data stored to 0.1, ...; see
        :func:`volpack.volume_codec.search.lattice`): a bound below half of it is met by
        bins of ``grid``. ``modes``: values many float voxels hold, most common first
        (:func:`volpack.volume_codec.search.modes`), put on bin centres
        (:func:`on_bins`); the bound narrows with the bins."""
        dtype = np.dtype(dtype)
        peak_lo = lo  # the PSNR's peak is the valid range, wherever the bins start
        if not (max_error > 0 and math.isfinite(max_error)):
            raise OptionError(f"expected a positive finite error bound, found {max_error!r}")
        integer = dtype.kind in "iu"
        if integer and dtype.itemsize > 4:
            raise OptionError(
                f"error-bounded coding takes 8 to 32-bit integers or floats, found {dtype}; "
                "64-bit integers are stored exactly by the lossless path"
            )
        if integer:
            e = min(math.floor(max_error), 2**31)  # past any 32-bit range: one bin either way
            step = 2 * e + 1
            qmax = (hi - lo + e) // step
        else:
            step = 2.0 * max_error
            if grid is not None and step < grid and math.isfinite(grid):
                step = float(grid)  # the data's own grid: far fewer bins, and exact
            elif modes:
                lo, step = on_bins(lo, step, modes)
                max_error = min(max_error, step / 2)  # every path assumes bins of 2E
            levels = (hi - lo) / step  # may overflow to inf: then it is refused below
            qmax = math.floor(levels + 0.5) + 1 if levels < 2**40 else math.inf
        for qd in ("uint8", "uint16", "int32"):
            if qmax <= np.iinfo(qd).max:
                break
        else:
            raise OptionError(
                f"the bound {max_error:g} is too small for the value range {lo:g}..{hi:g}: "
                "it needs more than 2^31 quantisation levels; raise the bound or store the "
                "volume losslessly"
            )
        return cls(
            max_error=float(max_error),
            lo=float(lo),
            step=float(step),
            integer=integer,
            qdtype=qd,
            value_range=float(hi - peak_lo),
            **{k: v for k, v in inner.items() if v is not None},
        )

    def __post_init__(self) -> None:
        _check_inner(self)
        check_choice("effort", self.effort, EFFORTS)
        # what the quantiser's arithmetic needs (a stored config may hold anything)
        if self.qdtype not in ("uint8", "uint16", "int32"):
            raise OptionError(f"expected qdtype uint8, uint16 or int32, found {self.qdtype!r}")
        finite = (self.max_error, self.lo, self.step, self.value_range)
        if not all(math.isfinite(v) for v in finite):
            raise OptionError(
                f"expected finite max_error, lo, step and value_range, found {finite}"
            )
        if not (self.max_error > 0 and self.step > 0):
            raise OptionError(f"expected a positive bound and step, found {finite[:3]}")
        if self.integer and not (
            abs(self.lo) < 2**53 and self.step < 2**33 and self.step == int(self.step)
            and self.lo == int(self.lo)
        ):  # fmt: skip
            raise OptionError(f"expected an integer lo and step, found {self.lo}, {self.step}")
        if self.fill is not None and not math.isfinite(self.fill):
            raise OptionError(f"expected a finite fill value, found {self.fill!r}")
        if not (isinstance(self.rd, (int, float)) and 0 <= self.rd < math.inf):
            raise OptionError(f"expected a non-negative finite rd, found {self.rd!r}")

    def get_config(self) -> dict[str, Any]:
        """As every codec's, but ``effort`` only when it is not the default: it changes
        what the encoder tries, not what the decoder reads, and files written before it
        existed keep their bytes."""
        config = super().get_config()
        if self.effort == "default":
            del config["effort"]
        if not self.rd:
            del config["rd"]
        return config

    def _inner(self) -> WaveletCodec:
        return WaveletCodec(self.wavelet, self.coder, self.order, self.max_levels)

    # The quantiser and its inverse: the encoder checks the bound with the same code
    # the decoder runs.
    def _quantize(self, x: np.ndarray) -> np.ndarray:
        if self.integer:
            e = (int(self.step) - 1) // 2
            q = (x.astype(np.int64) - int(self.lo) + e) // int(self.step)
        else:
            q = np.rint((x.astype(np.float64) - self.lo) / self.step)
        qd = np.dtype(self.qdtype)
        return np.clip(q, 0, np.iinfo(qd).max).astype(qd)

    def _reconstruct(self, q: np.ndarray, dtype: np.dtype, into=None) -> np.ndarray:
        if self.integer and q.ndim == 3:
            from .floatcast import dequantise_integer

            return dequantise_integer(q, int(self.step), int(self.lo), dtype, into)  # one pass
        if self.integer:
            v = q.astype(np.int64) * int(self.step) + int(self.lo)
            return _clip_to(v, dtype)
        if dtype == np.float32 and q.ndim == 3 and q.flags.c_contiguous:
            from .floatcast import dequantise_float32

            return dequantise_float32(q, self.step, self.lo, into)  # one pass, same values
        v = q.astype(np.float64)
        v *= self.step  # in place: the same two IEEE operations per voxel
        v += self.lo
        return _to_float(v, dtype, overwrite=True, out=into)

    def _reconstruct_fast(self, payload, shape, dtype: np.dtype, into=None) -> np.ndarray:
        """:meth:`_reconstruct` of the quantised voxels of a fast payload, from the fast
        decoder's own work array (no ``qdtype`` copy between); with a palette each of its
        values is rebuilt once, by the same code, and each voxel is a look-up of that
        table (same values, one pass)."""
        from .fast import decode_parts
        from .fastpredict import store_palette

        qd = np.dtype(self.qdtype)
        values, p, kinds = decode_parts(payload, shape, qd)
        if p is not None and dtype == np.float16:  # no kernel takes float16: numpy's path
            values, p = p.astype(qd)[values], None
        if p is None:
            return self._reconstruct(values, dtype, into)
        table = self._reconstruct(p.astype(qd).reshape(1, 1, -1), dtype).reshape(-1)
        out = np.empty(shape, dtype) if into is None else into
        store_palette(values, table, out, kinds)
        return out

    def _special(self, x: np.ndarray) -> np.ndarray | None:
        return special_mask(x, self.fill)

    def encode_measured(self, brick: np.ndarray) -> Measured:
        """Return ``(payload, max error, squared error sum, valid voxels)``.

        Several codings are made and the shortest kept: the quantised voxels coded
        losslessly (best for tight bounds), and quantised wavelet coefficients plus the
        voxels that strayed past the bound (best for loose ones, where wide bins in the
        voxel domain waste the transform's energy compaction): integer lifting on a fine
        grid, and for floats the float CDF 9/7 (:mod:`volpack.volume_codec.bounded_cdf97`).
        """
        x = np.ascontiguousarray(brick)
        mask = self._special(x)
        best = self._encode_masked(x, mask)
        value = sentinel(x, mask) if x.dtype.kind == "f" else None
        if value is not None:  # masked too, it may code shorter: try
            more = x == value if mask is None else mask | (x == value)
            cand = self._encode_masked(x, more)
            if self._cost(cand) < self._cost(best):
                best = cand
        if x.dtype.kind == "f" and (
            _exact_may_pay(x, self.max_error) or _near_exact(x, len(best[0]))
        ):
            if self.effort == "fast":
                return self._exact_fast(x, mask, best)
            cand = self._exact_candidate(x, mask)
            if self._cost(cand) < self._cost(best):
                best = cand
        return best

    def _cost(self, m: Measured) -> float:
        """What a coding costs in the choice between a brick's codings: its bytes, plus
        under a PSNR target its squared error at ``rd`` bytes a unit of max_error^2."""
        if not self.rd:
            return len(m[0])
        return len(m[0]) + self.rd * m[2] / (self.max_error * self.max_error)

    def _keep(self, cands, saving: float) -> Measured:
        return keep_faster(cands, saving, self._cost if self.rd else None)

    def _budget(self, cands, saving: float, own_error) -> float:
        """The bytes a coding of the quantised voxels (which reconstruct them as ``rec``:
        the quantised payloads and the long fit) must come under to beat ``cands``: the
        kept one's bytes, or under ``rd`` its cost less ``own_error()``, the cost of
        ``rec``'s own error (:meth:`_own_error`; the pruning gates' budget: by size alone
        a rate-distortion choice loses the codings that give exact values back; a 97 %
        zero field at 3 % of its range: the predictive coding's 449 bytes at 51.5 dB
        never made against the interpolation path's 490 at 46.5 dB)."""
        best = self._keep(cands, saving)
        if not self.rd:
            return len(best[0])
        return max(0.0, self._cost(best) - own_error())

    def _own_error(self, x, mask, rec):
        """``rec``'s error cost under ``rd`` (:meth:`_cost` less the bytes), measured
        once a brick however many gates ask (an error pass over the brick)."""

        @functools.cache
        def own_error() -> float:
            own = self._finish(x, mask, rec, 0, [])
            return self._cost(own) - len(own[0])

        return own_error

    def _exact_fast(self, x, mask, best: Measured) -> Measured:
        """Under effort 'fast': the exact path by the fast codec (:mod:`.fastexact`),
        kept where it is shorter than ``best``, then by the lossless codec, kept only
        where it saves FAST_BYTES_PER_NS a nanosecond of its modelled extra decode time
        over the shorter of those two."""
        from . import fastexact

        valid = x.size - (int(mask.sum()) if mask is not None else 0)
        for body in fastexact.encode(x):
            body = bytes([FLAG_EXACT]) + put_section(body)
            if len(body) < len(best[0]):
                best = Measured(body, 0.0, 0.0, valid)
        cand = self._exact_candidate(x, mask)
        extra_ns = (EXACT_LOSSLESS_NS - EXACT_FAST_NS) * x.size
        if len(best[0]) - len(cand[0]) > FAST_BYTES_PER_NS * extra_ns:
            best = cand
        return best

    def _min_saving(self) -> float:
        """What a slower-decoding coding must save to be kept (none with effort 'max')."""
        return 0.0 if self.effort == "max" else SLOW_MIN_SAVING

    def _quantised_version(self) -> int:
        from .lossless import LOCAL_VERSION

        return LOCAL_VERSION if self.effort == "max" else QUANTISED_VERSION

    def _lossless(self):
        from .lossless import LosslessCodec

        return LosslessCodec(
            self.wavelet, self.coder, self.order, self.max_levels,
            predict_version=self._quantised_version(),
        )

    def _predictive(self):
        """The lossless codec's predictive tool alone, for the quantised voxels."""
        from .lossless import LosslessCodec

        return LosslessCodec(
            self.wavelet, self.coder, self.order, self.max_levels, "predict",
            self._quantised_version(),
        )

    def _exact_candidate(self, x, mask) -> Measured:
        """The brick coded exactly by the lossless codec (its special voxels too): within
        any bound, and the shortest where the values sit on a grid per slice coarser
        than the bins (the lossless codec's lattice tool)."""
        body = bytes([FLAG_EXACT]) + put_section(self._lossless().encode(x))
        valid = x.size - (int(mask.sum()) if mask is not None else 0)
        return Measured(body, 0.0, 0.0, valid)

    def _encode_masked(self, x: np.ndarray, mask: np.ndarray | None) -> Measured:
        """:meth:`encode_measured` with the voxels of ``mask`` stored exactly."""
        clean = x if mask is None else fill_masked(x, mask)
        fast = self.effort == "fast"
        q = self._quantize(clean)
        if mask is not None:
            q = fill_masked(q, mask)  # masked voxels take their neighbour's value
        rec = self._reconstruct(q, x.dtype)
        own_error = self._own_error(x, mask, rec)
        if self._pruned:
            return self._encode_pruned(x, mask, clean, q, rec, own_error)
        cands = [(t, self._finish(x, mask, rec, 0, [b])) for t, b in self._code_quantised(q)]
        if fast:
            if x.size >= 64 and x.dtype.kind == "f" and not self._exact:
                # the interpolation walk decodes slower than the fast codec at tight bounds
                cands.append((TIER_MID, self._interp_candidate(x, clean, mask)[1]))
                return self._keep(cands, FAST_INTERP_SAVING)
            return self._keep(cands, self._min_saving())
        if x.size >= 64 and not self._exact:
            cands.append((TIER_MID, self._coef_candidate(x, clean, mask)))
        if x.size >= 64 and x.dtype.kind == "f" and not self._exact:
            cands += [(TIER_MID, c) for c in self._cdf97_candidates(x, clean, mask)]
            cands.append(self._interp_candidate(x, clean, mask))
        best = self._keep(cands, self._min_saving())
        if x.dtype.kind == "f":
            longs = self._longfit(q, self._budget(cands, self._min_saving(), own_error))
            if longs:
                cands += [
                    (tier, self._finish(x, mask, rec, FLAG_RESIDUALS, [long]))
                    for tier, long in longs
                ]  # fmt: skip
                best = self._keep(cands, self._min_saving())
        return best

    @property
    def _pruned(self) -> bool:
        return PRUNE and self.effort == "default"

    def _encode_pruned(self, x, mask, clean, q, rec, own_error) -> Measured:
        """The default effort's selection: the interpolation and coefficient paths, the
        long fit, the float CDF 9/7 (not made, or its step search given up, where it
        cannot come near the shortest so far), then the quantised voxels (their
        predictive coding made where its estimate may win, PREDICT_GATE); kept by
        ``keep_faster`` as every other selection."""
        from . import bounded_cdf97

        saving = self._min_saving()
        big = x.size >= 64 and not self._exact

        def quantised():
            best = self._budget(cands, saving, own_error) if cands else None
            coded = self._code_quantised(q, best)
            cands.extend((t, self._finish(x, mask, rec, 0, [b])) for t, b in coded)

        cands, planned, floor = [], None, math.inf
        if big and x.dtype.kind == "f":
            cands.append(self._interp_candidate(x, clean, mask))
            # the CDF 9/7 layouts' cost estimate: the long fit's gate on bits a voxel sees
            # the wavelet's floor, as it saw its coding when that was made first
            planned = bounded_cdf97.plan(clean.astype(np.float64), self.max_error, self.max_levels)
            floor = bounded_cdf97.COST_FLOOR * planned[1] / 8 if planned else math.inf
        if big:
            cands.append((TIER_MID, self._coef_candidate(x, clean, mask)))
        else:  # small, or on a grid: the quantised voxels alone, then the long fit
            quantised()
        so_far = self._budget(cands, saving, own_error) if cands else 0
        if x.dtype.kind == "f" and 8 * min(so_far, floor) >= LONGFIT_MIN_BITS * q.size:
            longs = self._longfit(q, so_far)
            cands += [
                (tier, self._finish(x, mask, rec, FLAG_RESIDUALS, [long])) for tier, long in longs
            ]
        if planned is not None:
            shortest = min(self._cost(m) for _, m in cands)
            cands += [
                (TIER_MID, c) for c in self._cdf97_candidates(x, clean, mask, shortest, planned)
            ]
        if big:
            quantised()
        return self._keep(cands, saving)

    def _predict_may_pay(self, v: np.ndarray, wav: int, best: int | None) -> bool:
        """Whether the predictive tool's bytes of ``v`` (whose wavelet bytes are ``wav``)
        may come within PREDICT_GATE of ``best``: estimated on the central half of its
        slices (a central block missed the background of masked fields: mri_dipy_float's
        ratio 0.88 for 0.78 at 1e-2 of its range; these slices 0.80)."""
        nz = v.shape[0] if v.ndim == 3 else 0
        if best is None or nz < SAMPLE_MIN_SLICES:
            return True
        part = np.ascontiguousarray(v[nz // 4 : nz // 4 + nz // 2])
        ratio = len(self._predictive().encode(part)) / max(1, len(self._inner().encode(part)))
        return ratio * wav < PREDICT_GATE * best

    def _code_quantised(self, q: np.ndarray, best: int | None = None) -> list[tuple[int, bytes]]:
        """The quantised voxels' payloads with their decoding tiers: the lossless
        wavelet payload (modes 0-3, what this path wrote first) and the lossless codec's
        predictive one (mode 4, the fitted 3-D predictor; or raw): at tight bounds the
        quantised voxels of a noisy or thin field are better predicted from their causal
        neighbours (mri_piesno_noise at 1e-4 of the range: 106.0 -> 99.9 kB). 'fast'
        makes the fast codec's payload alone (:data:`QVOX_FAST`). ``best``: the shortest
        coding so far, which the predictive one must come near (:meth:`_predict_may_pay`)."""
        from .lossless import MODE_PREDICT, inner_mode

        if self.effort == "fast":
            from .fast import FastCodec

            # without its zstd mode: level 19 took 60 % of the head CT's encode (3.3 s),
            # for 1.1x the decode speed on most bricks it kept (2.3x at 3e-2 of the range);
            # without the near context rule since qvox26 (FAST_NEAR)
            codec = FastCodec(zstd=False, near=FAST_NEAR)
            return [(TIER_FAST, bytes([QVOX_FAST]) + codec.encode(q))]
        wav = self._inner().encode(q)
        if not self._predict_may_pay(q, len(wav), best):
            return [(TIER_MID, wav)]
        p = self._predictive().encode(q)
        tier = TIER_SLOW if inner_mode(p) == MODE_PREDICT else TIER_FAST  # (else raw or constant)
        return [(TIER_MID, wav), (tier, p)]

    def _longfit(self, q: np.ndarray, best: int) -> list[tuple[int, bytes]]:
        """(decoding tier, payload) pairs of the quantised voxels by the long fitted
        predictor, version 2 (:mod:`volpack.volume_codec.bounded_longfit`), for
        ``keep_faster``: at each reach it tries (the two whose fits leave the least
        squared residual, and the shortest), the residual by the lossless codec's
        wavelet (the middle tier: the walk costs about what the wavelet does), by
        static rANS tables in contexts of the residual's magnitudes (middle tier: it
        decodes faster than the wavelet) and by the adaptive coder in those contexts
        (the slow tier: a chain of adaptive binary decisions per voxel, as the lossless
        codec's predictor); the shortest of each kind, and the wavelet's residual by the
        lossless codec's predictive tool (slow tier). Made only where the first reach's
        residual entropy is under LONGFIT_MAX_ENTROPY times ``best`` bytes (the
        shortest coding so far), and not tried where that spends less than
        LONGFIT_MIN_BITS a voxel (loose bounds: the wavelet and interpolation paths)."""
        from . import bounded_longfit as lf

        small = q.ndim != 3 or min(q.shape) < 4 or q.size < 4096
        if small or 8 * best < LONGFIT_MIN_BITS * q.size:
            return []
        qmax = int(np.iinfo(q.dtype).max)
        if self._pruned:
            return self._longfit_pruned(q, best, qmax)
        wav = self._inner()
        ctx = by_wav = shifted = static = None
        for i, reach in enumerate(lf.tried_reaches(np.ascontiguousarray(q, np.int64))):
            r, plan, weights = lf.residuals(q, reach, qmax, prune=True)
            if i == 0 and lf.estimate_bits(r) / 8 > best * LONGFIT_MAX_ENTROPY:
                return []
            data = lf.encode_head(r, plan, weights, context=True)[0] + lf.code_residuals(r)
            if ctx is None or len(data) < len(ctx):
                ctx = data
            body = lf.code_static(r)
            if body is not None:
                data = lf.encode_head(r, plan, weights, code=lf.STATIC_CODED)[0] + body
                if static is None or len(data) < len(static):
                    static = data
            head = lf.encode_head(r, plan, weights)
            if head is not None:
                data = head[0] + wav.encode(head[1])
                if by_wav is None or len(data) < len(by_wav):
                    by_wav, shifted = data, head
        out = [(TIER_SLOW, ctx)] + ([(TIER_MID, static)] if static is not None else [])
        if shifted is not None:
            head, res = shifted
            out += [(TIER_MID, by_wav), (TIER_SLOW, head + self._predictive().encode(res))]
        return out

    def _longfit_pruned(self, q, best: int, qmax: int) -> list[tuple[int, bytes]]:
        """:meth:`_longfit` of the default effort: the reach kept is the one whose
        residual codes shortest by static tables (the cheapest coding; it ranks the
        reaches as the others do), and only its residual is coded the other ways, by the
        lossless predictive tool where its estimate may win (:meth:`_predict_may_pay`)."""
        from . import bounded_longfit as lf

        chosen = None  # (static bytes or None, residual, plan, weights)
        for i, reach in enumerate(lf.tried_reaches(np.ascontiguousarray(q, np.int64))):
            r, plan, weights = lf.residuals(q, reach, qmax, prune=True)
            if i == 0 and lf.estimate_bits(r) / 8 > best * LONGFIT_MAX_ENTROPY:
                return []
            body = lf.code_static(r)
            if body is not None:
                body = lf.encode_head(r, plan, weights, code=lf.STATIC_CODED)[0] + body
            if chosen is None or _shorter(body, chosen[0]):
                chosen = (body, r, plan, weights)
        static, r, plan, weights = chosen
        out = [(TIER_SLOW, lf.encode_head(r, plan, weights, context=True)[0] + lf.code_residuals(r))]
        out += [(TIER_MID, static)] if static is not None else []
        head = lf.encode_head(r, plan, weights)
        if head is not None:
            by_wav = head[0] + self._inner().encode(head[1])
            out.append((TIER_MID, by_wav))
            so_far = min([best] + [len(b) for _, b in out])
            if self._predict_may_pay(head[1], len(by_wav), so_far):
                out.append((TIER_SLOW, head[0] + self._predictive().encode(head[1])))
        return out

    @property
    def _exact(self) -> bool:
        """Floats on a grid under a bound below half of it: the voxels are quantised to
        the grid (bins wider than 2E); the other paths assume bins of 2E, so they are
        left out."""
        return not self.integer and self.step > 2.0 * self.max_error

    def _interp_candidate(self, x, clean, mask):
        """The interpolation path (:mod:`volpack.volume_codec.bounded_interp`), checked on
        every voxel like the others."""
        from . import bounded_interp

        g = clean.astype(np.float64)
        if mask is not None:  # no value to keep: bin 0, the voxel follows its prediction
            g[mask] = np.nan
        if self.effort == "fast":
            tried, codings = bounded_interp.TRIED_FAST, bounded_interp.CODINGS_FAST
            inner, rec = bounded_interp.encode(g, self.step, tried, codings, FAST_BIN_SAVINGS)
        else:  # (codings left to encode's default: tests narrow it)
            saving = self._min_saving()
            inner, rec = bounded_interp.encode(
                g, self.step, bounded_interp.TRIED, min_saving=saving, few=self._pruned
            )
        tier = TIER_MID if bounded_interp.is_adaptive(inner) else TIER_FAST
        y = _to_float(rec, x.dtype, overwrite=True)
        return tier, self._finish(x, mask, y, FLAG_INTERP, [inner])

    def _cdf97_candidates(self, x, clean, mask, shortest=None, planned=None):
        """The float CDF 9/7 path at each step it tries; each checked on every voxel (none,
        or fewer, where it cannot come near ``shortest`` bytes: :func:`.bounded_cdf97.encode`;
        ``planned``: its layouts, if made)."""
        from . import bounded_cdf97 as w

        xf = x.reshape(-1).astype(np.float64)
        out = []

        def finish(inner, rec):
            err = _to_float(rec, x.dtype).reshape(-1).astype(np.float64)
            err = np.abs(np.subtract(err, xf, out=err), out=err)  # in place: same values
            if mask is not None:
                err[mask.reshape(-1)] = 0.0
            bad = np.flatnonzero(err > self.max_error)
            r = np.floor((xf[bad] - rec.reshape(-1)[bad]) / self.step + 0.5)
            keep = (r != 0) & (np.abs(r) < 2**31)  # the rest: exact corrections
            extra = []
            if keep.any():
                idx, bins = bad[keep], r[keep].astype(np.int64)
                extra.append(w.pack_outliers(idx, bins, x.shape))
                w.add_bins(rec, idx, bins, self.step)  # as the decoder will
            y = _to_float(rec, x.dtype)
            out.append(self._finish(x, mask, y, FLAG_CDF97, [inner], extra, FLAG_OUTLIERS))
            return len(out[-1][0])

        # (unmasked: the voxels' float64 copy serves both; the transforms make new arrays)
        g = xf.reshape(x.shape) if clean is x else clean.astype(np.float64)
        w.encode(g, self.max_error, self.coder, self.max_levels, finish, shortest, planned)
        return out

    # The coefficient path works on a fine integer grid: the voxels themselves for
    # integers, steps of E/16 for floats, leaving 15 of those steps (31E/32 with the
    # grid's rounding) for the coefficient quantisation.
    def _fine(self) -> tuple[float, int]:
        """(grid step, largest error allowed on the grid, in grid steps)."""
        if self.integer:
            return 1.0, (int(self.step) - 1) // 2
        return self.step / 32, 15

    def _coef_candidate(self, x, clean, mask):
        from ..entropy import CODERS
        from ..wavelet import sigmap

        fine, slack = self._fine()
        if self.integer:
            g = clean.astype(np.int64) - int(self.lo)
        else:
            g = np.rint((clean.astype(np.float64) - self.lo) / fine).astype(np.int64)
        if mask is not None:
            g = fill_masked(g, mask)
        body, rec = _code_coefficients(g.copy(), self, self._coef_steps, dead_zone=True)
        off = g - rec
        if mask is not None:
            off[mask] = 0
        # Voxels past the allowed grid error get a residual in units of 2s+1 grid steps,
        # which brings them back within s: mostly zeros and +-1, coded as a sparse field.
        width = 2 * slack + 1
        far = np.abs(off) > slack
        res = np.divide(off, width)  # floor(off / width + 0.5) where far, in place
        res += 0.5
        np.floor(res, out=res)
        res[~far] = 0.0
        res = res.astype(np.int64)
        del far, off
        extra = []
        if res.any():
            rec += res * width
            extra.append(
                CODERS[self._residual_coder].encode(res, sigmap.scan(x.shape, (0, 0, 0), "line"))
            )
        return self._finish(x, mask, self._from_grid(rec, x.dtype), FLAG_COEF, [body], extra)

    @property
    def _residual_coder(self) -> str:
        return self.coder if self.coder in ("arith", "arith2", "static", "auto") else "rle"

    def _coef_steps(self, shape, levels) -> np.ndarray:
        """Per-coefficient steps of the coefficient path, on the fine grid."""
        fine, _ = self._fine()
        base = COEF_STEP * max(self.max_error, 0.5) / fine
        return (base / band_scale(tuple(shape), tuple(levels))).reshape(shape)

    def _from_grid(self, g: np.ndarray, dtype: np.dtype) -> np.ndarray:
        fine, _ = self._fine()
        if self.integer:
            return _clip_to(g + int(self.lo), dtype)
        v = g.astype(np.float64) * fine + self.lo
        if dtype != np.float64:
            big = float(np.finfo(dtype).max)
            v = np.clip(v, -big, big)
        return v.astype(dtype)

    def _finish(self, x, mask, rec, flags, inner, residuals=(), residual_flag=FLAG_RESIDUALS):
        """Check every voxel of ``rec``, add the exact corrections and the mask, and
        assemble the payload; returns what :meth:`encode_measured` returns."""
        err = rec.astype(np.float64)  # |rec - x| in place (x cast to float64 as it goes)
        err = np.abs(np.subtract(err, x, out=err, dtype=np.float64), out=err)
        if mask is not None:
            err[mask] = 0.0
        bad = np.flatnonzero(err > self.max_error)
        parts = [b""] + [put_section(b) for b in inner]
        for body in residuals:
            flags |= residual_flag
            parts.append(put_section(body))
        if mask is not None:
            flags |= FLAG_MASK
            body = np.packbits(mask.reshape(-1)).tobytes() + as_stored(x[mask])
            parts.append(_section(body))
        if bad.size:
            flags |= FLAG_CORRECTIONS
            err.reshape(-1)[bad] = 0.0
            parts.append(put_section(pack_corrections(x, bad)))
        parts[0] = bytes([flags])
        valid = x.size - (int(mask.sum()) if mask is not None else 0)
        worst = float(err.max(initial=0.0))
        with np.errstate(over="ignore"):  # errors near 1e300 square to inf: PSNR unknown
            sse = float(np.sum(np.square(err, out=err)))  # in place: the same squares
        return Measured(b"".join(parts), worst, sse, valid)

    def encode(self, brick: np.ndarray) -> bytes:
        return self.encode_measured(brick)[0]

    def decode(self, data: bytes | memoryview, shape: tuple[int, ...], dtype: Any) -> np.ndarray:
        return self._decode(data, tuple(shape), np.dtype(dtype), None)

    def decode_into(self, data: bytes | memoryview, out: np.ndarray) -> None:
        """Into a view of the volume (any strides: a brick inside a larger volume) the
        float paths write their cast straight (no brick-sized copy)."""
        if out.flags.writeable and out.ndim == 3:
            self._decode(data, out.shape, out.dtype, out)
        else:
            super().decode_into(data, out)

    def _decode(self, data, shape, dtype, into: np.ndarray | None) -> np.ndarray:
        """The brick, written into ``into`` (of ``shape`` and ``dtype``, any strides) when
        given."""
        data = memoryview(data)
        n = math.prod(shape)
        if dtype.kind not in ("iu" if self.integer else "f"):  # (a damaged header's dtype)
            kind = "integers" if self.integer else "floats"
            raise FormatError(f"bounded brick payload: voxels of {dtype}, a config for {kind}")
        if len(data) < 5:
            raise FormatError(
                f"bounded brick payload: expected at least 5 bytes, found {len(data)}"
            )
        flags = data[0]
        if flags & ~_KNOWN_FLAGS:
            raise FormatError(f"bounded brick payload: unknown flags {flags:#x}")
        pos = 1
        inner, pos = _take(data, pos, len(data))
        if flags & FLAG_EXACT:
            if flags != FLAG_EXACT or dtype.kind != "f":
                raise FormatError(
                    "bounded brick payload: the exact path is for float voxels, alone"
                )
            from . import fastexact

            if len(inner) and inner[0] == fastexact.MARK:  # effort 'fast': step 19b
                out = fastexact.decode(inner, tuple(shape), dtype)
            else:
                out = self._lossless().decode(inner, tuple(shape), dtype)
        elif flags & FLAG_INTERP:
            out = self._decode_interp(flags, inner, tuple(shape), dtype, into)
        elif flags & FLAG_CDF97:
            out = self._decode_cdf97(flags, data, inner, pos, tuple(shape), dtype, into)
            pos = out[1]
            out = out[0]
        elif flags & FLAG_OUTLIERS:
            raise FormatError("bounded brick payload: outliers without the cdf97 path")
        elif flags & FLAG_COEF:
            g = _decode_coefficients(inner, tuple(shape), self, self._coef_steps, dead_zone=True)
            if flags & FLAG_RESIDUALS:
                from ..entropy import CODERS
                from ..wavelet import sigmap

                body, pos = _take(data, pos, len(data))
                res = np.empty(tuple(shape), np.int64)
                CODERS[self._residual_coder].decode(
                    body, sigmap.scan(tuple(shape), (0, 0, 0), "line"), res
                )
                g += res * (2 * self._fine()[1] + 1)
            out = self._from_grid(g, dtype)
        elif not flags & FLAG_RESIDUALS and len(inner) and inner[0] == QVOX_FAST:
            out = self._reconstruct_fast(memoryview(inner)[1:], shape, dtype, into)
        else:
            if flags & FLAG_RESIDUALS:  # the quantised voxels by the long fitted predictor
                from . import bounded_longfit

                q = bounded_longfit.decode(inner, shape, np.dtype(self.qdtype), self._lossless())
            else:
                q = self._lossless().decode(inner, shape, np.dtype(self.qdtype))
            out = self._reconstruct(q, dtype, into)
        if into is not None and out is not into:
            into[...] = out
            out = into
        sd = storage_dtype(dtype)
        if flags & FLAG_MASK:
            body, pos = _take(data, pos, n // 8 + 1 + n * sd.itemsize, zstd=True)
            nb = (n + 7) // 8
            if len(body) < nb:
                raise FormatError("bounded brick payload: mask section too short")
            mask = np.unpackbits(np.frombuffer(body[:nb], np.uint8), count=n).astype(bool)
            k = int(mask.sum())
            out[mask.reshape(out.shape)] = from_stored(body[nb:], (k,), dtype)  # C order
        if flags & FLAG_CORRECTIONS:
            body, pos = _take(data, pos, len(data))
            apply_corrections(body, out, "bounded brick payload")
        if pos != len(data):
            raise FormatError(f"bounded brick payload: {len(data) - pos} stray bytes at the end")
        return out

    def _decode_interp(self, flags, inner, shape, dtype, into=None):
        from . import bounded_interp

        if flags & (FLAG_COEF | FLAG_RESIDUALS | FLAG_CDF97 | FLAG_OUTLIERS) or dtype.kind != "f":
            raise FormatError(
                "bounded brick payload: the interpolation path is for float voxels, without "
                "the other paths' flags"
            )
        rec = bounded_interp.decode(inner, shape, self.step)
        out = _to_float(rec, dtype, overwrite=True, out=into)
        if into is not None:  # the caller copies anything else in, in one pass
            return out
        return np.ascontiguousarray(out)  # the axes back in C order

    def _decode_cdf97(self, flags, data, inner, pos, shape, dtype, into=None):
        from . import bounded_cdf97 as w

        if flags & (FLAG_COEF | FLAG_RESIDUALS) or dtype.kind != "f":
            raise FormatError(
                "bounded brick payload: the cdf97 path is for float voxels, without the "
                "coefficient path's flags"
            )
        rec = w.decode(inner, shape, self.coder, self.max_levels)
        if flags & FLAG_OUTLIERS:
            body, pos = _take(data, pos, len(data))
            w.apply_outliers(body, rec, self.step, self._residual_coder)
        return _to_float(rec, dtype, overwrite=True, out=into), pos


def on_bins(lo: float, step: float, modes: tuple[float, ...]) -> tuple[float, float]:
    """``(lo', step')``, ``lo' <= lo`` and ``step' <= step``, whose bins ``lo' + k step'``
    have the values ``modes`` (most common first) on their centres, so that the voxels
    holding them come back exactly and their neighbours' noise does not straddle a bin
    edge: the two most common both where a whole number of bins at least half as wide
    spans them, else the most common alone (same bins, moved). A field's plateaus (a
    species' mass fraction at 0 and at its burnt value, a clipped floor, the zeros of a
    tensor field whose minimum is below 0) then cost neither error nor bits, and the
    PSNR no longer jumps with the bound as a plateau's value drifts across the bins."""
    anchor = modes[0]
    if len(modes) > 1:
        a, b = sorted(modes[:2])
        k = max(math.ceil((b - a) / step), 1)
        if (b - a) / k >= step / 2:
            anchor, step = a, (b - a) / k
    return anchor - math.ceil((anchor - lo) / step) * step, step


def keep_faster(
    cands: list[tuple[int, Measured]], saving: float = SLOW_MIN_SAVING, cost=None
) -> Measured:
    """The coding to keep of ``(decoding tier, coding)`` pairs: the shortest, except
    that one of a slower tier than the best of the faster ones must be shorter than it
    by ``saving`` of its bytes (``SLOW_MIN_SAVING``: the adaptive codings decode at a
    third to a half of the speed of the static ones for a few per cent of the bytes).
    Ties keep the faster tier, then the first. With ``cost`` (a coding's cost,
    :meth:`BoundedCodec._cost`) the least cost is kept, a slower tier's only where its
    cost is lower by ``saving`` of the faster one's bytes (of its cost, the slower tier
    was charged for the distortion too: isabel_pfill at 80 dB kept 127,900 bytes for
    125,251 at the same PSNR, session 38)."""
    order = sorted(cands, key=lambda c: c[0])
    best_tier, best = order[0]
    for tier, m in order[1:]:
        if cost is None:
            limit = len(best[0]) * (1.0 - saving) if tier > best_tier else len(best[0])
            if len(m[0]) < limit:
                best_tier, best = tier, m
            continue
        limit = cost(best) - (saving * len(best[0]) if tier > best_tier else 0.0)
        if cost(m) < limit:
            best_tier, best = tier, m
    return best


def _shorter(a: bytes | None, b: bytes | None) -> bool:
    """Whether ``a`` is a shorter coding than ``b`` (None: no coding, the longest)."""
    return a is not None and (b is None or len(a) < len(b))


def _exact_may_pay(x: np.ndarray, max_error: float) -> bool:
    """Whether the float brick ``x`` is coarse enough next to bins of ``2 max_error`` for
    the exact path to be worth trying (``EXACT_MIN_STEP``, ``EXACT_MAX_DISTINCT``)."""
    from .floatpredict import find_lattices

    if x.size < 64 or x.ndim != 3:
        return False
    # Distinct finite values per z slice: at most the brick's, and a slice on a grid of
    # step s spans at least (count - 1) s. Most fields leave here, after one sort.
    v = np.sort(x.reshape(x.shape[0], -1).astype(np.float64), axis=1)
    with np.errstate(invalid="ignore", over="ignore"):
        d = np.diff(v, axis=1)
        count = 1 + np.count_nonzero(np.isfinite(d) & (d != 0), axis=1)
        span = v[:, -1] - v[:, 0]
        lo, hi = np.fmin.reduce(v[:, 0]), np.fmax.reduce(v[:, -1])  # NaN only if all are
    most = int(count.max())
    if most <= EXACT_MAX_DISTINCT * x.size and not most * 2.0 * max_error > hi - lo:
        u = np.unique(x[np.isfinite(x)])
        if u.size and u.size <= EXACT_MAX_DISTINCT * x.size and (
            u.size * 2.0 * max_error <= float(u[-1]) - float(u[0])
        ):
            return True
    coarse = (count - 1) * (EXACT_MIN_STEP * 2.0 * max_error) <= span
    if 2 * np.count_nonzero(coarse) < coarse.size:
        return False
    for params, _, _ in find_lattices(x):
        if np.median(np.abs(params[:, 1])) >= EXACT_MIN_STEP * 2.0 * max_error:
            return True
    return False


def _near_exact(x: np.ndarray, nbytes: int) -> bool:
    """Whether a float brick's quick lossless stand-in comes within ``EXACT_PROXY`` of
    ``nbytes``, the shortest bounded coding (see ``EXACT_PROXY``)."""
    from .codec import ZstdCodec

    if EXACT_PROXY <= 0 or x.size < 64 or x.ndim != 3:
        return False
    return len(ZstdCodec(level=3).encode(x)) <= EXACT_PROXY * nbytes


def _to_float(v: np.ndarray, dtype: np.dtype, overwrite: bool = False, out=None) -> np.ndarray:
    """Float64 values cast to the float ``dtype``, clipped to its finite range (in ``v``
    itself when ``overwrite``; the float32 cast, C-ordered, possibly into ``out`` of
    ``v``'s shape, both of any strides when 3-D)."""
    contiguous = v.flags.c_contiguous and (out is None or out.flags.c_contiguous)
    if dtype == np.float32 and v.dtype == np.float64 and (contiguous or v.ndim == 3):
        from .floatcast import to_float32

        return to_float32(v, out)  # one pass, same values
    if dtype != np.float64:
        big = float(np.finfo(dtype).max)
        v = np.clip(v, -big, big, out=v if overwrite else None)
    return v.astype(dtype, copy=not overwrite)


def _code_coefficients(g, codec, steps_of, *, dead_zone: bool):
    """Transform ``g`` (int64, overwritten), quantise its coefficients with
    ``steps_of(shape, levels)`` and code them with ``codec``'s wavelet, scan and coder.

    Returns the coded bytes and the integers the decoder will rebuild from them.
    """
    from ..entropy import CODERS
    from ..wavelet import dwt3, sigmap

    levels = dwt3.levels_for_shape(g.shape, codec.max_levels)
    steps = steps_of(g.shape, levels)
    c = dwt3.forward(g, levels, codec.wavelet, overwrite=True)
    q = _quantize_coefs(c, steps, dead_zone)
    body = CODERS[codec.coder].encode(q, sigmap.scan(g.shape, levels, codec.order))
    return body, _rebuild_coefficients(q, steps, levels, codec.wavelet, dead_zone)


def _decode_coefficients(body, shape, codec, steps_of, *, dead_zone: bool) -> np.ndarray:
    """The decoding side of :func:`_code_coefficients`."""
    from ..entropy import CODERS
    from ..wavelet import dwt3, sigmap

    levels = dwt3.levels_for_shape(shape, codec.max_levels)
    q = np.empty(shape, np.int64)
    CODERS[codec.coder].decode(bytes(body), sigmap.scan(shape, levels, codec.order), q)
    return _rebuild_coefficients(q, steps_of(shape, levels), levels, codec.wavelet, dead_zone)


def _rebuild_coefficients(q, steps, levels, wavelet: str, dead_zone: bool) -> np.ndarray:
    from ..wavelet import dwt3

    c = _dequantize_coefs(q, steps, dead_zone)
    return dwt3.inverse(c, levels, wavelet, overwrite=True)


def _section(body: bytes) -> bytes:
    return put_section(deflate(body))


def _take(data: memoryview, pos: int, limit: int, zstd: bool = False) -> tuple[bytes, int]:
    """One length-prefixed section from ``pos``; zstd sections are inflated to at most
    ``limit`` bytes."""
    body, end = take_section(data, pos, "lossy brick payload")
    if zstd:
        body = inflate(body, limit, "lossy brick payload section")
    return body, end


def pack_corrections(x: np.ndarray, idx: np.ndarray) -> bytes:
    """The voxels ``x.flat[idx]`` stored exactly (uint32 indices, then the values as
    stored), zstd'd: what a bounded coder keeps where rounding to the output dtype
    pushed a voxel past its bound (the lossy bricks, the animation frames and the
    octree nodes share this layout)."""
    return deflate(idx.astype("<u4").tobytes() + as_stored(x.reshape(-1)[idx]))


def apply_corrections(data, out: np.ndarray, what: str) -> None:
    """Put the voxels of :func:`pack_corrections` back into ``out`` (their indices
    count in C order; ``out`` of any strides); a corrupt section raises FormatError
    naming ``what``."""
    n = out.size
    item = 4 + storage_dtype(out.dtype).itemsize
    body = inflate(data, n * item, f"{what} corrections")
    k = len(body) // item
    if k * item != len(body):
        raise FormatError(f"{what}: the corrections have a ragged length")
    idx = np.frombuffer(body[: 4 * k], "<u4").astype(np.int64)
    if k and idx.max() >= n:
        raise FormatError(f"{what}: a correction points outside the data")
    values = from_stored(body[4 * k :], (k,), out.dtype)
    if out.flags.c_contiguous:
        out.reshape(-1)[idx] = values
    else:  # a view of a larger volume: reshape would copy
        out[np.unravel_index(idx, out.shape)] = values


# -- the thesis's coefficient modes -----------------------------------------------------


@dataclasses.dataclass(frozen=True, eq=False, repr=False)
class CoefCodec(BrickCodec):
    """Thresholding (``threshold``) or dead-zone quantisation (``quality``) of the
    integer lifting coefficients, in orthonormal units (see ``formats/lossy-1.md``).

    ``value_range`` is the volume's range; ``quality`` Q sets the orthonormal step to
    ``value_range / (Q + 1)``. ``threshold`` T zeroes coefficients whose orthonormal
    magnitude is below T and keeps the others exactly.
    """

    codec_id: ClassVar[str] = "coef"
    lossless: ClassVar[bool] = False
    value_range: float
    quality: int | None = None
    threshold: float | None = None
    step: float | None = None  # the orthonormal step itself (what --psnr/--ratio search)
    wavelet: str = "53"
    coder: str = "arith"
    order: str = "dfs"
    max_levels: int | None = None

    def __post_init__(self) -> None:
        _check_inner(self)
        if sum(v is not None for v in (self.quality, self.threshold, self.step)) != 1:
            raise OptionError("expected exactly one of quality, threshold and step")
        if self.step is not None and not (self.step > 0 and math.isfinite(self.step)):
            raise OptionError(f"expected a positive step, found {self.step!r}")
        if self.quality is not None and not 1 <= int(self.quality) <= 65535:
            raise OptionError(f"expected a quality in 1..65535, found {self.quality!r}")
        if self.threshold is not None and not (0 <= self.threshold < math.inf):
            raise OptionError(f"expected a finite threshold >= 0, found {self.threshold!r}")
        if not (0 <= self.value_range < 2**53):
            raise OptionError(f"expected a finite value_range >= 0, found {self.value_range!r}")

    def _steps(self, shape, levels) -> np.ndarray:
        scale = band_scale(tuple(shape), tuple(levels)).reshape(shape)
        if self.quality is not None:
            return (self.value_range / (int(self.quality) + 1)) / scale
        if self.step is not None:
            return float(self.step) / scale
        return float(self.threshold) / scale

    @property
    def _dead_zone(self) -> bool:
        return self.threshold is None

    def encode_measured(self, brick: np.ndarray) -> Measured:
        from .codec import check_wavelet_dtype

        x = np.ascontiguousarray(brick)
        check_wavelet_dtype(x.dtype)
        value = constant_value(x)
        if value is not None:
            return Measured(bytes([MODE_CONSTANT]) + value, 0.0, 0.0, x.size)
        body, rec = _code_coefficients(
            x.astype(np.int64), self, self._steps, dead_zone=self._dead_zone
        )
        payload = bytes([MODE_CODED]) + body
        if len(payload) > x.nbytes + 1:  # quantisation did not pay: store it exactly
            return Measured(bytes([MODE_RAW]) + as_stored(x), 0.0, 0.0, x.size)
        err = np.abs(_clip_to(rec, x.dtype).astype(np.float64) - x)
        return Measured(payload, float(err.max(initial=0.0)), float(np.sum(err * err)), x.size)

    def encode(self, brick: np.ndarray) -> bytes:
        return self.encode_measured(brick)[0]

    def decode(self, data: bytes | memoryview, shape: tuple[int, ...], dtype: Any) -> np.ndarray:
        dtype = np.dtype(dtype)
        data = memoryview(data)
        if len(data) < 1:
            raise FormatError("empty coef brick payload: expected at least a mode byte")
        mode, body = data[0], data[1:]
        if mode == MODE_RAW:
            return from_stored(body, shape, dtype)
        if mode == MODE_CONSTANT:
            return np.full(shape, from_stored(body, (1,), dtype)[0], dtype=dtype)
        if mode != MODE_CODED:
            raise FormatError(f"coef brick payload: expected mode 0, 1 or 2, found {mode}")
        rec = _decode_coefficients(body, tuple(shape), self, self._steps, dead_zone=self._dead_zone)
        return _clip_to(rec, dtype)


def _clip_to(v: np.ndarray, dtype: np.dtype) -> np.ndarray:
    info = np.iinfo(dtype)
    return np.clip(v, info.min, info.max).astype(dtype)


# The dead-zone quantiser: bins of width ``step`` whose zero bin reaches 0.75 step on each
# side (a plain rounder's reaches 0.5), values rebuilt 1/8 step above the bin's start.
# At ``step`` = 1 it gives back every integer exactly, so rate and error change smoothly
# as the step crosses 1 (steps at or below 1 keep the coefficient).
# The coefficient quantiser (formats/lossy-1.md, `coef`).
DEAD_ZONE_OFFSET = 0.25
REBUILD_OFFSET = 0.125


def _quantize_coefs(c: np.ndarray, steps: np.ndarray, dead_zone: bool) -> np.ndarray:
    if not dead_zone:  # threshold: small coefficients dropped, the rest kept
        return np.where(np.abs(c) < steps, 0, c).astype(np.int64)
    # sign(c) floor(|c| / step + offset), the coefficient itself where the step is at
    # most 1, in one float64 array (the same operations as over whole temporaries)
    exact = steps <= 1.0
    q = np.where(exact, 1.0, steps)
    np.divide(np.abs(c), q, out=q)
    q += DEAD_ZONE_OFFSET
    np.floor(q, out=q)
    np.multiply(np.sign(c), q, out=q)
    q[exact] = c[exact]  # (as float64, like np.where's: then cast back)
    return q.astype(np.int64)


def _dequantize_coefs(q: np.ndarray, steps: np.ndarray, dead_zone: bool) -> np.ndarray:
    if not dead_zone:
        return np.ascontiguousarray(q, dtype=np.int64)
    # sign(q) floor((|q| + offset) step + 0.5), 0 for q = 0 and q itself where the step
    # is at most 1, in one float64 array (the same operations as over whole temporaries)
    exact = steps <= 1.0
    mag = np.abs(q) + REBUILD_OFFSET
    mag *= steps
    mag += 0.5
    np.floor(mag, out=mag)
    np.multiply(np.sign(q), mag, out=mag)  # 0 where q is
    mag[exact] = q[exact]
    return np.ascontiguousarray(mag, dtype=np.int64)


def band_scale(shape: tuple[int, int, int], levels: tuple[int, int, int]) -> np.ndarray:
    """:func:`volpack.wavelet.dwt3.band_scale` (imported on first call: it loads numba)."""
    from ..wavelet.dwt3 import band_scale as scale

    return scale(shape, levels)


def _check_inner(c) -> None:
    check_choice("wavelet", c.wavelet, WAVELET_NAMES)
    check_choice("coder", c.coder, CODER_NAMES)
    check_choice("order", c.order, ORDER_NAMES)
