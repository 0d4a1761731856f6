"""The ``lossless`` brick codec: each brick coded by the tool that suits it.

The wavelet codec (:mod:`.codec`) suits smooth, noisy scans; a sharp edge against
a flat background (skull-stripped MRI), a sparse histogram (rescaled scans) or floats
suit 3-D prediction (:mod:`.predict`) better. This codec tries the tools on every
brick and keeps the shortest payload, so a volume gets what each of its bricks needs.
The payload's first byte says what was chosen:

====  ===============================================================================
mode  payload after the mode byte
====  ===============================================================================
0-3   as the ``wavelet`` codec's modes (coefficients, raw, constant, byte-shuffled zstd)
4     3-D prediction: a flags byte (1: palette, 2: float bits, 4: floats split into
      exponent and mantissa, 8: labels copied from neighbours, 16: the predictive
      stream of version 2 (:mod:`.predictfit`), 32: a background mask, 64: version 2
      with the low-value models, 128: version 2 with the texture bias; 8 with 16, which
      excludes labels: a second flags byte follows, bit 0 of it (flag 256) the mixed
      estimates, bit 1 (flag 512) the local fit, bit 2 (flag 1024) the brick's slices
      coded as one plane by the planar predictor), then the palette or the value range
      (none when split), the mask, then the predictive or label stream
5     floats by prediction on their integer images (:mod:`.floatpredict`): a tool byte
      (0: Lorenzo, 1: lattice, 2: blend of predictors with copies and a fill value,
      :mod:`.floatmix`, 3: a least-squares predictor fitted per brick, or Lorenzo,
      with 16-bit models, :mod:`.floatfit`), then its stream
6     slices in equal runs (:mod:`.repeat`, version 8 on): the runs along z, y, x,
      then the payload (mode 0-5) of the brick shrunk to one slice a run
7     mirrored halves (:mod:`.mirror`, version 8 on, since session 37): a byte of the
      axes the brick equals its mirror image along, then the payload (mode 0-5) of the
      brick cut to its first half (``ceil(n / 2)`` slices) along each
8     a gain comb (:mod:`.gain`, integer bricks, version 8 on, since session 38): the
      period g, the shift s and the length of the counts' payload (ULEB128 each), the
      payload (mode 0-5) of the counts ``k = (v + s) // g``, then that of the residues
      ``r = v + s - g k``
====  ===============================================================================

``predict_version`` (a config field) says which predictive stream the encoder writes for
integer bricks: 1 (:mod:`.predict`, the files written before version 2 existed; their
headers have no ``predict_version`` and read as 1) or 2 (a fitted predictor, and a background
mask where it pays). Version 3 codes integer bricks as 2 and adds, for float
bricks, the tools of mode 5 and zstd at level 19 in mode 3 (where it may beat level 9:
see ``ZSTD_19_OVER_9``). Version 4 adds mode 5's blend (tool 2) for
float32 and float64 bricks. Version 5 adds, for integer bricks, version
2's stream with the low-value models of :mod:`.predictfit` (flag 64), where it is the
shorter. Version 6 adds mode 5's fitted predictor (tool 3) for float32 and
float64 bricks. Version 7 adds, for integer bricks, version 2's stream with
the texture bias of :mod:`.predictfit` (flag 128), where it is the shorter. Version 8 (the
default) adds, for integer bricks, version 2's stream with the residual's decisions
coded by a mix of four estimates (:mod:`.residmix`, flag 256), where it saves
``MIX_MIN_SAVING`` of the bytes (it decodes slower); on a thin integer brick (at most
``PLANE_SLICES`` slices of ``PLANE_AREA`` voxels or more) it also codes version 2's
stream with the slices as one plane (flag 1024, :data:`.predictfit.PLANE_OFFSETS`: a few
thick slices have little to gain along z), kept where shorter. Version 9 (``effort='max'``) adds
the blend weighted against a predictor refitted along every row (:mod:`.localfit`, flag
512), wherever it is shorter (it decodes 3-11x slower again). A decoder reads every version,
whatever the config says.

Floats (float16, float32, float64) are coded exactly through integer images of their
bits (:mod:`.floatbits`, :mod:`.floatpredict`); NaN, -0.0, denormals and Inf come back
bit for bit. float64 bricks take modes 1, 2, 3 and 5 only.
``formats/lossless-1.md`` gives every byte. ``volpack info`` reports how many bricks
took each tool (:func:`describe`).
"""

from __future__ import annotations

import dataclasses
import functools
from typing import Any, ClassVar

import numpy as np

from ..errors import FormatError
from . import bgmask, gain, mirror, repeat
from . import palette as pal
from .codec import (
    MODE_CONSTANT,
    MODE_RAW,
    MODE_ZSTD,
    WAVELET_DTYPES,
    WaveletCodec,
    ZstdCodec,
    piecewise_constant,
)
from .floatbits import FLOAT_DTYPES, from_ordered, to_ordered
from .protocol import BrickCodec, as_brick, split_mode
from .protocol import as_stored as _as_stored
from .protocol import check_choice as _check_choice
from .protocol import from_stored as _from_stored

