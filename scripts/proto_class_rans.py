"""Prototype (not in the format): the bounded codec's coefficients coded without neighbour
contexts, with static rANS tables per subband class, against today's coders.

Issue 21's open question (README, lossy13): what would a coefficient coding that
decodes from fixed tables, several coefficients per lookup and no context from the
coefficients decoded before, cost in ratio and give in decoding speed? For each field
and bound (relative to the value range) the field is compressed with volpack's defaults
and the stream decoded once while every coefficient stream its decoder hands a coder is
recorded (the coefficients, their scan, the stream's bytes): exactly the coefficients of
the codings the encoder kept (the float CDF 9/7 bins, the quantised voxels' integer
wavelet, the outlier fields that go through a coder). Each recorded array is then
coded here, in scan order, four ways:

``single``
    one rANS symbol per coefficient in the table of its subband class (the scan's
    ``cls``, 25 classes): the zigzagged value below 32 as itself, else its bit length
    and the bit under the leading one (two symbols a length), the bits below those raw;
``quad``
    runs of four coefficients of one class as one symbol when all four are in -1..1
    (81 symbols), else an escape symbol and four ``single`` symbols (their own tables);
    the tail of a class run that is not four long: ``single`` symbols;
``single+parents``, ``quad+parents``
    the same, each table split five ways by the summed magnitudes of the coefficients'
    parents (a coarser band, decoded long before: a load, not a link in the chain from
    one symbol to the next, which is what neighbour contexts cost today's coders).

Tables: a byte per symbol on :mod:`volpack.entropy.static`'s log scale, deflated, the
12-bit frequencies rebuilt from them by its integer arithmetic; only the contexts used
get decoder tables (its split layout). Two interleaved rANS states
(:mod:`volpack.entropy.rans`). Decoding (tables rebuilt from their bytes, then one
kernel; the class runs and parents' flat indices are the scan's, made once per scan
and not timed) is timed against today's decoder of the same bytes (``coder.decode``),
alternating, best of ``--rounds`` CPU times; every decode is checked against the
recorded array. ``file_ratio_*``: the field's compression ratio with today's streams
and with the prototype's in their place (the rest of the file as it is).

    python scripts/proto_class_rans.py --datasets cam_u,climate_t --rels 1e-2,1e-3,1e-4

Writes ``proto.csv`` in ``--out`` (default ``results/lossy/lossy14``).
"""

from __future__ import annotations

import argparse
import csv
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import datasets  # noqa: E402

from volpack._jit import kernel, leading_zeros  # noqa: E402
from volpack.volume_codec.bounded_interp import _get_bits, _put_bits  # noqa: E402  (n < 32)
from volpack.entropy import rans, static  # noqa: E402
from volpack.entropy.rans import TOTAL  # noqa: E402
from volpack.format.deflate import inflate  # noqa: E402

DIRECT = 32
N_SYM = DIRECT + 2 * (33 - 6)  # bit lengths 6..32, two symbols each (|coefficients| < 2^31)
N_CLS = 25
QUAD = 81  # four values in -1..1; QUAD itself is the escape
N_PAR = 5  # classes of the parents' magnitudes (``parents`` variants)
ESC_CTX = N_CLS * N_PAR  # the single symbols after an escape and in tails: their own tables
N_CTX = 2 * ESC_CTX
VARIANTS = ("single", "quad", "single+parents", "quad+parents")
ALPHA = np.full(N_CTX, N_SYM, dtype=np.int64)  # symbols a table may hold
CSV_FIELDS = ["dataset", "rel_bound", "path", "coders", "streams", "coefficients",
              "file_bytes", "today_bytes", *(f"{v}_bytes" for v in VARIANTS),
              *(f"{v}_table_bytes" for v in VARIANTS), "today_ns",
              *(f"{v}_ns" for v in VARIANTS), "file_ratio_today",
              *(f"file_ratio_{v}" for v in VARIANTS)]  # fmt: skip


# -- symbols ------------------------------------------------------------------------------


@kernel(inline=True)
def _single(v, raw, bitpos):
    """(symbol, bitpos) of value ``v``, its low bits appended to ``raw``."""
    u = 2 * v if v >= 0 else -2 * v - 1
    if u < DIRECT:
        return u, bitpos
    n = 64 - np.int64(leading_zeros(np.uint64(u)))
    bitpos = _put_bits(raw, bitpos, u, n - 2)
    return DIRECT + 2 * (n - 6) + ((u >> (n - 2)) & 1), bitpos


