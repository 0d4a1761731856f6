"""Tucker (truncated HOSVD) coding of float bricks, for PSNR and ratio targets.

A band-limited field (a dealiased spectral simulation) or one made of few separable
patterns has low multilinear rank: the SVD of each mode's unfolding leaves few singular
values, and the core ``G = X x1 U1^T x2 U2^T x3 U3^T`` of the mean-removed brick packs
its energy into a small corner. The factors are orthonormal, so an error in the core is
the same error, in L2, on the voxels: the core is dead-zone quantised with one step
(what sets the PSNR) and the ranks are cut where its slices quantise to zero.

A factor column ``u_j`` multiplies its core slice ``G_j``: an error ``e`` in the column
adds ``|e| |G_j|`` to the voxels' L2 error. Each column is therefore rounded to a power
of two step ``2^-b_j`` with ``2^-b_j ~ SLACK * step / |G_j|``: every column then adds
about the same error (``SLACK`` trades factor bits against core bits: 2 coded tgv_u
shortest at 40-100 dB). The core is then recomputed against the rounded factors (least
squares), so it absorbs part of their error.

The core's integers are coded by the wavelet coefficient coder (its octave bands match
the core's decay: index ``i`` of a mode sits in the band of its octave, with the
coefficient at ``i // 2`` as its parent), the factors' integers by the same coder in one
line. The decoder multiplies the dequantised core by the factors in a numba kernel whose
float64 operations run in a fixed order (no fused multiply-add): the same bytes give the
same voxels on every machine. The byte layout is in ``formats/lossy-1.md``.
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
import struct
import threading
from typing import Any, ClassVar

import numpy as np

from ..errors import FormatError, OptionError
from .codec import MODE_CODED, MODE_CONSTANT
from .protocol import BrickCodec, Measured, constant_value, from_stored

SLACK = 2.0  # factor column step over step / |G_j| (tgv_u: 0.25-4 tried, 2 shortest)
DEADZONE = 0.4  # q = floor(|g| / step + DEADZONE)
RECON = 0.1  # |g'| = (|q| + RECON) * step
MAX_EXP = 48  # factor column exponents 0..MAX_EXP
_HEAD = struct.Struct("<dd3HI")  # mean, step, ranks, factor stream length


def _levels(n: int) -> int:
    """Octave levels of a core axis of length ``n`` (halved while longer than 1)."""
    return max(0, math.ceil(math.log2(n))) if n > 1 else 0


def _core_scan(shape):
    from ..wavelet import sigmap

    return sigmap.scan(tuple(shape), tuple(min(_levels(n), 8) for n in shape), "dfs")


def _line_scan(n: int):
    from ..wavelet import sigmap

    return sigmap.scan((1, 1, n), (0, 0, 0), "line")


_BASES: dict[bytes, list[np.ndarray]] = {}  # a PSNR search codes one brick many times
_BASES_LOCK = threading.Lock()  # bricks are coded in threads


def _bases(y: np.ndarray) -> list[np.ndarray]:
    """The left singular vectors of the three unfoldings of ``y``: LAPACK's SVD of the
    triangle R of each unfolding's transpose (``A^T = QR``, so ``A = R^T Q^T`` has the
    singular vectors of ``R^T``; no squared condition number as in ``A A^T``)."""
    key = hashlib.sha1(y.tobytes()).digest() + repr(y.shape).encode()
    with _BASES_LOCK:
        if key in _BASES:
            return _BASES[key]
    out = []
    for k in range(3):
        a = _unfold(y, k)
        if a.shape[1] > a.shape[0]:
            a = np.linalg.qr(a.T, mode="r").T
        out.append(np.linalg.svd(a)[0])
    with _BASES_LOCK:
        while len(_BASES) >= 8:
            _BASES.pop(next(iter(_BASES)))
        _BASES[key] = out
    return out


def _unfold(x: np.ndarray, mode: int) -> np.ndarray:
    return np.moveaxis(x, mode, 0).reshape(x.shape[mode], -1)


def _project(x: np.ndarray, mats) -> np.ndarray:
    """``x x1 m0 x2 m1 x3 m2`` (each ``m`` maps the axis: shape (new, old))."""
    for mode, m in enumerate(mats):
        x = np.moveaxis(np.tensordot(m, x, axes=(1, mode)), 0, mode)
    return x


def _quantise(g: np.ndarray, step: float) -> np.ndarray:
    return (np.sign(g) * np.floor(np.abs(g) / step + DEADZONE)).astype(np.int64)


def _dequantise(q: np.ndarray, step: float) -> np.ndarray:
    return np.sign(q) * (np.abs(q) + RECON) * step


@dataclasses.dataclass(frozen=True, eq=False, repr=False)
class TuckerCodec(BrickCodec):
    codec_id: ClassVar[str] = "tucker"
    lossless: ClassVar[bool] = False
    value_range: float
    step: float

    def __post_init__(self) -> None:
        if not 0 < self.step < math.inf:
            raise OptionError(f"expected a positive finite step, found {self.step!r}")
        if not 0 <= self.value_range < math.inf:
            raise OptionError(f"expected a finite value_range >= 0, found {self.value_range!r}")

    def encode(self, brick: np.ndarray) -> bytes:
        return self.encode_measured(brick)[0]

    def encode_measured(self, brick: np.ndarray) -> Measured:
        from ..entropy import CODERS

        x = np.asarray(brick)
        if x.ndim != 3 or x.dtype.kind != "f":
            raise OptionError(f"tucker codes 3-D float bricks, found {x.dtype} {x.shape}")
        if not np.isfinite(x).all():
            raise OptionError("tucker takes finite voxels; use max_error= for NaN/Inf")
        value = constant_value(x)
        if value is not None:
            return Measured(bytes([MODE_CONSTANT]) + value, 0.0, 0.0, x.size)
        step = float(self.step)
        xd = x.astype(np.float64)
        mean = float(np.float64(xd.mean()))
        y = xd - mean
        full = _bases(y)
        q = _quantise(_project(y, [u.T for u in full]), step)
        ranks = _ranks(q)
        factors: list[np.ndarray] = []
        exps: list[np.ndarray] = []
        if min(ranks) > 0:
            g = _dequantise(q[: ranks[0], : ranks[1], : ranks[2]], step)
            for k in range(3):
                norms = np.sqrt((_unfold(g, k) ** 2).sum(axis=1))
                e = np.log2(np.maximum(norms, 1e-300) / (SLACK * step))
                e = np.clip(np.ceil(e), 0, MAX_EXP).astype(np.int64)
                u = full[k][:, : ranks[k]]
                qi = np.rint(u * np.exp2(e)).astype(np.int64)
                factors.append(qi)
                exps.append(e)
            deq = [f * np.exp2(-e) for f, e in zip(factors, exps)]
            # Least squares core against the rounded factors: it absorbs part of their error.
            q = _quantise(_project(y, [np.linalg.pinv(u) for u in deq]), step)
            new = _ranks(q)
            q = q[: new[0], : new[1], : new[2]]
            factors = [f[:, :r] for f, r in zip(factors, new)]
            exps = [e[:r] for e, r in zip(exps, new)]
            ranks = new
        if min(ranks) == 0:
            ranks = (0, 0, 0)
            q = np.zeros((0, 0, 0), np.int64)
            factors, exps = [], []
        fstream = b""
        cstream = b""
        if ranks[0]:
            flat = np.concatenate([f.T.reshape(-1) for f in factors]).reshape(1, 1, -1)
            fstream = CODERS["arith"].encode(flat, _line_scan(flat.size))
            cstream = CODERS["arith"].encode(np.ascontiguousarray(q), _core_scan(q.shape))
        payload = (
            bytes([MODE_CODED])
            + _HEAD.pack(mean, step, *ranks, len(fstream))
            + b"".join(e.astype(np.uint8).tobytes() for e in exps)
            + fstream
            + cstream
        )
        rec = self._rebuild(q, factors, exps, mean, x.shape, x.dtype)
        err = np.abs(rec.astype(np.float64) - xd)
        return Measured(payload, float(err.max()), float(np.sum(err * err)), x.size)

    def _rebuild(self, q, factors, exps, mean, shape, dtype) -> np.ndarray:
        if q.size == 0:
            return np.full(shape, mean, dtype=np.float64).astype(dtype)
        step = float(self.step)
        from .tuckerexpand import expand

        deq = [f.astype(np.float64) * np.exp2(-e.astype(np.float64)) for f, e in zip(factors, exps)]
        return expand(_dequantise(q, step), deq, mean, shape).astype(dtype)

    def decode(self, data: bytes | memoryview, shape: tuple[int, ...], dtype: Any) -> np.ndarray:
        from ..entropy import CODERS

        dtype = np.dtype(dtype)
        data = memoryview(data)
        if len(data) < 1:
            raise FormatError("empty tucker brick payload: expected at least a mode byte")
        if data[0] == MODE_CONSTANT:
            return np.full(shape, from_stored(data[1:], (1,), dtype)[0], dtype=dtype)
        if data[0] != MODE_CODED:
            raise FormatError(f"tucker brick payload: expected mode 0 or 2, found {data[0]}")
        if dtype.kind != "f" or len(shape) != 3:
            raise FormatError(f"tucker bricks are 3-D floats, found {dtype} {shape}")
        if len(data) < 1 + _HEAD.size:
            raise FormatError("tucker brick payload: header cut short")
        mean, step, r0, r1, r2, nf = _HEAD.unpack_from(data, 1)
        ranks = (r0, r1, r2)
        if step != float(self.step) or not math.isfinite(mean):
            raise FormatError(f"tucker brick payload: step {step!r} or mean {mean!r} is wrong")
        if (min(ranks) == 0) != (max(ranks) == 0) or any(r > n for r, n in zip(ranks, shape)):
            raise FormatError(f"tucker brick payload: ranks {ranks} do not fit {shape}")
        pos = 1 + _HEAD.size
        if min(ranks) == 0:
            if len(data) != pos or nf:
                raise FormatError("tucker brick payload: bytes after a rank-0 brick")
            return np.full(shape, mean, dtype=np.float64).astype(dtype)
        ne = sum(ranks)
        if len(data) < pos + ne + nf:
            raise FormatError("tucker brick payload: cut short")
        exps_all = np.frombuffer(data[pos : pos + ne], np.uint8).astype(np.int64)
        if exps_all.max() > MAX_EXP:
            raise FormatError(f"tucker brick payload: a factor exponent above {MAX_EXP}")
        pos += ne
        total = sum(n * r for n, r in zip(shape, ranks))
        flat = np.empty((1, 1, total), np.int64)
        CODERS["arith"].decode(bytes(data[pos : pos + nf]), _line_scan(total), flat)
        pos += nf
        q = np.empty(ranks, np.int64)
        CODERS["arith"].decode(bytes(data[pos:]), _core_scan(ranks), q)
        factors, exps = [], []
        at, eat = 0, 0
        for n, r in zip(shape, ranks):
            factors.append(flat.reshape(-1)[at : at + n * r].reshape(r, n).T)
            exps.append(exps_all[eat : eat + r])
            at, eat = at + n * r, eat + r
        if any(np.abs(f).max() > (1 << int(e.max()) + 1) for f, e in zip(factors, exps)):
            raise FormatError("tucker brick payload: a factor entry out of range")
        return self._rebuild(q, factors, exps, mean, tuple(shape), dtype)


def _ranks(q: np.ndarray) -> tuple[int, int, int]:
    """Per mode, one past the last slice that holds a nonzero integer."""
    out = []
    for k in range(3):
        nz = np.flatnonzero(np.abs(_unfold(q, k)).max(axis=1, initial=0) > 0)
        out.append(int(nz[-1]) + 1 if nz.size else 0)
    return tuple(out)  # type: ignore[return-value]