MODE_PREDICT = 4
MODE_FLOAT = 5
MODE_REPEAT = 6  # slices in equal runs along an axis (:mod:`.repeat`), then mode 0-5
# Mode 6 is tried from this predict_version on (session 34, results/lossless/kinds34);
# REPEAT = False: not tried (the measurements' "before").
REPEAT_VERSION = 8
REPEAT = True
# Kept only where it saves this share of the brick's bytes and more than REPEAT_MIN_BYTES:
# its decoder makes one more pass, and a new tool's entry in the file's summary costs
# about 20 bytes. Slices that repeat by chance (a brick edge with one slice of tissue)
# saved 5-23 bytes a brick on six corpus volumes and made two files 2-5 bytes longer; an
# upsampled label brick saves about half its bytes.
REPEAT_MIN_SAVING = 0.05
REPEAT_MIN_BYTES = 32
MODE_MIRROR = 7  # a brick equal to its mirror image along axes (:mod:`.mirror`), then mode 0-5
# Mode 7 is tried from this predict_version on (session 37, results/kinds37: a hydrogen
# atom's density, symmetric in z and y, was 0.684x zstd-19); kept by the rule of mode 6.
# MIRROR = False: not tried (the measurements' "before").
MIRROR_VERSION = 8
MIRROR = True
MODE_GAIN = 8  # integers that are a count times a gain plus noise (:mod:`.gain`): k, then r
# Mode 8 is tried from this predict_version on (session 38, results/kinds38: detector
# frames of photons times 30 ADU plus read noise were 1.003x JPEG-XL e9, 1.175x their
# Shannon bound); kept by the rule of mode 6. GAIN = False: not tried (the "before").
GAIN_VERSION = 8
GAIN = True
# Modes that wrap another brick payload: the payload they wrap is mode 0-5, never one of these
WRAPPING = (MODE_REPEAT, MODE_MIRROR, MODE_GAIN)
FLOAT_TOOLS = ("lorenzo", "lattice", "blend", "fit")  # the tool byte of mode 5 indexes this
FLOAT_BLEND = 2
FLOAT_FIT = 3
FIT_VERSION = 6  # the first predict_version whose encoder tries the fitted predictor
FIT_BOXED = 8  # tool 3's predictor byte from here on: with a box fit (floatfit.BOXED)
# The blend (mode 5, tool 2) decodes at about 0.7x the speed of one Lorenzo predictor
# (and far slower than zstd): it is kept only when it saves this share of the bytes.
BLEND_MIN_SAVING = 0.02
# The fitted predictor saves 0.4-6.3 % of the best Lorenzo stream's bytes on the 28 float
# fields of the benchmark: where another tool is already this share shorter than Lorenzo
# (lattices, split floats: integers stored as floats), the fit cannot win and is not run.
FIT_MAX_GAIN = 0.25
FIT_MAX_GAIN_BOX = 0.5  # with the box fit (version 10), up to 20 % on the CAM fields
EXACT_FLOATS = FLOAT_DTYPES + ("float64",)
# 64-bit integers (connectomics label ids, numpy's default integer) take the raw, zstd and
# palette payloads (labels, prediction of ranks), and prediction of the values only where
# they lie in the range 32-bit bricks take: the wavelet and the predictors work in that
# range. uint64 voxels are read as the int64 of the same bits (their palette order).
LONG_INTS = ("int64", "uint64")
NARROW = (-(1 << 31), (1 << 32) - 1)  # the values the predictors of 32-bit voxels span
# Every voxel type the codec takes (masks last: coded as their uint8 bytes)
LOSSLESS_DTYPES = WAVELET_DTYPES + LONG_INTS + EXACT_FLOATS + ("bool",)
FLAG_PALETTE, FLAG_FLOAT, FLAG_SPLIT, FLAG_LABELS, FLAG_FIT, FLAG_MASK = 1, 2, 4, 8, 16, 32
FLAG_LOW, FLAG_TEX = 64, 128
# With FIT, the LABELS bit (which FIT excludes) says a second flags byte follows: flags
# 256 and up, MIX (256), LOCAL (512), PLANE (1024) and LOWM (2048: with LOW, the
# low-value class's mantissa bits in models keyed on the prediction, predictfit.LOW_MANT).
FLAG_MORE, FLAG_MIX, FLAG_LOCAL, FLAG_PLANE, FLAG_LOWM = FLAG_LABELS, 256, 512, 1024, 2048
FLAGS = (
    FLAG_PALETTE | FLAG_FLOAT | FLAG_SPLIT | FLAG_LABELS | FLAG_FIT | FLAG_MASK | FLAG_LOW | FLAG_TEX
    | FLAG_MIX | FLAG_LOCAL | FLAG_PLANE | FLAG_LOWM
)  # fmt: skip
LOWM = True  # False: the encoder never tries LOWM (the tests compare)
VERSIONS = (1, 2, 3, 4, 5, 6, 7, 8, 9, 10)
LOW_VERSION = 5  # the first predict_version whose encoder tries the low-value models
TEX_VERSION = 7  # the first predict_version whose encoder tries the texture bias
MIX_VERSION = 8  # the first predict_version whose encoder tries the mixed estimates
# The mix decodes at about half the speed of version 7's stream: kept only when it saves
# this share of the brick's bytes.
MIX_MIN_SAVING = 0.003
# The planar stream (flag 1024; session 33, results/lossless/thin33) is tried from
# MIX_VERSION on, on integer bricks of at most PLANE_SLICES slices of PLANE_AREA voxels or
# more (smaller slices do not repay the second chain's time; 64x64 or less leaves the
# golden streams as they were), where the planar fit's sums stay exact (PLANE_EXACT).
PLANE_SLICES = 16
PLANE_AREA = 64 * 64 + 1
PLANE_EXACT = 1 << 53
# A brick of 3 slices or more tries it only where its slices differ from one another by
# PLANE_STEP times as much as neighbours in a slice do (mean absolute differences): 5.6x
# on the CT resampled to 8 thick slices (the planar stream 4.6 % shorter), 0.93x on the
# 12x1024^2 microscopy stack (0.65 % longer: the z taps average its noise away; its sample
# put the planar chain 0.24 % ahead).
PLANE_STEP = 2.0
# With PRUNE, the planar chain codes in full only its pick on the sample (its doubts cost
# more time than they saved), and nothing where the sample puts it this share behind the
# 3-D chain's estimate (set by hand: it acted on no volume of results/lossless/thin33).
PLANE_MARGIN = 0.005
LOCAL_VERSION = 9  # the first predict_version whose encoder tries the local fit
# The local fit decodes at a third to a tenth of the mix's speed (a 17 x 17 system
# solved at every second voxel); version 9 is asked for ratio (effort 'max'), so it is
# kept wherever it is shorter.
LOCAL_MIN_SAVING = 0.0
# The first predict_version whose encoder tries tool 3 with a box fit (effort 'max': its
# hundreds of weights a voxel decode several times slower than the 23 of version 6).
BOX_VERSION = 10
# The default version's selection for integer bricks (session 30, results/lossless/lenc30):
# the chain of _encode_fit is run on a sample of the brick, SLABS slabs of a sixteenth of
# its slices each, spread evenly along its longer axis of z and y and joined (one central
# slab missed backgrounds and regions that change along z), and only the variant it
# reaches is coded in full, with each variant one of the slab's decisions made by less
# than its margin would turn (DOMAIN_MARGIN for palette ranks against values, PRUNE_MARGIN
# for the others) and the variant with one gradient class (which the joined slabs rank
# badly): the shortest of those kept. The version-1 predictor is coded in full only where
# the sample puts it within V1_MARGIN of the chain (it won no brick of the corpus at a
# tenth of a percent). False: every variant coded in full, as before (the exhaustive mode
# the tests compare with).
PRUNE = True
SLABS = 4
SLAB_MIN = 32  # slices along the sampled axis: a thinner brick is coded as before
JOIN = 2  # the predictor's reach back along the axis: slices of context before each slab
DOMAIN_MARGIN = 0.005
PRUNE_MARGIN = 0.0015
# The low-value models and the texture bias learn slowly: a sample shortens their gain
# (mri_itk_t1: 0.7 % in full, below 0 on the sample), so they are also coded in full
# where the sample puts them up to this share behind.
LEARN_MARGIN = 0.01
# One gradient class against four: the sample's ranking of them is poor (fitted to the
# brick, the four classes' thresholds cut the sample's few voxels unevenly), so one class
# is also coded in full where the sample puts it up to this share ahead.
ONE_MARGIN = 0.01
V1_MARGIN = 0.05
# A brick the sample puts under this many bytes a voxel is coded in full as before (the
# models' learning, paid on the sample again and scaled up, dominates such estimates: 9046
# bytes for 5433 on labels_itk_skullstrip, whose sample chose the mask wrongly, +4.8 %),
# unless the wavelet's or the labels' payload is SMALL_FACTOR shorter than the estimate.
SMALL_PAYLOAD = 0.02
SMALL_FACTOR = 2
TOOLS = ("auto", "wavelet", "predict")
FLOAT_ZSTD_LEVEL = 9
FLOAT_ZSTD_LEVEL_V3 = 19  # floats compress slowly either way; 19 finds repeats 9 misses
ZSTD_19_OVER_9 = 0.75  # the smallest share of level 9's bytes level 19 is assumed to reach
# The default version's float bricks (session 31, results/lossless/flen31): zstd at 19
# costs 10-25x level 9 and won no brick of the float tuning set (3-300 % behind the best
# tool; 15-40 % of the encoder's time). Where the brick is thick enough to sample (along z
# and y where each is SLAB_MIN or more, as the integer chain's sample), level 19 runs in
# full only where level 9's bytes, scaled by 19's share of 9's on the sample, come within
# ZSTD_MARGIN of the best payload (on a sixteenth of the voxels the share was off by -0.12
# to +0.13 of the brick's, mostly by less than 0.02).
ZSTD_MARGIN = 0.02
PRUNE_FLOAT = True  # False: the float tools tried as before (the tests compare)
# With PRUNE_FLOAT, the Lorenzo predictors, the blend and the split floats are first coded
# on a block of the brick (:mod:`.floatprobe`); the blend and the split floats are coded in
# full only where the block's estimate, less this share, is under the shortest payload.
PROBE_MARGIN = 0.03
# The fit (version 8) saved at most 6.3 % of the best Lorenzo stream on the 28 float fields
# (and at most 4.9 % on flen31's tuning bricks): where the blend is so much shorter than
# Lorenzo that it would be kept over a fit this much shorter, the fit is not run.
FIT_BLEND_GAIN = 0.1