@kernel(inline=True)
def _unsingle(s, raw, bitpos):
    u = s
    if s >= DIRECT:
        t = s - DIRECT
        n = 6 + (t >> 1)
        u = (np.int64(1) << (n - 1)) | ((t & 1) << (n - 2)) | _get_bits(raw, bitpos, n - 2)
        bitpos += n - 2
    return (u >> 1) ^ -(u & 1), bitpos


@kernel(inline=True)
def _parent_class(flat, pflat, i, n, use):
    """Class of the summed magnitudes of the parents of scan positions ``i .. i + n - 1``
    (already decoded: a coarser band, so no chain through the last decoded value)."""
    if not use:
        return 0
    a = np.int64(0)
    for j in range(n):
        p = pflat[i + j]
        if p >= 0:
            a += abs(np.int64(flat[p]))
    return 0 if a == 0 else (1 if a <= n else (2 if a <= 3 * n else (3 if a <= 8 * n else 4)))


@kernel
def _symbols(vals, flat, pflat, cls, runs, quad, parents, sym, ctx, raw):
    """Symbols and contexts of ``vals`` (scan order; ``flat`` the array itself, ``pflat``
    each position's parent in it or -1) in class runs ``runs`` (start, end pairs);
    ``quad``: group fours. Returns (symbol count, raw bits)."""
    k = 0
    bitpos = 0
    for r in range(runs.shape[0]):
        i, end = runs[r, 0], runs[r, 1]
        c = np.int64(cls[i]) * N_PAR
        if quad:
            while i + 4 <= end:
                pc = _parent_class(flat, pflat, i, 4, parents)
                small = True
                s = 0
                for j in range(3, -1, -1):
                    v = vals[i + j]
                    small = small and -1 <= v <= 1
                    s = 3 * s + (v + 1)
                sym[k], ctx[k] = (s if small else QUAD), c + pc
                k += 1
                if not small:
                    for j in range(4):
                        sym[k], bitpos = _single(vals[i + j], raw, bitpos)
                        ctx[k] = ESC_CTX + c + pc
                        k += 1
                i += 4
        base = ESC_CTX + c if quad else c
        while i < end:
            sym[k], bitpos = _single(vals[i], raw, bitpos)
            ctx[k] = base + _parent_class(flat, pflat, i, 1, parents)
            k += 1
            i += 1
    return k, bitpos


@kernel(inline=True)
def _sym(data, x0, x1, pos, k, c, table):
    """The next symbol in context ``c``, the two states taking turns: (symbol, x0, x1,
    pos, k). ``table``: (context map, split symbol table, split info table), as
    :mod:`volpack.entropy.static` keeps them (only the contexts used, in L1 mostly)."""
    cmap, syms, info = table
    cb = cmap[c] << 12
    if k & 1:
        s, x1, pos = rans.decode_symbol_split(data, x1, pos, cb, syms, info)
    else:
        s, x0, pos = rans.decode_symbol_split(data, x0, pos, cb, syms, info)
    return s, x0, x1, pos, k + 1


@kernel(nrt=False)
def _decode(data, raw, table, cls, runs, perm, pflat, quad, parents, qvals, flat):
    """The decoder: per class run, fours (``quad``) then singles, into ``flat`` at
    ``perm``. Returns 0, or -1 when the states do not end where the encoder began."""
    x0, x1, pos = rans.open_states(data)
    k = 0
    bitpos = 0
    for r in range(runs.shape[0]):
        i, end = runs[r, 0], runs[r, 1]
        c = np.int64(cls[i]) * N_PAR
        if quad:
            while i + 4 <= end:
                cc = c + _parent_class(flat, pflat, i, 4, parents)
                s, x0, x1, pos, k = _sym(data, x0, x1, pos, k, cc, table)
                if s < QUAD:
                    for j in range(4):
                        flat[perm[i + j]] = qvals[s, j]
                else:
                    for j in range(4):
                        t, x0, x1, pos, k = _sym(data, x0, x1, pos, k, ESC_CTX + cc, table)
                        flat[perm[i + j]], bitpos = _unsingle(t, raw, bitpos)
                i += 4
        base = ESC_CTX + c if quad else c
        while i < end:
            cc = base + _parent_class(flat, pflat, i, 1, parents)
            t, x0, x1, pos, k = _sym(data, x0, x1, pos, k, cc, table)
            flat[perm[i]], bitpos = _unsingle(t, raw, bitpos)
            i += 1
    return 0 if rans.state_ok(data, x0, x1, pos) else -1