@dataclasses.dataclass(frozen=True, eq=False, repr=False)
class LosslessCodec(BrickCodec):
    """Per-brick choice of wavelet coding or 3-D prediction (with a palette), lossless.

    Parameters
    ----------
    wavelet, coder, order, max_levels
        Settings of the wavelet tool (see :class:`volpack.codec.WaveletCodec`).
    tools : {"auto", "wavelet", "predict"}
        ``auto`` tries both tools on every brick and keeps the shorter; the others use
        one tool (for comparison; floats always use prediction).
    predict_version : {1, 2, 3, 4, 5, 6, 7, 8, 9, 10}
        The predictive stream written for integer bricks: 2 (a fitted predictor and a
        background mask) or 1 (the earlier one, for identical files); 3 codes integers
        as 2 and floats also by Lorenzo or lattice prediction (mode 5); 4 also by the
        blend of predictors with copies and a fill value (mode 5, tool 2); 5 as 4,
        integers also with the low-value models; 6 as 5, float32 and float64 also by a
        predictor fitted per brick (mode 5, tool 3); 7 as 6, integers also with the
        texture bias; 8 (the default) as 7, integers also with the mixed estimates; 9
        as 8, integers also averaged with the local fit (slower to decode); 10 as 9,
        float32 and float64 also by tool 3 with a box fit (slower to decode).
    """

    codec_id: ClassVar[str] = "lossless"
    wavelet: str = "53"
    coder: str = "arith"
    order: str = "dfs"
    max_levels: int | None = None
    tools: str = "auto"
    predict_version: int = 8

    def __post_init__(self) -> None:
        _check_choice("tools", self.tools, TOOLS)
        _check_choice("predict_version", self.predict_version, VERSIONS)
        self._wavelet_codec()  # checks the wavelet settings

    def get_config(self) -> dict[str, Any]:
        """As stored in a header; version 1 is stored as the files before it were (no
        ``predict_version`` field), so that they are reproduced byte for byte."""
        config = super().get_config()
        if self.predict_version == 1:
            del config["predict_version"]
        return config

    @classmethod
    def from_config(cls, config: Any) -> BrickCodec:
        if isinstance(config, dict) and "predict_version" not in config:
            config = {**config, "predict_version": 1}
        return super().from_config(config)

    @staticmethod
    def describe(payload: bytes) -> str:
        """The tool a brick payload used (``volpack info`` counts them)."""
        return describe(payload)

    def _wavelet_codec(self) -> WaveletCodec:
        return WaveletCodec(self.wavelet, self.coder, self.order, self.max_levels)

    def encode(self, brick: np.ndarray) -> bytes:
        brick = as_brick(brick, check_dtype)
        if brick.dtype == np.bool_:  # a mask: coded as its bytes, 0 and 1 (uint8's payload)
            return self.encode(brick.view(np.uint8))
        best = self._encode(brick)
        if best[0] == MODE_CONSTANT:
            return best
        runs = repeat.find(brick) if REPEAT and self.predict_version >= REPEAT_VERSION else None
        if runs is not None:  # slices in equal runs: the shrunk brick as any, if shorter
            payload = bytes([MODE_REPEAT]) + repeat.pack(runs) + self._encode(repeat.shrink(brick, runs))
            best = _smaller_kept(payload, best)
        axes = mirror.find(brick) if MIRROR and self.predict_version >= MIRROR_VERSION else 0
        if axes:  # its own mirror image: the first half as any brick, if shorter
            best = _smaller_kept(bytes([MODE_MIRROR, axes]) + self._encode(mirror.shrink(brick, axes)), best)
        comb = gain.find(brick) if GAIN and self.predict_version >= GAIN_VERSION else None
        if comb is not None:  # counts times a gain plus noise: the two apart, if shorter
            k, r = gain.split(brick, *comb)
            payload = bytes([MODE_GAIN]) + gain.pack(*comb, self._encode(k)) + self._encode(r)
            best = _smaller_kept(payload, best)
        return best

    def _encode(self, brick: np.ndarray) -> bytes:
        """The shortest payload of modes 0-5 of a (non-bool) brick."""
        raw = _as_stored(brick)
        flat = brick.reshape(-1)
        bits = flat.view(f"u{brick.itemsize}")
        if brick.size and (bits == bits[0]).all():
            return bytes([MODE_CONSTANT]) + raw[: brick.dtype.itemsize]
        is_float = brick.dtype.kind == "f"
        candidates = [bytes([MODE_RAW]) + raw]
        if is_float:
            z = ZstdCodec(level=FLOAT_ZSTD_LEVEL).encode(brick)
            candidates.append(bytes([MODE_ZSTD]) + z)
        elif brick.dtype.name in LONG_INTS:  # (the level of the zstd codec they had before)
            candidates.append(bytes([MODE_ZSTD]) + ZstdCodec().encode(brick))
        elif self.tools != "predict":
            candidates.append(self._wavelet_codec().encode(brick))
        probe = None
        if is_float and PRUNE_FLOAT and self.predict_version == MIX_VERSION:
            from .floatprobe import Probe

            probe = Probe.make(brick)
        split_at = len(candidates)  # (the split floats' place: ties go to the first)
        if brick.dtype.name in FLOAT_DTYPES or (not is_float and self.tools != "wavelet"):
            known = min(map(len, candidates))
            candidates += _encode_predict(brick, self.predict_version, known, probe is None)
        blend = b""
        if is_float and self.predict_version >= 3:
            floats = self._encode_float(brick, self.predict_version, min(map(len, candidates)), probe)
            blend = next((c for c in floats if c[1] == FLOAT_BLEND), b"")
            candidates += [c for c in floats if c[1] != FLOAT_BLEND]
        if probe is not None and brick.dtype.name in FLOAT_DTYPES:
            # the split floats, where the block puts them near the shortest payload
            split = _encode_split(probe.block)
            lorenzo = next(c for c in candidates if c[:2] == bytes([MODE_FLOAT, 0]))
            shortest = _shortest(candidates, blend)
            if probe.estimate(len(split), len(lorenzo)) * (1 - PROBE_MARGIN) < shortest:
                candidates.insert(split_at, _encode_split(brick))
        if is_float and self.predict_version >= 3:
            # zstd at 19 rarely saves a tenth over 9, and takes most of the encoder's
            # time on a float brick: run it only where it may win
            shortest = min(len(c) for c in candidates)
            may_win = len(candidates[1]) * ZSTD_19_OVER_9 < shortest
            if may_win and PRUNE_FLOAT and self.predict_version == MIX_VERSION:
                shortest = _shortest(candidates, blend)
                may_win = _zstd19_may_win(brick, len(candidates[1]), shortest)
            if may_win:
                z = ZstdCodec(level=FLOAT_ZSTD_LEVEL_V3).encode(brick)
                candidates[1] = bytes([MODE_ZSTD]) + z
        best = min(candidates, key=len)
        # the blend decodes slower than the other float tools: it must pay for that
        if blend and len(blend) < (1 - BLEND_MIN_SAVING) * len(best):
            return blend
        return best

    def _encode_float(
        self, brick: np.ndarray, version: int, known: int, probe=None
    ) -> list[bytes]:
        """Mode-5 payloads of a float brick: Lorenzo, the blend (with the brick's copy
        offsets and fill value; float32/64), the fitted predictor (float32/64, with the
        best Lorenzo predictor on its faces; not run where a payload of the lattice or
        one ``known`` already is :data:`FIT_MAX_GAIN` shorter than Lorenzo's), and the
        lattice when the values sit on one (its integer fields coded by this codec as
        int32 bricks). With a :class:`.floatprobe.Probe`, only the Lorenzo predictors
        it leaves in doubt, and the blend only where the probe puts it near the shortest
        payload."""
        from . import floatmix as fm
        from . import floatpredict as fp

        lorenzo = fp.encode_best_lorenzo(brick, None if probe is None else probe.lorenzo())
        out = [bytes([MODE_FLOAT, 0]) + lorenzo]
        lattices = []
        for params, k, gap in fp.find_lattices(brick):
            kp = self.encode(k)
            lattices.append(
                bytes([MODE_FLOAT, 1])
                + pal.uleb(len(params))
                + params.astype("<f8").tobytes()
                + pal.uleb(len(kp))
                + kp
                + self.encode(gap)
            )
        shortest = min([known, len(out[0])] + [len(c) for c in lattices])
        gain = FIT_MAX_GAIN_BOX if version >= BOX_VERSION else FIT_MAX_GAIN
        fit_may_win = shortest >= (1 - gain) * len(out[0])
        blend = []
        if brick.itemsize >= 4 and version >= 4:
            offsets, fill = fm.copy_offsets(brick), fm.fill_value(brick)
            if probe is None or _blend_may_win(probe, offsets, fill, len(out[0]), shortest):
                blend = [bytes([MODE_FLOAT, FLOAT_BLEND]) + fm.encode(brick, offsets=offsets, fill=fill)]
        if blend and PRUNE_FLOAT and version == MIX_VERSION:
            # a fit at most FIT_BLEND_GAIN shorter than Lorenzo still loses to such a blend
            fit_may_win &= len(blend[0]) >= (1 - BLEND_MIN_SAVING) * (1 - FIT_BLEND_GAIN) * len(out[0])
        if brick.itemsize >= 4 and version >= FIT_VERSION and fit_may_win:
            from . import floatfit

            boxes = floatfit.BOX_SHAPES if version >= BOX_VERSION else ()
            fitted = floatfit.encode_best(brick, lorenzo[0], boxes)
            if fitted is not None:
                out.append(bytes([MODE_FLOAT, FLOAT_FIT]) + fitted)
        return out + blend + lattices

    def _decode_float(self, body: memoryview, shape: tuple[int, ...], dtype: np.dtype) -> np.ndarray:
        from . import floatpredict as fp

        if len(body) < 1 or body[0] >= len(FLOAT_TOOLS):
            raise FormatError("float brick payload: expected tool byte 0, 1, 2 or 3")
        if body[0] == 0:
            return fp.decode_lorenzo(body[1:], shape, dtype)
        if body[0] == FLOAT_BLEND:
            from . import floatmix

            return floatmix.decode(body[1:], shape, dtype)
        if body[0] == FLOAT_FIT:
            from . import floatfit

            return floatfit.decode(body[1:], shape, dtype)
        m, pos = pal.read_uleb(body, 1)
        if m not in (1, shape[0]) or pos + 16 * m > len(body):
            raise FormatError(
                f"float lattice payload: expected 1 or {shape[0]} lattices within the payload, found {m}"
            )
        params = np.frombuffer(bytes(body[pos : pos + 16 * m]), dtype="<f8").reshape(m, 2)
        n, pos = pal.read_uleb(body, pos + 16 * m)
        if pos + n > len(body):
            raise FormatError("float lattice payload: its k field runs past the payload")
        k = self.decode(body[pos : pos + n], shape, np.int32)
        gap = self.decode(body[pos + n :], shape, np.int32)
        return fp.apply_lattice(params.astype(np.float64), k, gap, dtype)

    def decode(self, data: bytes | memoryview, shape: tuple[int, ...], dtype: Any) -> np.ndarray:
        dtype = np.dtype(dtype)
        check_dtype(dtype)
        if dtype == np.bool_:
            out = self.decode(data, shape, np.uint8)
            if out.size and out.max() > 1:
                raise FormatError("lossless bool brick payload: a value other than 0 and 1")
            return out.view(np.bool_)
        mode, body = split_mode(data, "lossless")
        if mode == MODE_GAIN and dtype.kind in "iu" and dtype.name not in LONG_INTS:
            g, s, pos, n = gain.unpack(body)
            parts = (body[pos : pos + n], body[pos + n :])
            if any(len(p) and p[0] in WRAPPING for p in parts):
                raise FormatError("gain-comb payload: its counts or residues are mode 6, 7 or 8")
            k, r = (self.decode(p, tuple(shape), dtype) for p in parts)
            return gain.join(k, r, g, s, dtype)
        if mode in (MODE_REPEAT, MODE_MIRROR):  # a smaller brick, then how it spreads out
            tool, what = (repeat, "repeated-slice") if mode == MODE_REPEAT else (mirror, "mirrored-halves")
            how, used = tool.unpack(body, tuple(shape))
            if len(body) > used and body[used] in WRAPPING:
                raise FormatError(f"{what} payload: its smaller brick is mode {body[used]}")
            small = self.decode(body[used:], tool.shape_of(tuple(shape), how), dtype)
            return tool.expand(small, how, tuple(shape))
        if mode == MODE_FLOAT and dtype.kind == "f":
            return self._decode_float(body, tuple(shape), dtype)
        if mode == MODE_PREDICT and dtype.name != "float64":
            return _decode_predict(body, tuple(shape), dtype)
        if dtype.kind != "f" and dtype.name not in LONG_INTS:
            if mode > MODE_ZSTD:
                raise FormatError(f"lossless brick payload: expected mode 0 to 4 or 6 to 8, found {mode}")
            return self._wavelet_codec().decode(data, shape, dtype)
        if mode == MODE_RAW:
            return _from_stored(body, shape, dtype)
        if mode == MODE_CONSTANT:
            return np.full(shape, _from_stored(body, (1,), dtype)[0], dtype=dtype)
        if mode == MODE_ZSTD:
            return ZstdCodec(level=FLOAT_ZSTD_LEVEL).decode(body, shape, dtype)
        if dtype.kind != "f":
            raise FormatError(f"lossless {dtype} brick payload: expected mode 1 to 4, 6 or 7, found {mode}")
        raise FormatError(f"lossless float brick payload: expected mode 1 to 7, found {mode}")


def _smaller_kept(payload: bytes, best: bytes) -> bytes:
    """``payload`` (a smaller brick's: mode 6 or 7) where it is shorter than ``best`` by
    :data:`REPEAT_MIN_SAVING` and :data:`REPEAT_MIN_BYTES`, else ``best``."""
    if len(payload) < min((1 - REPEAT_MIN_SAVING) * len(best), len(best) - REPEAT_MIN_BYTES):
        return payload
    return best


def check_dtype(dtype: np.dtype) -> None:
    dtype = np.dtype(dtype)
    if dtype in _ACCEPTED:  # every brick's decoder asks; ``dtype.name`` costs 5-10 us
        return
    if dtype.name not in LOSSLESS_DTYPES:
        raise FormatError(
            f"the lossless codec takes {', '.join(LOSSLESS_DTYPES[:-1])} or bool voxels, "
            f"found {np.dtype(dtype)}; use codec='zstd' for this dtype"
        )
    _ACCEPTED.add(dtype)


_ACCEPTED: set = set()  # dtypes :func:`check_dtype` passed


def inner_mode(payload: bytes) -> int:
    """The mode of a payload's voxels: mode 6's shrunk or mode 7's cut brick's, else its own."""
    if payload[:1] == bytes([MODE_REPEAT]):
        return payload[1 + repeat.unpack(memoryview(payload)[1:])[1]]
    if payload[:1] == bytes([MODE_MIRROR]):
        return payload[2]
    if payload[:1] == bytes([MODE_GAIN]):  # the counts' payload's
        return payload[1 + gain.unpack(memoryview(payload)[1:])[2]]
    return payload[0]