def _quad_values() -> np.ndarray:
    s = np.arange(QUAD)
    return np.stack([(s // 3**j) % 3 - 1 for j in range(4)], axis=1).astype(np.int64)


QVALS = _quad_values()


def class_runs(cls: np.ndarray) -> np.ndarray:
    """(start, end) of each run of one class along the scan."""
    edges = np.flatnonzero(np.diff(cls.astype(np.int64))) + 1
    starts = np.concatenate([[0], edges])
    ends = np.concatenate([edges, [cls.size]])
    return np.stack([starts, ends], axis=1).astype(np.int64)


def parent_index(scan) -> np.ndarray:
    """Each scan position's parent as a flat index of the array (-1 for roots): a
    property of the scan, made once per scan (not timed)."""
    par = scan.parent.astype(np.int64)
    return np.where(par >= 0, scan.perm[np.maximum(par, 0)], -1).astype(np.int64)


def _flags(variant: str) -> tuple[bool, bool]:
    return variant.startswith("quad"), variant.endswith("parents")


def encode(coeffs: np.ndarray, scan, pflat, variant: str) -> tuple[bytes, bytes, bytes]:
    """(deflated tables, rANS stream, raw bits) of the coefficients in scan order."""
    flat = np.ascontiguousarray(coeffs.reshape(-1), dtype=np.int64)
    if flat.size and np.abs(flat).max() >= 2**31:
        raise ValueError("coefficients of 2^31 or more: beyond the prototype's alphabet")
    vals = flat[scan.perm]
    runs = class_runs(scan.cls)
    n = vals.size
    sym = np.empty(2 * n + 8, np.int64)
    ctx = np.empty(2 * n + 8, np.int64)
    raw = np.zeros(8 * n + 16, np.uint8)
    k, nbits = _symbols(vals, flat, pflat, scan.cls, runs, *_flags(variant), sym, ctx, raw)
    sym, ctx = sym[:k], ctx[:k]
    counts = np.bincount(ctx * N_SYM + sym, minlength=N_CTX * N_SYM).reshape(N_CTX, N_SYM)
    # static.py's tables: a byte per symbol on a log scale, the frequencies rebuilt
    # from those by integer arithmetic on both sides
    tot = np.maximum(counts.sum(axis=1, keepdims=True), 1)
    levels = static.level_of(
        np.where(counts > 0, np.maximum(1, (counts * TOTAL + tot // 2) // tot), 0)
    )
    freq = _freqs(levels)
    used = np.flatnonzero(counts.sum(axis=1))
    compact = np.full(N_CTX, -1, dtype=np.int64)
    compact[used] = np.arange(used.size)
    stream = rans.encode(sym, compact[ctx], freq[used])
    return static._pack_levels(levels), stream, raw[: (nbits + 7) // 8].tobytes()


def _freqs(levels):
    out = np.zeros((N_CTX, N_SYM), dtype=np.int64)
    static._scale_rows(levels, ALPHA, static._VALUES, out)
    return out


def decode(parts, scan, pflat, runs, out: np.ndarray, variant: str) -> None:
    tables, stream, rawb = parts
    body = np.frombuffer(inflate(tables, N_CTX * (N_SYM + 1), "prototype tables"), np.uint8)
    levels = np.zeros((N_CTX, N_SYM), dtype=np.int64)
    if static._read_levels(body, ALPHA, levels):
        raise AssertionError("the prototype's tables are corrupt")
    freq = _freqs(levels)
    used = np.flatnonzero(freq.any(axis=1))
    cmap = np.zeros(N_CTX, dtype=np.int64)
    cmap[used] = np.arange(used.size)
    syms = np.zeros(used.size << 12, dtype=np.uint8)
    info = np.zeros(used.size << 8, dtype=np.uint32)
    static._slots(freq[used], syms, info)
    table = (cmap, syms, info)
    data = np.frombuffer(stream + bytes(2), np.uint8)
    raw = np.frombuffer(rawb + bytes(16), np.uint8)  # _get_bits' slack
    flat = out.reshape(-1)
    if _decode(data, raw, table, scan.cls, runs, scan.perm, pflat, *_flags(variant), QVALS, flat):
        raise AssertionError("the prototype's states did not end where they began")


# -- recording what today's decoder decodes -------------------------------------------------


def record(blob: bytes) -> list:
    """(coder module, stream bytes, scan, decoded coefficients) of every coefficient
    stream the decoder of ``blob`` decodes."""
    from volpack import api
    from volpack.entropy import CODERS

    seen = []
    saved = dict(CODERS)

    class Spy:
        def __init__(self, coder):
            self.coder, self.encode = coder, coder.encode

        def decode(self, data, scan, out):
            self.coder.decode(data, scan, out)
            seen.append((self.coder, bytes(data), scan, out.copy()))

    try:
        for name in CODERS:
            CODERS[name] = Spy(saved[name])
        api.decompress_array(blob)
    finally:
        CODERS.update(saved)
    return seen


def run_cell(name: str, a: np.ndarray, rel: float, rounds: int) -> dict | None:
    from bench_lossy_decode import best_interleaved, payload_paths

    from volpack import api

    e = rel * float(np.nanmax(a) - np.nanmin(a))
    blob = api.compress_array(a, max_error=e)
    seen = record(blob)
    if not seen:  # the interpolation path or the fitted predictor: no coefficients
        return None
    today = sum(len(d) for _, d, _, _ in seen)
    pfl = [parent_index(s) for _, _, s, _ in seen]  # the scan's, as its other arrays
    runs = [class_runs(s.cls) for _, _, s, _ in seen]
    coded = {
        v: [encode(c, s, pf, v) for (_, _, s, c), pf in zip(seen, pfl)] for v in VARIANTS
    }
    outs = [np.empty_like(c) for *_, c in seen]

    def today_dec():
        for (coder, d, s, _), o in zip(seen, outs):
            coder.decode(d, s, o)

    def proto_dec(v):
        def go():
            for parts, (_, _, s, _), pf, r, o in zip(coded[v], seen, pfl, runs, outs):
                decode(parts, s, pf, r, o, v)

        return go

    calls = {"today": today_dec, **{v: proto_dec(v) for v in VARIANTS}}
    for k, f in calls.items():  # check every decoder, and compile
        for o in outs:
            o.fill(7)
        f()
        for (*_, c), o in zip(seen, outs):
            if not np.array_equal(c, o):
                raise AssertionError(f"{k} did not decode its coefficients")
    t = best_interleaved(calls, rounds)
    n = sum(c.size for *_, c in seen)
    size = {v: sum(sum(len(p) for p in parts) for parts in coded[v]) for v in VARIANTS}
    coders = sorted({f"{m.__name__.rsplit('.', 1)[-1]}:{d[0]}" if m.__name__.endswith("choose")
                     else m.__name__.rsplit(".", 1)[-1] for m, d, _, _ in seen})  # fmt: skip
    row = {
        "dataset": name, "rel_bound": rel, "path": payload_paths(blob),
        "coders": " ".join(coders), "streams": len(seen), "coefficients": n,
        "file_bytes": len(blob), "today_bytes": today, "file_ratio_today": a.nbytes / len(blob),
    }  # fmt: skip
    for k in calls:
        row[f"{k}_ns"] = 1e9 * t[k] / max(n, 1)
    for v in VARIANTS:
        row[f"{v}_bytes"] = size[v]
        row[f"{v}_table_bytes"] = sum(len(parts[0]) for parts in coded[v])
        row[f"file_ratio_{v}"] = a.nbytes / (len(blob) - today + size[v])
    return row


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--datasets", default="cam_u,climate_t,cam_t,hgt_500,tgv_u,climate_rh")
    ap.add_argument("--rels", default="1e-2,1e-3,1e-4")
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--out", default="results/lossy/lossy14")
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for name in args.datasets.split(","):
        a = datasets.load(name)[0]
        for rel in (float(r) for r in args.rels.split(",")):
            row = run_cell(name, a, rel, args.rounds)
            if row is None:
                print(f"{name:16s} {rel:<7g} no coefficient stream", flush=True)
                continue
            rows.append(row)
            tb = max(row["today_bytes"], 1)
            print(
                f"{name:16s} {rel:<7g} {row['path'][:36]:36s} {row['coders']:9s}"
                f" coef {row['coefficients']:8d} today {tb:7d} B {row['today_ns']:5.1f} ns |"
                + " |".join(
                    f" {v} {row[f'{v}_bytes'] / tb - 1:+6.1%} {row[f'{v}_ns']:5.1f} ns"
                    for v in VARIANTS
                ),
                flush=True,
            )

    with open(out / "proto.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=CSV_FIELDS)
        w.writeheader()
        for row in rows:
            w.writerow({k: (f"{v:.4g}" if isinstance(v, float) else v) for k, v in row.items()})
    return 0


if __name__ == "__main__":
    sys.exit(main())