def describe(payload: bytes) -> str:
    """The tool a brick payload used, as ``volpack info`` lists it."""
    mode = payload[0] if payload else -1
    if mode == MODE_REPEAT:
        try:
            used = repeat.unpack(memoryview(payload)[1:])[1]
        except FormatError:
            return "repeat"
        return "repeat+" + describe(payload[1 + used :])
    if mode == MODE_MIRROR:
        return "mirror+" + describe(payload[2:]) if len(payload) > 2 else "mirror"
    if mode == MODE_GAIN:
        try:
            _, _, pos, n = gain.unpack(memoryview(payload)[1:])
        except FormatError:
            return "gain"
        return "gain+" + describe(payload[1 + pos : 1 + pos + n])
    if mode == MODE_PREDICT and len(payload) > 1:
        flags = payload[1]
        if flags & FLAG_SPLIT:
            return "predict-float"
        if flags & FLAG_LABELS and not flags & FLAG_FIT:
            return "labels"
        name = "predict2" if flags & FLAG_FIT else "predict"
        name += "+palette" if flags & FLAG_PALETTE else ""
        name += "+mask" if flags & FLAG_MASK else ""
        name += "+low" if flags & FLAG_LOW else ""
        name += "+tex" if flags & FLAG_TEX else ""
        more = payload[2] if flags & FLAG_FIT and flags & FLAG_MORE and len(payload) > 2 else 0
        name += "+mix" if more & FLAG_MIX >> 8 else ""
        name += "+local" if more & FLAG_LOCAL >> 8 else ""
        name += "+lowm" if more & FLAG_LOWM >> 8 else ""
        return name + ("+plane" if more & FLAG_PLANE >> 8 else "")
    if mode == MODE_FLOAT and len(payload) > 1:
        tool = FLOAT_TOOLS[payload[1]] if payload[1] < len(FLOAT_TOOLS) else payload[1]
        boxed = payload[1] == FLOAT_FIT and len(payload) > 2 and payload[2] >= FIT_BOXED
        return f"float-{tool}" + ("+box" if boxed else "")
    return {0: "wavelet", 1: "raw", 2: "constant", 3: "zstd"}.get(mode, f"mode {mode}")


def _encode_predict(
    brick: np.ndarray, version: int = 1, known: int | None = None, split: bool = True
) -> list[bytes]:
    """Predictive payloads of a brick: on its values, and on their ranks when the brick
    leaves values of its range unused (``known``: the shortest other payload, if any;
    ``split``: floats split into exponent and mantissa, else left to the caller)."""
    from . import predict

    is_float = brick.dtype.kind == "f"
    values = to_ordered(brick) if is_float else brick.astype(np.int64)  # (uint64: same bits)
    flags = FLAG_FLOAT if is_float else 0
    lo, hi = int(values.min()), int(values.max())
    narrow = is_float or (NARROW[0] <= lo and hi <= NARROW[1])
    plane = version >= MIX_VERSION and not is_float and narrow and _plane_fits(values, lo, hi)
    if PRUNE and version == MIX_VERSION and not is_float and narrow and max(brick.shape[:2]) >= SLAB_MIN:
        seen: list[float] = []
        pruned = _encode_pruned(brick, values, lo, hi, known, estimates=seen)
        if pruned is not None:
            return pruned + (_encode_plane(values, lo, hi, version, known, seen[0]) if plane else [])
    planes = _encode_plane(values, lo, hi, version, known) if plane else []
    if is_float:  # exponent and mantissa apart: whole images leap at binade changes
        out = [_encode_split(brick)] if split else []
    elif not narrow:  # a 64-bit brick's wide values: its palette alone
        out = []
    else:
        out = [
            bytes([MODE_PREDICT, flags]) + pal.pack_range(lo, hi) + predict.encode(values, lo, hi)
        ]
    if version >= 2 and not is_float and narrow:  # version 1 stays a candidate: tiny bricks pay
        out.append(
            _encode_fit(
                values, lo, hi, version >= LOW_VERSION, version >= TEX_VERSION, version >= MIX_VERSION,
                version >= LOCAL_VERSION,
            )
        )
    if hi - lo + 1 > 2:
        p = pal.build(values)
        if len(p) < hi - lo + 1 and len(p) <= pal.MAX_PALETTE:
            ranks = pal.to_ranks(values, p)
            out.append(
                bytes([MODE_PREDICT, flags | FLAG_PALETTE])
                + pal.pack(p)
                + predict.encode(ranks, 0, len(p) - 1)
            )
    if piecewise_constant(brick):
        from . import labels

        p = pal.build(values)
        if len(p) <= pal.MAX_PALETTE:
            out.append(
                bytes([MODE_PREDICT, flags | FLAG_PALETTE | FLAG_LABELS])
                + pal.pack(p)
                + labels.encode(pal.to_ranks(values, p), len(p))
            )
    return out + planes


def _plane_fits(values: np.ndarray, lo: int, hi: int) -> bool:
    """Whether the planar stream is tried on a brick (see :data:`PLANE_SLICES` and
    :data:`PLANE_STEP`)."""
    nz, ny, nx = values.shape
    if not (nz <= PLANE_SLICES and ny * nx >= PLANE_AREA and values.size * (hi - lo) ** 2 < PLANE_EXACT):
        return False
    if nz <= 2:
        return True
    step = (np.abs(np.diff(values, axis=1)).mean() + np.abs(np.diff(values, axis=2)).mean()) / 2
    return bool(np.abs(np.diff(values, axis=0)).mean() >= PLANE_STEP * step)


def _encode_plane(
    values: np.ndarray, lo: int, hi: int, version: int, known: int | None, rival: float | None = None
) -> list[bytes]:
    """Version 2's payloads of an integer brick with its slices coded as one plane (the
    chain of :func:`_encode_fit`, pruned as the brick's own at the default version: then
    none where the sample puts it PLANE_MARGIN behind the 3-D chain's estimate
    ``rival``), each flagged PLANE."""
    stacked = values.reshape(1, -1, values.shape[2])
    out = None
    if PRUNE and version == MIX_VERSION and stacked.shape[1] >= SLAB_MIN:
        out = _encode_pruned(stacked, stacked, lo, hi, known, plane=True, rival=rival)
    if out is None:
        out = [_encode_fit(stacked, lo, hi, True, True, True, plane=True)]
    return [_with_plane(p) for p in out]


def _with_plane(payload: bytes) -> bytes:
    """A version-2 payload with the PLANE bit set in its second flags byte (added if absent)."""
    flags = payload[1]
    if flags & FLAG_MORE:
        return payload[:2] + bytes([payload[2] | FLAG_PLANE >> 8]) + payload[3:]
    return bytes([payload[0], flags | FLAG_MORE, FLAG_PLANE >> 8]) + payload[2:]


def _fits(v: np.ndarray, plane: bool, mask: np.ndarray | None = None):
    """The fitted predictors of :mod:`.predictfit` for ``v`` (values from 0): the 3-D or
    the planar one."""
    from . import predictfit

    return predictfit.fit_plane(v, mask) if plane else predictfit.fit(v, mask)


def _encode_fit(
    values: np.ndarray, lo: int, hi: int, low: bool = False, tex: bool = False, mix: bool = False,
    local: bool = False, plane: bool = False,
) -> bytes:
    """The shortest version-2 predictive payload of an integer brick: on its values or
    on their palette ranks (when the brick leaves values of its range unused), then
    for the better of those with a background mask, and with one gradient class; with
    ``low``, the best of those again with the low-value models; with ``tex``, the best
    again with the texture bias; with ``mix``, the best again with the mixed estimates
    (kept when ``MIX_MIN_SAVING`` shorter); with ``local``, the best again averaged with
    the local fit (kept when ``LOCAL_MIN_SAVING`` shorter); ``plane``: every stream by
    the planar predictor (``values`` one plane; not flagged here)."""
    from . import predictfit

    enc = functools.partial(predictfit.encode, plane=plane)

    head = bytes([MODE_PREDICT, FLAG_FIT]) + pal.pack_range(lo, hi)
    domains = [(head, values, lo, hi)]
    p = pal.build(values)
    if 2 < len(p) < hi - lo + 1 and len(p) <= pal.MAX_PALETTE:
        head = bytes([MODE_PREDICT, FLAG_FIT | FLAG_PALETTE]) + pal.pack(p)
        domains.append((head, pal.to_ranks(values, p), 0, len(p) - 1))
    tried = []
    for head, v, a, b in domains:
        fits = _fits(v - a, plane)  # one fit serves every variant below
        tried.append((head + enc(v, a, b, fitted=fits[0]), head, v, a, b, fits))
    best, head, v, a, b, fits = min(tried, key=lambda t: len(t[0]))
    section, mask = b"", None
    masked = bgmask.choose(v)
    if masked is not None:
        fill, m = masked
        sec = bgmask.encode(fill - a, m)
        head2 = bytes([head[0], head[1] | FLAG_MASK]) + head[2:]
        payload = head2 + sec + enc(v, a, b, mask=m, fitted=fits[0])
        if len(payload) < len(best):
            best, head, section, mask = payload, head2, sec, m
    fitted = fits[0]
    one = head + section + enc(v, a, b, mask=mask, fitted=fits[1])
    if len(one) < len(best):
        best, fitted = one, fits[1]
    if low:  # (one more run, not one per variant: the models rarely change the choice)
        head2 = bytes([head[0], head[1] | FLAG_LOW]) + head[2:]
        payload = head2 + section + enc(v, a, b, mask=mask, fitted=fitted, low=True)
        best = min(best, payload, key=len)
    if tex:  # (likewise one more run, with the low-value models if they were kept)
        with_low = bool(best[1] & FLAG_LOW)
        head2 = bytes([head[0], head[1] | FLAG_TEX | (FLAG_LOW if with_low else 0)]) + head[2:]
        payload = head2 + section + enc(v, a, b, mask=mask, fitted=fitted, low=with_low, tex=True)
        best = min(best, payload, key=len)
    if mix:  # (the same settings as the best, mixed)
        flags = best[1]
        head2 = bytes([head[0], flags | FLAG_MORE, FLAG_MIX >> 8]) + head[2:]
        low_, tex_ = bool(flags & FLAG_LOW), bool(flags & FLAG_TEX)
        payload = head2 + section + enc(v, a, b, mask=mask, fitted=fitted, low=low_, tex=tex_, mix=True)
        if len(payload) < (1 - MIX_MIN_SAVING) * len(best):
            best = payload
    if local and not plane and predictfit.localfit.usable(v.shape, b - a):  # (the best again, with the local fit)
        flags = best[1]
        more = best[2] if flags & FLAG_MORE else 0
        head2 = bytes([head[0], flags | FLAG_MORE, more | FLAG_LOCAL >> 8]) + head[2:]
        payload = head2 + section + predictfit.encode(
            v, a, b, mask=mask, fitted=fitted, low=bool(flags & FLAG_LOW), tex=bool(flags & FLAG_TEX),
            mix=bool(more & FLAG_MIX >> 8), local=True,
        )  # fmt: skip
        if len(payload) < (1 - LOCAL_MIN_SAVING) * len(best):
            best = payload
    if not mix:  # (LOWM: version 8 and up, as MIX)
        return best
    return _lowm_kept(best, len(head) - 2, section, lambda lm: predictfit.encode(
        v, a, b, mask=mask, fitted=fitted, plane=plane, lowm=lm, **_stream_flags(best)
    ))  # fmt: skip


def _stream_flags(payload: bytes) -> dict:
    """The stream options a version-2 predictive payload's flags name."""
    flags = payload[1]
    more = payload[2] if flags & FLAG_MORE else 0
    return dict(
        low=bool(flags & FLAG_LOW), tex=bool(flags & FLAG_TEX), mix=bool(more & FLAG_MIX >> 8),
        local=bool(more & FLAG_LOCAL >> 8),
    )  # fmt: skip


def _lowm_kept(best: bytes, nhead: int, section: bytes, enc) -> bytes:
    """``best`` (a version-2 predictive payload: its flags, ``nhead`` bytes of range or
    palette, ``section``, the stream), or where it has the low-value models, the same
    with LOWM (``enc(True)``: the stream) if shorter. (One more run, on the pick only:
    LOWM moves the mantissa bits of the low class alone, it rarely changes the pick.)"""
    if not (LOWM and best[1] & FLAG_LOW):
        return best
    flags = best[1]
    more = best[2] if flags & FLAG_MORE else 0
    lead = 3 if flags & FLAG_MORE else 2
    payload = bytes([best[0], flags | FLAG_MORE, more | FLAG_LOWM >> 8]) + best[lead : lead + nhead] + section
    return min(best, payload + enc(True), key=len)


def _encode_pruned(
    brick: np.ndarray, values: np.ndarray, lo: int, hi: int, known: int | None, plane: bool = False,
    rival: float | None = None, estimates: list | None = None,
) -> list[bytes] | None:
    """:func:`_encode_predict` of an integer brick at the default version, pruned (see
    :data:`PRUNE`): the payloads of the variants the slab leaves in doubt, the version-1
    predictor's where the slab puts it near them, and the labels' as before; None where
    the sample cannot tell (see :data:`SMALL_PAYLOAD`). With ``plane`` (``values`` one
    plane), the planar predictor's pick on the sample only, and none where its estimate
    is PLANE_MARGIN above ``rival``'s. The chain's estimate is added to ``estimates``."""
    from . import predict

    p = pal.build_span(values, lo, hi)
    domains = [(bytes([MODE_PREDICT, FLAG_FIT]) + pal.pack_range(lo, hi), values, lo, hi)]
    if 2 < len(p) < hi - lo + 1 and len(p) <= pal.MAX_PALETTE:
        ranks = pal.to_ranks(values, p)
        domains.append((bytes([MODE_PREDICT, FLAG_FIT | FLAG_PALETTE]) + pal.pack(p), ranks, 0, len(p) - 1))
    out = []
    if not plane and piecewise_constant(brick) and len(p) <= pal.MAX_PALETTE:
        from . import labels

        out.append(
            bytes([MODE_PREDICT, FLAG_PALETTE | FLAG_LABELS])
            + pal.pack(p)
            + labels.encode(pal.to_ranks(values, p), len(p))
        )
        known = min(len(out[0]), known or len(out[0]))
    chain = _FitChain(domains, plane)
    plans = chain.plan()
    if estimates is not None:
        estimates.append(chain.estimate)
    small = chain.estimate < SMALL_PAYLOAD * values.size
    if small and (known is None or chain.estimate < SMALL_FACTOR * known):
        return None
    if plane:
        behind = rival is not None and chain.estimate > (1 + PLANE_MARGIN) * rival
        return [] if behind else [chain.best(plans[:1])]
    out.append(chain.best(plans))
    head, v, a, b = domains[chain.domain]
    v1 = len(predict.encode(chain.sample(v), a, b)) * chain.scale + len(head)
    if v1 <= (1 + V1_MARGIN) * chain.estimate:
        flags = FLAG_PALETTE if chain.domain else 0
        out.append(bytes([MODE_PREDICT, flags]) + head[2:] + predict.encode(v, a, b))
    return out


def _shortest(candidates: list[bytes], blend: bytes) -> float:
    """The bytes a payload must be under to be kept: the shortest of ``candidates``, or
    the blend's over ``1 - BLEND_MIN_SAVING`` (the blend beats any payload longer)."""
    shortest = min(map(len, candidates))
    return min(shortest, len(blend) / (1 - BLEND_MIN_SAVING)) if blend else shortest


def _encode_split(brick: np.ndarray) -> bytes:
    """The float brick's exponents and mantissas coded apart (mode 4, :mod:`.floatcode`)."""
    from . import floatcode

    flags = FLAG_FLOAT | FLAG_SPLIT
    return bytes([MODE_PREDICT, flags]) + floatcode.encode(to_ordered(brick), brick.itemsize)


def _blend_may_win(probe, offsets: list, fill, lorenzo: int, shortest: int) -> bool:
    """Whether the blend may be kept, by its share of Lorenzo's bytes on the probe's block
    (True where a copy offset reaches past the block: the block cannot show it)."""
    from . import floatmix as fm

    block = probe.block
    if any(o[i] >= block.shape[i] for o in offsets for i in range(3)):
        return True
    n = len(fm.encode(block, offsets=offsets, fill=fill))
    return probe.estimate(n, lorenzo) * (1 - PROBE_MARGIN) < (1 - BLEND_MIN_SAVING) * shortest


def _zstd19_may_win(brick: np.ndarray, z9: int, shortest: int) -> bool:
    """Whether zstd at level 19 may come within ZSTD_MARGIN of ``shortest`` bytes, its
    share of level 9's bytes judged on the integer chain's sample of slices (:func:`_sample`
    along z and y); True where the brick is too thin to sample."""
    if max(brick.shape[:2]) < SLAB_MIN:
        return True
    rows = [_sample(n)[0] if n >= SLAB_MIN else np.arange(n) for n in brick.shape[:2]]
    part = brick[np.ix_(*rows)]
    share = len(ZstdCodec(level=FLOAT_ZSTD_LEVEL_V3).encode(part)) / len(
        ZstdCodec(level=FLOAT_ZSTD_LEVEL).encode(part)
    )
    return z9 * share * (1 - ZSTD_MARGIN) < shortest


def _sample(n: int) -> tuple[np.ndarray, np.ndarray]:
    """The slices of the sample (SLABS slabs of ``n // 16`` slices spread evenly, each
    after JOIN slices of context) and which of them are context, not coded."""
    t = n // 16
    starts = [max(0, round((i + 0.5) * n / SLABS - t / 2) - JOIN) for i in range(SLABS)]
    index = np.concatenate([np.arange(z, z + t + JOIN) for z in starts])
    context = np.tile(np.arange(t + JOIN) < JOIN, SLABS)
    return index, context


class _FitChain:
    """The variants of :func:`_encode_fit` on a slab of the brick, then in full.

    A variant is (domain, mask, one class, low, tex, mix) as the flags set them; the slab
    makes each decision of the chain in its order, and :meth:`plan` lists the variant it
    reached and, for each decision made by less than PRUNE_MARGIN, that variant with the
    decision the other way."""

    def __init__(self, domains: list, plane: bool = False) -> None:
        self.domains = domains
        self.plane = plane  # (the planar predictor's variants: domains of one plane)
        shape = domains[0][1].shape
        # (the slices of z and of y sampled where the brick is thick enough, x whole)
        picks = [_sample(n) if n >= SLAB_MIN else (np.arange(n), np.zeros(n, bool)) for n in shape[:2]]
        self.index = np.ix_(picks[0][0], picks[1][0])
        self.context = picks[0][1][:, None, None] | picks[1][1][None, :, None]
        self.context = np.broadcast_to(self.context, self.sample(domains[0][1]).shape)
        self.scale = np.prod(shape) / np.count_nonzero(~self.context)
        self._masks: dict = {}
        self._fits: dict = {}
        self.domain, self.estimate = 0, 0.0

    def sample(self, a: np.ndarray) -> np.ndarray:
        return a[self.index]

    def fits(self, d: int):
        """The fitted predictors of domain ``d`` (4 gradient classes, 1), on the brick."""
        if d not in self._fits:
            _, v, a, _ = self.domains[d]
            self._fits[d] = _fits(v - a, self.plane)
        return self._fits[d]

    def mask(self, d: int):
        """(mask section, mask) of domain ``d``, or None (as :func:`bgmask.choose`)."""
        if d not in self._masks:
            _, v, a, _ = self.domains[d]
            masked = bgmask.choose(v)
            self._masks[d] = None if masked is None else (bgmask.encode(masked[0] - a, masked[1]), masked[1])
        return self._masks[d]

    def _size(self, var: tuple, fits) -> float:
        """The slab's estimate of a variant's payload: its slab stream scaled to the brick,
        plus the head and the mask section of the brick."""
        from . import predictfit

        d, masked, one, low, tex, mix = var
        head, v, a, b = self.domains[d]
        mask = self.mask(d) if masked else None
        m = self.context if mask is None else self.sample(mask[1]) | self.context
        n = len(predictfit.encode(
            self.sample(v), a, b, mask=m, fitted=fits[one], low=low, tex=tex, mix=mix, plane=self.plane
        ))  # fmt: skip
        return n * self.scale + len(head) + (len(mask[0]) if mask else 0) + mix

    def plan(self) -> list[tuple]:
        """The variants to code in full (the slab's pick first)."""
        fits = [_fits(self.sample(v) - a, self.plane, self.context) for _, v, a, _ in self.domains]
        sizes = [self._size((d, False, 0, False, False, False), fits[d]) for d in range(len(fits))]
        d = int(np.argmin(sizes))
        doubts = [0] if len(sizes) == 2 and 1 - min(sizes) / max(sizes) <= DOMAIN_MARGIN else []
        var = (d, False, 0, False, False, False)
        best = self._size(var, self.fits(d))  # the brick's fit from here on
        for i, th in ((1, 0.0), (2, 0.0), (3, 0.0), (4, 0.0), (5, MIX_MIN_SAVING)):
            if i == 1 and self.mask(d) is None:
                continue
            other = var[:i] + ((1 if i == 2 else True),) + var[i + 1 :]
            n = self._size(other, self.fits(d))
            gain = 1 - n / best
            below = LEARN_MARGIN if i in (3, 4) else PRUNE_MARGIN
            above = ONE_MARGIN if i == 2 else PRUNE_MARGIN
            if -below <= gain - th <= above:
                doubts.append(i)
            if gain > th:
                var, best = other, n
        self.domain, self.estimate = d, best
        plans = [var]
        for i in doubts:
            if i == 0:  # the other domain, its mask if it has one
                other = (1 - d, var[1] and self.mask(1 - d) is not None) + var[2:]
            else:
                other = var[:i] + ((1 - var[i] if i == 2 else not var[i]),) + var[i + 1 :]
            if other not in plans:
                plans.append(other)
        return plans

    def payload(self, var: tuple, lowm: bool = False) -> bytes:
        from . import predictfit

        d, masked, one, low, tex, mix = var
        head, v, a, b = self.domains[d]
        mask = self.mask(d) if masked else None
        flags = head[1] | (FLAG_MASK if mask else 0) | (FLAG_LOW if low else 0) | (FLAG_TEX if tex else 0)
        more = (FLAG_MIX >> 8 if mix else 0) | (FLAG_LOWM >> 8 if lowm else 0)
        lead = bytes([head[0], flags | FLAG_MORE, more]) if more else bytes([head[0], flags])
        stream = predictfit.encode(
            v, a, b, mask=None if mask is None else mask[1], fitted=self.fits(d)[one], low=low,
            tex=tex, mix=mix, plane=self.plane, lowm=lowm,
        )  # fmt: skip
        return lead + head[2:] + (mask[0] if mask else b"") + stream

    def best(self, plans: list[tuple]) -> bytes:
        """The shortest payload of ``plans``, the mixed estimates kept where they save
        MIX_MIN_SAVING over the shortest without."""
        coded = [(var, self.payload(var)) for var in plans]
        plain = min((c for c in coded if not c[0][5]), key=lambda c: len(c[1]), default=None)
        mixed = min((c for c in coded if c[0][5]), key=lambda c: len(c[1]), default=None)
        if plain is None or (mixed is not None and len(mixed[1]) < (1 - MIX_MIN_SAVING) * len(plain[1])):
            var, best = mixed
        else:
            var, best = plain
        if LOWM and var[3]:  # (the pick again with LOWM, see _lowm_kept)
            best = min(best, self.payload(var, lowm=True), key=len)
        return best


def _decode_predict(body: memoryview, shape: tuple[int, ...], dtype: np.dtype) -> np.ndarray:
    from . import predict

    if len(body) < 1:
        raise FormatError("predictive brick payload: missing flags byte")
    flags = body[0]
    rest = body[1:]
    if flags & FLAG_FIT and flags & FLAG_MORE:  # a second flags byte: MIX, LOCAL or both
        if len(body) < 2 or body[1] & 7 not in ((0, 1, 2, 3, 4, 5) if body[1] & 8 else (1, 2, 3, 4, 5)) or body[1] > 15:
            found = f"{body[1]:#x}" if len(body) >= 2 else "the end of the payload"
            raise FormatError(f"predictive brick payload: expected the second flags byte 1 (MIX), "
                              f"2 (LOCAL), 3 (both), 4 (PLANE) or 5 (MIX and PLANE), each or none "
                              f"with 8 (LOWM), found {found}")
        flags = (flags & ~FLAG_MORE) | (body[1] << 8)
        rest = body[2:]
    is_float = dtype.kind == "f"
    split = bool(flags & FLAG_SPLIT)
    fit = bool(flags & FLAG_FIT)
    if (
        flags & ~FLAGS
        or (fit and flags & (FLAG_FLOAT | FLAG_LABELS))
        or (flags & (FLAG_MASK | FLAG_LOW | FLAG_TEX | FLAG_MIX | FLAG_LOCAL | FLAG_PLANE) and not fit)
        or (flags & FLAG_LOWM and not flags & FLAG_LOW)
        or bool(flags & FLAG_FLOAT) != is_float
        or (split and flags & (FLAG_PALETTE | FLAG_LABELS))
        or (split and not is_float)
        or (flags & FLAG_LABELS and not flags & FLAG_PALETTE)
    ):
        raise FormatError(f"predictive brick payload: flags {flags:#x} do not fit {dtype} voxels")
    vmin, vmax = _value_range(dtype)
    n = int(np.prod(shape))
    if split:
        from . import floatcode

        values = floatcode.decode(rest, shape, dtype.itemsize)
    elif flags & FLAG_PALETTE:
        p, used = pal.unpack(rest, min(pal.MAX_PALETTE, max(n, 1)))
        if p[0] < vmin or p[-1] > vmax:
            raise FormatError(f"corrupt palette: values outside the range of {dtype}")
        if flags & FLAG_LABELS:
            from . import labels

            # (straight into the voxels' own type where it holds them: no int64 volume)
            values = labels.decode(rest[used:], shape, len(p), p if is_float else p.astype(dtype))
        else:
            if fit:
                ranks = _decode_fit(rest[used:], shape, 0, len(p) - 1, flags)
            else:
                ranks = predict.decode(rest[used:], shape, 0, len(p) - 1)
            values = pal.from_ranks(ranks, p)
    else:
        lo, hi, pos = pal.read_range(rest, vmin, vmax, f"predictive brick payload of {dtype}")
        if fit:
            values = _decode_fit(rest[pos:], shape, lo, hi, flags)
        else:
            values = predict.decode(rest[pos:], shape, lo, hi)
    if is_float:
        return from_ordered(values, dtype).reshape(shape)
    return values.astype(dtype, copy=False).reshape(shape)


def _decode_fit(data: memoryview, shape: tuple[int, ...], lo: int, hi: int, flags: int) -> np.ndarray:
    """A version-2 predictive stream, after its mask section when ``flags`` has one."""
    from . import predictfit

    if hi - lo >= 1 << 32:
        raise FormatError(f"predictive brick payload: value range [{lo}, {hi}] is out of bounds")
    low, tex, mix = bool(flags & FLAG_LOW), bool(flags & FLAG_TEX), bool(flags & FLAG_MIX)
    local, plane, lowm = bool(flags & FLAG_LOCAL), bool(flags & FLAG_PLANE), bool(flags & FLAG_LOWM)
    if flags & FLAG_MASK:  # (coded over the plane the voxels are, with PLANE)
        coded = (1, shape[0] * shape[1], shape[2]) if plane else shape
        fill, mask, used = bgmask.decode(data, coded, hi - lo)
        return predictfit.decode(data[used:], shape, lo, hi, mask, lo + fill, low, tex, mix, local, plane, lowm)
    return predictfit.decode(data, shape, lo, hi, low=low, tex=tex, mix=mix, local=local, plane=plane, lowm=lowm)


def _value_range(dtype: np.dtype) -> tuple[int, int]:
    """The integers a voxel of ``dtype`` maps to (floats: their ordered bit images)."""
    if dtype.kind == "f":
        return 0, (1 << (8 * dtype.itemsize)) - 1
    info = np.iinfo(np.int64 if dtype.name == "uint64" else dtype)
    return int(info.min), int(info.max)
