"""Slow, obviously correct references that the fast code is tested against.

Each module's references sit in their own headed section; add new ones at the end.
"""

# --- prep and metrics ---


def _prep_gauss_taps(n, f, i):
    """Input indices and unnormalised weights of output i along one axis (sigma f/3, 3 sigma)."""
    import math

    c = i * f + (f - 1) / 2
    sigma = f / 3
    return [
        (j, math.exp(-((j - c) ** 2) / (2 * sigma * sigma))) for j in range(n) if abs(j - c) <= f
    ]


def prep_downsample(a, f, method="box"):
    """Block average (box) or Gaussian-weighted average of a 3-D array, voxel by voxel.

    Box sums of integers are kept as exact fractions and rounded half to even; Gaussian
    weights are normalised over the whole 3-D window (not axis by axis).
    """
    from fractions import Fraction

    import numpy as np

    nz, ny, nx = a.shape
    shape = tuple(-(-n // f) for n in a.shape)
    out = np.zeros(shape, dtype=a.dtype)
    is_int = a.dtype.kind in "iub"
    for i in range(shape[0]):
        for j in range(shape[1]):
            for k in range(shape[2]):
                if method == "box":
                    vals = [
                        a[z, y, x].item()
                        for z in range(i * f, min(i * f + f, nz))
                        for y in range(j * f, min(j * f + f, ny))
                        for x in range(k * f, min(k * f + f, nx))
                    ]
                    if is_int:
                        out[i, j, k] = round(Fraction(sum(vals), len(vals)))
                    else:
                        out[i, j, k] = sum(vals) / len(vals)
                    continue
                num = den = 0.0
                for z, wz in _prep_gauss_taps(nz, f, i):
                    for y, wy in _prep_gauss_taps(ny, f, j):
                        for x, wx in _prep_gauss_taps(nx, f, k):
                            w = wz * wy * wx
                            num += w * float(a[z, y, x])
                            den += w
                out[i, j, k] = round(num / den) if is_int else num / den
    return out


def prep_gaussian_float(a, f):
    """The Gaussian downsample of ``a`` before rounding (float64), for tie checks."""
    import numpy as np

    return prep_downsample(np.asarray(a, dtype=np.float64), f, "gaussian")


def prep_resample(a, old, new, order=1):
    """Trilinear (order 1) or nearest (order 0) resampling by the textbook formula per voxel."""
    import math

    import numpy as np

    counts = [
        int(math.floor((n - 1) * o / s + 1e-9)) + 1
        for n, o, s in zip(a.shape, old, new, strict=True)
    ]
    out = np.zeros(counts, dtype=np.float64)
    for idx in np.ndindex(*counts):
        p = [min(i * s / o, n - 1) for i, s, o, n in zip(idx, new, old, a.shape, strict=True)]
        if order == 0:
            out[idx] = a[
                tuple(min(math.floor(q + 0.5), n - 1) for q, n in zip(p, a.shape, strict=True))
            ]
            continue
        total = 0.0
        for corner in np.ndindex(2, 2, 2):
            w, pos = 1.0, []
            for q, c, n in zip(p, corner, a.shape, strict=True):
                lo = min(math.floor(q), max(n - 2, 0))
                t = q - lo
                w *= t if c else 1 - t
                pos.append(min(lo + c, n - 1))
            if w:
                total += w * float(a[tuple(pos)])
        out[idx] = total
    return out


def metric_abs_errors(a, b):
    """``|a - b|`` of every voxel as exact Python numbers (ints stay ints)."""
    return [abs(x - y) for x, y in zip(a.ravel().tolist(), b.ravel().tolist(), strict=True)]


def metric_max_error(a, b):
    return float(max(metric_abs_errors(a, b), default=0))


def metric_rmse(a, b):
    import math

    e = metric_abs_errors(a, b)
    return math.sqrt(sum(float(v) ** 2 for v in e) / len(e)) if e else 0.0


def metric_psnr(a, b):
    import math

    vals = a.ravel().tolist()
    peak = max(vals) - min(vals)
    mse = metric_rmse(a, b) ** 2
    return math.inf if mse == 0 else 20 * math.log10(peak) - 10 * math.log10(mse)


# --- coefficient scans and fixed codes ---


def entropy_scan_parents(shape, levels):
    """Parent of every coefficient (flat index -> flat index or -1), written out by band.

    A detail coefficient at level k, orientation o, local position p has its parent in the
    band (k + 1, o) at p // 2 along axes split at level k + 1 and p along the others, clipped
    to that band; the coarsest details and the approximation are roots.
    """
    n = list(shape)
    bands = {}
    nlev = max(levels)
    for k in range(nlev):
        active = [levels[a] > k for a in range(3)]
        lo = [(n[a] + 1) // 2 if active[a] else n[a] for a in range(3)]
        for oz in (0, 1):
            for oy in (0, 1):
                for ox in (0, 1):
                    o = (oz, oy, ox)
                    if o == (0, 0, 0) or any(o[a] and not active[a] for a in range(3)):
                        continue
                    start = [lo[a] if o[a] else 0 for a in range(3)]
                    size = [n[a] - lo[a] if o[a] else lo[a] for a in range(3)]
                    if min(size) > 0:
                        bands[(k, o)] = (start, size)
        n = lo
    parent = {}
    for (k, o), (start, size) in bands.items():
        up = bands.get((k + 1, o))
        for z in range(size[0]):
            for y in range(size[1]):
                for x in range(size[2]):
                    me = ((start[0] + z) * shape[1] + start[1] + y) * shape[2] + start[2] + x
                    if up is None:
                        parent[me] = -1
                        continue
                    ps, psz = up
                    loc = []
                    for a, p in enumerate((z, y, x)):
                        q = p // 2 if levels[a] > k + 1 else p
                        loc.append(min(q, psz[a] - 1))
                    parent[me] = (
                        ((ps[0] + loc[0]) * shape[1] + ps[1] + loc[1]) * shape[2] + ps[2] + loc[2]
                    )
    total = shape[0] * shape[1] * shape[2]
    return [parent.get(i, -1) for i in range(total)]


def sigmap_scan(shape, levels, order):
    """The coefficient scan of :func:`volpack.wavelet.sigmap.scan` written out in plain
    Python: ``(perm, end, parent, cls, nbr)`` as lists (positions, -1 for none)."""
    from volpack.wavelet.dwt3 import subbands
    from volpack.wavelet.sigmap import APPROX_CLASS

    nlev = max(levels)
    bands = sorted(subbands(shape, levels), key=lambda b: (-b.level, b.bits))
    by_key = {(b.level, b.bits): b for b in bands}
    line, up, near, kind = [], {}, {}, {}
    for b in bands:
        pb = by_key.get((b.level + 1, b.bits)) if b.level < nlev else None
        for z in range(b.size[0]):
            for y in range(b.size[1]):
                for x in range(b.size[2]):
                    f = ((b.start[0] + z) * shape[1] + b.start[1] + y) * shape[2] + b.start[2] + x
                    line.append(f)
                    kind[f] = APPROX_CLASS if b.level == nlev else min(b.level, 5) * 4 + sum(b.bits)
                    near[f] = [f - shape[1] * shape[2] if z else -1, f - shape[2] if y else -1,
                               f - 1 if x else -1]  # fmt: skip
                    if pb is None:
                        up[f] = -1
                        continue
                    p = [min(v // 2 if lv > b.level + 1 else v, n - 1)
                         for v, lv, n in zip((z, y, x), levels, pb.size)]  # fmt: skip
                    up[f] = (
                        ((pb.start[0] + p[0]) * shape[1] + pb.start[1] + p[1]) * shape[2]
                        + pb.start[2]
                        + p[2]
                    )
    n = len(line)
    if order == "dfs":
        kids = {f: [] for f in line}
        for f in line:
            if up[f] >= 0:
                kids[up[f]].append(f)

        def walk(f):
            out = [f]
            for k in kids[f]:
                out += walk(k)
            return out

        perm, end = [], []
        for f in line:
            if up[f] < 0:
                sub = walk(f)
                end += [len(perm) + j + len(walk(g)) for j, g in enumerate(sub)]
                perm += sub
    else:
        perm, end = list(line), list(range(1, n + 1))
        if order == "rows":
            start = 0
            for b in bands:
                bz, by, bx = b.size
                for r in range(bz * by if bx > 1 else 0):
                    end[start + bx * r] = start + bx * r + bx
                start += bz * by * bx
    at = {f: i for i, f in enumerate(perm)}
    parent = [at[up[f]] if up[f] >= 0 else -1 for f in perm]
    nbr = [[at[g] if g >= 0 else -1 for g in near[f]] for f in perm]
    return perm, end, parent, [kind[f] for f in perm], nbr


def fixed_code_bits(m):
    """The fixed prefix code of m as a string of '0'/'1'."""
    if m == 0:
        return "0"
    n = m.bit_length()
    return "1" * n + "0" + format(m, "b")[1:]


def _zigzag(c):
    return 2 * c if c >= 0 else -2 * c - 1


def _pack(bits):
    bits += "0" * (-len(bits) % 8)
    return bytes(int(bits[i : i + 8], 2) for i in range(0, len(bits), 8))


def huffman_encode(coeffs, perm, end):
    """Subtree flag at every inner position, then the fixed code of each survivor."""
    flat = [int(v) for v in coeffs.ravel()]
    vals = [flat[j] for j in perm]
    out, i = [], 0
    while i < len(vals):
        e = int(end[i])
        if e > i + 1:
            zero = not any(vals[i:e])
            out.append("1" if zero else "0")
            if zero:
                i = e
                continue
        out.append(fixed_code_bits(_zigzag(vals[i])))
        i += 1
    return _pack("".join(out))


def rle_encode(coeffs, perm):
    """Zero run before each non-zero value, then the code of its mapped value minus one."""
    flat = [int(v) for v in coeffs.ravel()]
    out, run = [], 0
    for j in perm:
        m = _zigzag(flat[j])
        if m == 0:
            run += 1
            continue
        out.append(fixed_code_bits(run) + fixed_code_bits(m - 1))
        run = 0
    if run:
        out.append(fixed_code_bits(run))
    return _pack("".join(out))


# --- wavelet ---


def _wavelet_wss(x, p):
    """x at position p of the whole-sample symmetric (mirror about 0 and n-1) extension."""
    n = len(x)
    if n == 1:
        return x[0]
    while p < 0 or p > n - 1:
        p = -p if p < 0 else 2 * (n - 1) - p
    return x[p]


def _wavelet_hss(x, p):
    """x at position p of the half-sample symmetric (mirror about -1/2 and n-1/2) extension."""
    n = len(x)
    while p < 0 or p > n - 1:
        p = -1 - p if p < 0 else 2 * n - 1 - p
    return x[p]


def wavelet_lift_1d(x, wavelet, seen=None):
    """One level of the integer lifting transform of the list ``x``: returns ``s + d``.

    Written as the lifting of the infinitely extended signal, evaluated at each output
    position; ``//`` floors. ``seen`` (a list) collects every value the fast code stores,
    intermediate details of 2/6 included.
    """
    n = len(x)
    ns, nd = (n + 1) // 2, n // 2
    if wavelet in ("53", "97m"):

        def X(p):
            return _wavelet_wss(x, p)

        def D(p):  # detail at odd position p
            if wavelet == "53":
                return X(p) - (X(p - 1) + X(p + 1)) // 2
            return X(p) - (9 * (X(p - 1) + X(p + 1)) - (X(p - 3) + X(p + 3)) + 8) // 16

        d = [D(2 * i + 1) for i in range(nd)]
        s = [X(2 * i) + (D(2 * i - 1) + D(2 * i + 1) + 2) // 4 for i in range(ns)]
    else:

        def X(p):
            return _wavelet_hss(x, p)

        def D1(i):  # S-transform of the pair at positions 2i, 2i+1
            return X(2 * i + 1) - X(2 * i)

        def S(i):
            return X(2 * i) + D1(i) // 2

        if wavelet == "haar":
            d = [D1(i) for i in range(nd)]
        else:
            d = [D1(i) + (S(i - 1) - S(i + 1) + 2) // 4 for i in range(nd)]
            if seen is not None:
                seen.extend(D1(i) for i in range(nd))
        s = [S(i) for i in range(ns)]
    if seen is not None:
        seen.extend(s + d)
    return s + d


def wavelet_forward(a, levels, wavelet, seen=None):
    """3-D Mallat-layout forward transform, one line at a time in Python integers."""
    import numpy as np

    out = np.array(a, dtype=object)
    cur = list(out.shape)
    for k in range(max(levels)):
        for axis in range(3):
            if levels[axis] <= k:
                continue
            region = out[: cur[0], : cur[1], : cur[2]]
            moved = np.moveaxis(region, axis, -1)
            for idx in np.ndindex(*moved.shape[:-1]):
                moved[idx] = wavelet_lift_1d([int(v) for v in moved[idx]], wavelet, seen)
        cur = [(n + 1) // 2 if lv > k else n for n, lv in zip(cur, levels)]
    return out.astype(np.int64)


def _arith_context(i, nbits, nprev, parent, cls, nbr, nq=12):
    """The context ``class * 12 + q`` of scan position ``i`` and its estimate ``q``."""
    par = int(parent[i])
    npar = nbits[par] if par >= 0 else nprev
    # local estimate: the previous coefficient and the band neighbours already coded
    seen = [nprev] + [nbits[int(j)] for j in nbr[i] if 0 <= int(j) < i]
    cnt, total = len(seen), sum(seen)
    q = min(nq - 1, (npar * cnt + 7 * total + 4 * cnt) // (8 * cnt))
    return int(cls[i]) * nq + q, q


def arith_encode(coeffs, perm, end, parent, cls, nbr):
    """The arithmetic coder with ``low`` as an unbounded integer: no carry bookkeeping.

    Follows formats/wavelet-1.md step by step; the bytes are the final ``low`` written
    out big-endian after the leading zero byte.
    """
    nq, n_classes, mant_bits = 12, 25, 2
    rate = [1, 2, 2, 3, 3, 3, 3, 4, 4, 4, 4, 4, 4, 4, 4, 5]
    n_flag = n_classes * nq
    n_tree = n_flag * 64
    prob, used = {}, {}
    low, rng, nbytes = 0, 0xFFFFFFFF, 0

    def put(k, bit):
        nonlocal low, rng, nbytes
        p = prob.get(k, 2048)
        u = used.get(k, 0)
        bound = (rng >> 12) * p
        if bit:
            low, rng = low + bound, rng - bound
            p -= p >> rate[u]
        else:
            rng = bound
            p += (4096 - p) >> rate[u]
        prob[k], used[k] = p, min(u + 1, 15)
        while rng < 1 << 24:
            rng <<= 8
            low <<= 8
            nbytes += 1

    def put_even(bits):
        """Bits at one half each, up to 16 at a time: 2^t equal parts of the range."""
        nonlocal low, rng, nbytes
        while bits:
            t = min(len(bits), 16)
            chunk, bits = bits[:t], bits[t:]
            rng >>= t
            low += int(chunk, 2) * rng
            while rng < 1 << 24:
                rng <<= 8
                low <<= 8
                nbytes += 1

    flat = [int(v) for v in coeffs.ravel()]
    vals = [flat[j] for j in perm]
    nbits = [0] * len(vals)
    nprev = 0
    i = 0
    while i < len(vals):
        ctx, q = _arith_context(i, nbits, nprev, parent, cls, nbr)
        e = int(end[i])
        if e > i + 1:
            live = any(vals[i:e])
            put(ctx, int(live))
            if not live:
                nprev = 0
                i = e
                continue
        m = _zigzag(vals[i])
        nb = m.bit_length()
        base = n_flag + ctx * 64
        put(base, int(nb >= q))
        if nb >= q:
            j = q
            while j < 63:
                put(base + 1 + min(j - q, 46), int(nb > j))
                if nb == j:
                    break
                j += 1
        else:
            j = q - 1
            while j > 0:
                put(base + 48 + (q - 1 - j), int(nb < j))
                if nb == j:
                    break
                j -= 1
        below = format(m, "b")[1:] if nb else ""
        modelled = min(nb - 1, mant_bits) if nb else 0
        prefix = 1
        for b in below[:modelled]:
            put(n_flag + n_tree + ((nb << mant_bits) + prefix) * n_classes + int(cls[i]), int(b))
            prefix = 2 * prefix + int(b)
        put_even(below[modelled:])
        nbits[i] = nb
        nprev = nb
        i += 1
    total = 1 + nbytes + 4  # leading zero byte, the shifted-out bytes, the final low
    return low.to_bytes(total, "big")


def arith2_encode(coeffs, perm, end, parent, cls, nbr):
    """The ``arith2`` coder written from formats/wavelet-1.md: symbols as (start, freq)
    pairs from plain-list tables, then rANS over them last to first with Python ints."""
    nq, n_classes, total = 12, 25, 1 << 15
    rate = [1, 2, 2, 3, 3, 3, 3, 4, 4, 4, 4, 4, 4, 4, 4, 5]
    prob, used = {}, {}
    tables = {}
    syms = []  # (start, freq)
    plain = []  # bits, in stream order

    def binary(k, bit):
        p, u = prob.get(k, 2048), used.get(k, 0)
        f0 = 8 * p
        syms.append((f0, total - f0) if bit else (0, f0))
        p = p - (p >> rate[u]) if bit else p + ((4096 - p) >> rate[u])
        prob[k], used[k] = p, min(u + 1, 15)

    def bounds(f):
        k, t = len(f), sum(f)
        scale = ((total - k) << 16) // t
        return [((sum(f[:j]) * scale) >> 16) + j for j in range(k)] + [total]

    def table(key, k, first, step):
        if key not in tables:
            f = list(first)
            tables[key] = {"f": f, "T": sum(f), "R": sum(f) + 1, "b": bounds(f), "step": step}
        return tables[key]

    def symbol(tab, s):
        b = tab["b"]
        syms.append((b[s], b[s + 1] - b[s]))
        tab["f"][s] += 1
        tab["T"] += 1
        if tab["T"] >= tab["R"]:
            if tab["T"] > 1024:
                tab["f"] = [(f + 1) >> 1 for f in tab["f"]]
                tab["T"] = sum(tab["f"])
            tab["b"] = bounds(tab["f"])
            tab["R"] = tab["T"] + min(tab["T"], tab["step"])

    def put_plain(v, n):  # a group of n plain bits: the value's bit j at the j-th place
        plain.extend((v >> j) & 1 for j in range(n))

    flat = [int(v) for v in coeffs.ravel()]
    vals = [flat[j] for j in perm]
    nbits = [0] * len(vals)
    nprev = 0
    i = 0
    while i < len(vals):
        ctx, q = _arith_context(i, nbits, nprev, parent, cls, nbr)
        e = int(end[i])
        if e > i + 1:
            live = any(vals[i:e])
            binary(ctx, int(live))
            if not live:
                nprev = 0
                i = e
                continue
        m = _zigzag(vals[i])
        nb = m.bit_length()
        prior = [1 << (4 - abs(s - q)) if abs(s - q) <= 4 else 0 for s in range(20)]
        symbol(table(("n", ctx), 20, prior, 16), min(nb, 19))
        if nb >= 19:
            put_plain(nb - 19, 6)
        if nb == 2:
            binary(n_classes * nq + int(cls[i]), m & 1)
        elif nb >= 3:
            symbol(table(("m", nb * n_classes + int(cls[i])), 4, [1] * 4, 8), (m >> (nb - 3)) & 3)
            r = nb - 3
            if r > 48:  # two groups, the top bits first
                put_plain((m >> 24) & ((1 << (r - 24)) - 1), r - 24)
                r = 24
            put_plain(m & ((1 << r) - 1), r)
        nbits[i] = nb
        nprev = nb
        i += 1
    x = [1 << 16, 1 << 16]
    out = []  # words in emission order
    for k in range(len(syms) - 1, -1, -1):
        start, freq = syms[k]
        if x[k % 2] >= freq << 17:
            out.append(x[k % 2] & 0xFFFF)
            x[k % 2] >>= 16
        x[k % 2] = ((x[k % 2] // freq) << 15) + x[k % 2] % freq + start
    words = [x[0] & 0xFFFF, x[0] >> 16, x[1] & 0xFFFF, x[1] >> 16] + out[::-1]
    plain += [0] * (-len(plain) % 8)
    raw = bytes(sum(plain[8 * j + b] << b for b in range(8)) for j in range(len(plain) // 8))
    body = b"".join(w.to_bytes(2, "little") for w in words)
    return len(words).to_bytes(4, "little") + body + raw


# --- render tables ---


def render_preint_reference(tf_table, length, steps=2000, lighting=False):
    """Pre-integration table by brute force: the volume rendering integral of every segment.

    Segment (i, j) is ``length`` voxels long, its scalar runs linearly from index i to j.
    Extinction per voxel ``tau = -ln(1 - a)`` (``a = 1`` -> 40) and colour are linear in
    the scalar between entries; emission is ``c * tau``. The segment is cut into ``steps``
    equal slabs, each taken constant at its midpoint and composited front to back WITH
    the attenuation of everything in front of it. Returns (n, n, 4) float64
    ``(C_r, C_g, C_b, A)``, premultiplied; with ``lighting`` (n, n, 7), adding the colour
    with each slab weighted by its position along the segment (0 front, 1 back).
    """
    import numpy as np

    tab = np.asarray(tf_table, dtype=np.float64)
    n = len(tab)
    a = tab[:, 3]
    tau = np.where(a >= 1.0, 40.0, -np.log(np.maximum(1.0 - a, 1e-300)))
    tau = np.minimum(tau, 40.0)
    idx = np.arange(n, dtype=np.float64)
    h = length / steps
    frac = (np.arange(steps) + 0.5) / steps
    out = np.zeros((n, n, 7 if lighting else 4))
    for i in range(n):
        for j in range(n):
            s = i + (j - i) * frac
            t = np.interp(s, idx, tau)
            slab_alpha = 1.0 - np.exp(-t * h)
            # transmittance of everything in front of each slab
            trans = np.concatenate([[1.0], np.cumprod(1.0 - slab_alpha)])
            for ch in range(3):
                c = np.interp(s, idx, tab[:, ch])
                out[i, j, ch] = np.sum(trans[:-1] * slab_alpha * c)
                if lighting:
                    out[i, j, 4 + ch] = np.sum(frac * trans[:-1] * slab_alpha * c)
            out[i, j, 3] = 1.0 - trans[-1]
    return out


def render_iso_reference(values, isos):
    """First iso crossed going from ``values[f]`` to ``values[b]``, by walking the isos.

    ``isos``: list of (value, ...). A rising segment hits an iso v with f < v <= b, a
    falling one with b <= v < f; of several, the one nearest the front value. Returns an
    (n, n) list of lists of the iso's position in ``isos`` (-1 for none).
    """
    n = len(values)
    out = [[-1] * n for _ in range(n)]
    for f in range(n):
        for b in range(n):
            sf, sb = values[f], values[b]
            best = None
            for q, iso in enumerate(isos):
                v = iso[0]
                crossed = (sf < v <= sb) if sb > sf else (sb <= v < sf) if sb < sf else False
                if crossed and (best is None or abs(v - sf) < abs(isos[best][0] - sf)):
                    best = q
            out[f][b] = -1 if best is None else best
    return out


def render_field_reference(origins, dirs, inside, field, tf_table, lo, hi, unit, t_max, steps):
    """Ray casting by brute force for the mesh renderer: ``steps`` midpoint samples per
    ray over ``[0, t_max]``, each kept when ``inside(points)`` (the mesh's region, known
    analytically), classified through ``tf_table`` (linear in value over [lo, hi]) with
    opacity per ``unit`` of length, and composited front to back. World coordinates
    (z, y, x). Returns (h, w, 4) premultiplied."""
    import numpy as np

    tab = np.asarray(tf_table, float)
    n = len(tab)
    h, w = origins.shape[:2]
    dt = t_max / steps
    ts = (np.arange(steps) + 0.5) * dt
    out = np.zeros((h, w, 4))
    tau = np.minimum(-np.log(np.maximum(1.0 - tab[:, 3], 1e-300)), 40.0)
    grid = np.linspace(lo, hi, n)
    for r in range(h):
        for c in range(w):
            pts = origins[r, c] + ts[:, None] * dirs[r, c]
            ok = inside(pts)
            s = field(pts)
            a = np.where(ok, 1.0 - np.exp(-np.interp(s, grid, tau) * dt / unit), 0.0)
            trans = np.concatenate([[1.0], np.cumprod(1.0 - a)])[:-1]
            for ch in range(3):
                out[r, c, ch] = np.sum(trans * a * np.interp(s, grid, tab[:, ch]))
            out[r, c, 3] = 1.0 - trans[-1] * (1.0 - a[-1])
    return out


# --- float CDF 9/7 (formats/lossy-1.md, float wavelet path) ---


def cdf97_lift_1d(x, backward=False):
    """One level of the float CDF 9/7 on a Python list, sample by sample as the spec reads."""
    a, b, g, d_, z = (-1.586134342059924, -0.052980118572961, 0.882911075530934,
                      0.443506852043971, 1.149604398860241)  # fmt: skip
    n = len(x)
    ns, nd = (n + 1) // 2, n // 2

    def predict(s, d, c):
        for i in range(nd):
            right = s[i + 1] if i + 1 < ns else s[i]
            d[i] += c * (s[i] + right)

    def update(s, d, c):
        for i in range(ns):
            left = d[i - 1] if i > 0 else d[0]
            right = d[i] if i < nd else d[nd - 1]
            s[i] += c * (left + right)

    if not backward:
        s, d = [float(v) for v in x[0::2]], [float(v) for v in x[1::2]]
        predict(s, d, a)
        update(s, d, b)
        predict(s, d, g)
        update(s, d, d_)
        return [v * z for v in s] + [v / z for v in d]
    s, d = [v / z for v in x[:ns]], [v * z for v in x[ns:]]
    update(s, d, -d_)
    predict(s, d, -g)
    update(s, d, -b)
    predict(s, d, -a)
    out = [0.0] * n
    out[0::2], out[1::2] = s, d
    return out


def cdf97_transform(arr, levels, backward=False):
    """The 3-D float CDF 9/7 in the Mallat layout, one line at a time."""
    import numpy as np

    a = np.array(arr, dtype=np.float64)
    regions = [a.shape]
    for k in range(max(levels)):
        regions.append(tuple((n + 1) // 2 if lv > k else n for n, lv in zip(regions[-1], levels)))
    ks = range(max(levels) - 1, -1, -1) if backward else range(max(levels))
    for k in ks:
        cur = regions[k]
        for axis in (2, 1, 0) if backward else (0, 1, 2):
            if levels[axis] <= k:
                continue
            view = np.moveaxis(a[tuple(slice(0, n) for n in cur)], axis, -1)
            for idx in np.ndindex(*view.shape[:-1]):
                view[idx] = cdf97_lift_1d(list(view[idx]), backward)
    return a


# --- the bounded codec's interpolation path (formats/lossy-1.md steps 14-17) ---


def interp_walk(g, step, kind, adaptive=False):
    """``(rec, bins, contexts)`` of steps 14-17 on ``g`` (already in the walk's axis
    order), one voxel at a time, straight from the spec; with ``adaptive``, also the
    adaptive coding's contexts ``4 c + t`` (step 17, bit 4 of the kind)."""
    import math

    import numpy as np

    m = g.shape
    rec = np.zeros(m)
    bins = np.zeros(m, dtype=np.int64)
    out_b, out_c, out_a = [], [], []

    def activity_class(a):
        if a < 4:
            return a
        n = a.bit_length()
        return min(47, 2 * n - 2 + ((a >> (n - 2)) & 1))

    def code(i, p, neighbours, prev, back=(), u=()):
        # back: the voxels whose |b| and b make nb and sg (kinds 0, 1); u: kinds 2, 3
        na = sum(abs(int(bins[j])) for j in neighbours)
        if kind >= 2:
            nb = sum(abs(int(bins[j])) for j in u)
            sg = sum(int(bins[j]) for j in neighbours)
        else:
            nb = sum(abs(int(bins[j])) for j in back)
            sg = sum(int(bins[j]) for j in back)
        g_ = 0 if 2 * nb < na else (1 if nb < 2 * na else 2)
        t_ = 0 if sg < 0 else (1 if sg == 0 else 2)
        out_a.append(4 * min(3 * activity_class(na + nb) + g_, 143) + t_)
        d = math.floor((g[i] - p) / step + 0.5)
        b = d if abs(d) < 2**30 else 0
        rec[i] = p + b * step
        bins[i] = b
        t = sum(min(abs(int(bins[j])), 127) for j in neighbours)
        out_b.append(b)
        out_c.append(3 * min(t.bit_length(), 5) + prev)
        return min(abs(b), 2)

    def result():
        out = (rec, np.array(out_b), np.array(out_c))
        return out + (np.array(out_a),) if adaptive else out

    if kind >= 2:
        for i0, i1 in np.ndindex(m[0], m[1]):
            prev = 0
            for i2 in range(m[2]):
                terms = [(0, 0, 1, 1), (0, 1, 0, 1), (0, 1, 1, -1)]
                if kind == 2:
                    terms += [(1, 0, 0, 1), (1, 0, 1, -1), (1, 1, 0, -1), (1, 1, 1, 1)]
                p = 0.0
                for d0, d1, d2, sign in terms:
                    j = (i0 - d0, i1 - d1, i2 - d2)
                    if min(j) >= 0:
                        p = p + rec[j] if sign > 0 else p - rec[j]
                nb = [j for j in ((i0, i1, i2 - 1), (i0, i1 - 1, i2)) if min(j) >= 0]
                u = [(i0 - 1, i1, i2)] if kind == 2 and i0 > 0 else []
                prev = code((i0, i1, i2), p, nb, prev, u=u)
        return result()
    top = 0
    while 2**top < max(m):
        top += 1
    code((0, 0, 0), 0.0, [], 0)
    for lv in range(top - 1, -1, -1):
        s = 2**lv
        for axis in range(3):
            for i in np.ndindex(*m):
                on = [
                    i[a] % (2 * s) == (s if a == axis else 0) if a >= axis else i[a] % s == 0
                    for a in range(3)
                ]
                if not all(on):
                    continue

                def at(k, i=i, axis=axis, s=s):
                    j = list(i)
                    j[axis] += k * s
                    return tuple(j)

                n, k = m[axis], i[axis]
                b, c = rec[at(-1)], None
                if k + s < n:
                    c = rec[at(1)]
                lo, hi = k - 3 * s >= 0, k + 3 * s < n
                if c is None:
                    p = b
                elif kind == 0 or not (lo or hi):
                    p = (b + c) * 0.5
                elif lo and hi:
                    p = (9.0 * (b + c) - (rec[at(-3)] + rec[at(3)])) * 0.0625
                elif hi:
                    p = (3.0 * b + 6.0 * c - rec[at(3)]) * 0.125
                else:
                    p = (6.0 * b + 3.0 * c - rec[at(-3)]) * 0.125
                nb = [at(-1)] + ([at(1)] if c is not None else [])
                # the context's second part: the same pass's voxel one row back (axis 1)
                sy, y0 = (2 * s if axis <= 1 else s), (s if axis == 1 else 0)
                back = (i[0], i[1] - sy, i[2])
                prev = min(abs(int(bins[back])), 2) if i[1] - sy >= y0 else 0
                # the adaptive coding's: one step back along the two other axes
                behind = []
                for a in range(3):
                    if a != axis:
                        j = list(i)
                        j[a] -= s if a < axis else 2 * s
                        if j[a] >= 0:
                            behind.append(tuple(j))
                code(i, p, nb, prev, back=behind)
    return result()


# --- render: quantised normals ---


def _central_differences(vol, z, y, x):
    """``vol`` one voxel up less one voxel down along z, y and x (indices clamped at the
    edges), as floats."""
    pos = (z, y, x)
    out = []
    for ax in range(3):
        up, dn = list(pos), list(pos)
        up[ax] = min(pos[ax] + 1, vol.shape[ax] - 1)
        dn[ax] = max(pos[ax] - 1, 0)
        out.append(float(vol[tuple(up)]) - float(vol[tuple(dn)]))
    return out


def render_unit_gradient(vol, spacing, z, y, x):
    """Unit world gradient (z, y, x) of voxel (z, y, x) by central differences (one voxel
    either way, the index clamped at the edges, divided by twice the spacing), folded
    onto n_z >= 0; None where it vanishes."""
    import math

    g = [d / (2.0 * sp) for d, sp in zip(_central_differences(vol, z, y, x), spacing)]
    n = math.sqrt(sum(c * c for c in g))
    if n == 0.0:
        return None
    s = -1.0 if g[0] < 0 else 1.0
    return tuple(s * c / n for c in g)


def render_normal_code(vol, spacing, z, y, x, levels=255):
    """The quantised normal code of voxel (z, y, x) (volpack.render.normals), in Python
    floats (IEEE doubles, one rounding an operation, as the kernel's): central
    differences scaled by ``0.5 / spacing``, 0 when their absolute sum is 0 or not
    finite, else folded onto n_z >= 0, mapped onto the octahedron's square and each of
    its two axes rounded half up to one of ``levels`` steps."""
    import math

    diff = _central_differences(vol, z, y, x)
    gz, gy, gx = (d * (0.5 / float(sp)) for d, sp in zip(diff, spacing))
    s = abs(gz) + abs(gy) + abs(gx)
    if not (0.0 < s < math.inf):
        return 0
    if gz < 0.0:
        gy, gx = -gy, -gx
    px, py = gx / s, gy / s
    half = 0.5 * (levels - 1)
    qu = math.floor((px + py + 1.0) * half + 0.5)
    qv = math.floor((px - py + 1.0) * half + 0.5)
    return 1 + qu * levels + qv


# --- lossless float prediction (volume_codec.floatpredict) ---


def float_signed_image(a):
    """The signed ordered image of each float, from its bits one by one: the bits as a
    signed integer, with every bit but the sign flipped when the sign is set."""
    import numpy as np

    b = 8 * a.dtype.itemsize
    out = []
    for u in a.reshape(-1).view(f"u{a.dtype.itemsize}").tolist():
        if u >> (b - 1):  # negative: -0.0 is -1, larger magnitudes further down
            out.append(-1 - (u - (1 << (b - 1))))
        else:
            out.append(u)
    return np.array(out, dtype=np.int64).reshape(a.shape)


def float_lorenzo_residuals(a, in_slice=False, in_floats=False):
    """Residuals of the Lorenzo predictor, voxel by voxel: the corners W, N, U, NW, UW,
    UN, UNW that exist (U and its corners left out ``in_slice``), signed by how many
    steps back they are, summed in that order, wrapped to the float's width. On the
    signed images; ``in_floats``: on the values in float64, the sum rounded to the
    float and then mapped (a NaN sum falls back to the integer sum)."""
    import numpy as np

    s = float_signed_image(a).tolist()
    v = a.astype(np.float64).tolist()
    b = 8 * a.dtype.itemsize
    nz, ny, nx = a.shape
    corners = [(0, 0, 1), (0, 1, 0), (1, 0, 0), (0, 1, 1), (1, 0, 1), (1, 1, 0), (1, 1, 1)]
    out = np.zeros(a.shape, dtype=np.int64)
    for z in range(nz):
        for y in range(ny):
            for x in range(nx):
                p, q = 0, 0.0
                for dz, dy, dx in corners:
                    if (dz and (in_slice or z == 0)) or (dy and y == 0) or (dx and x == 0):
                        continue
                    sign = 1 if (dz + dy + dx) % 2 else -1
                    p += sign * s[z - dz][y - dy][x - dx]
                    q = q + sign * v[z - dz][y - dy][x - dx]
                if in_floats and q == q:
                    with np.errstate(over="ignore"):
                        p = int(float_signed_image(np.array([q]).astype(a.dtype))[0])
                r = (s[z][y][x] - p + (1 << (b - 1))) % (1 << b) - (1 << (b - 1))
                out[z, y, x] = r
    return out


def float_blend_residuals(a, nset=127, offsets=(), fill=None):
    """The blend tool (lossless-1.md step 10, tool 2) voxel by voxel: ``(residual,
    copy mark, fill mark)`` arrays. Faces take the 3-D Lorenzo prediction on the values
    (``last`` beside a fill voxel); inside, the seven predictions weighted by the inverse
    of 1 + their errors at W, N, NW, U (and NE), predictors reading a fill voxel or not
    finite left out, none left: ``last``. Copies: the first offset whose voxel has the
    same bits."""
    import numpy as np

    b = 8 * a.dtype.itemsize
    nz, ny, nx = a.shape
    s = float_signed_image(a)
    v = a.astype(np.float64)
    fs = None if fill is None else int(float_signed_image(np.array([fill], a.dtype))[0])

    def image(q):
        with np.errstate(over="ignore"):
            return int(float_signed_image(np.array([q]).astype(a.dtype))[0])

    def wrap(x):
        return (x + (1 << (b - 1))) % (1 << b) - (1 << (b - 1))

    corners = [(0, 0, 1), (0, 1, 0), (1, 0, 0), (0, 1, 1), (1, 0, 1), (1, 1, 0), (1, 1, 1)]

    def face(z, y, x):  # the Lorenzo tool's P 2: on the values, a NaN sum on the images
        p, q = 0, 0.0
        for dz, dy, dx in corners:
            if (dz and z == 0) or (dy and y == 0) or (dx and x == 0):
                continue
            sign = 1 if (dz + dy + dx) % 2 else -1
            p += sign * int(s[z - dz, y - dy, x - dx])
            with np.errstate(invalid="ignore", over="ignore"):
                q = q + sign * v[z - dz, y - dy, x - dx]
        return image(q) if q == q else p

    fl = np.zeros(a.shape, bool)
    cp = np.zeros(a.shape, np.int64)
    res = np.zeros(a.shape, np.int64)
    err = {}
    keys = [k for k in range(7) if nset >> k & 1]
    uses = [
        [(0, 0, 1), (0, 1, 0), (1, 0, 0), (0, 1, 1), (1, 0, 1), (1, 1, 0), (1, 1, 1)],
        [(0, 0, 1), (0, 1, 0), (0, 1, 1)],
        [(1, 0, 0), (0, 0, 1), (1, 0, 1)],
        [(1, 0, 0), (0, 1, 0), (1, 1, 0)],
        [(0, 0, 1)],
        [(0, 1, 0)],
        [(1, 0, 0)],
    ]
    last = 0
    for z in range(nz):
        for y in range(ny):
            for x in range(nx):
                if fs is not None and int(s[z, y, x]) == fs:
                    fl[z, y, x] = True
                    err[(z, y, x)] = {k: 0 for k in keys}
                    continue
                if x == 0 or y == 0 or z == 0:
                    p = face(z, y, x)
                    near = [(z, y, x - 1), (z, y - 1, x), (z - 1, y, x)]
                    if fs is not None and any(min(c) >= 0 and fl[c] for c in near):
                        p = last
                    pk = {k: p for k in keys}
                else:

                    def at(dz, dy, dx, z=z, y=y, x=x):
                        return v[z - dz, y - dy, x - dx]

                    W, N, U = at(0, 0, 1), at(0, 1, 0), at(1, 0, 0)
                    NW, UW, UN, UNW = at(0, 1, 1), at(1, 0, 1), at(1, 1, 0), at(1, 1, 1)
                    with np.errstate(invalid="ignore", over="ignore"):
                        P = [
                            W + N + U - NW - UW - UN + UNW,
                            W + N - NW,
                            U + W - UW,
                            U + N - UN,
                            W,
                            N,
                            U,
                        ]
                    num = den = 0.0
                    pk = {}
                    for k in keys:
                        pk[k] = last
                        if fs is not None and any(
                            fl[z - dz, y - dy, x - dx] for dz, dy, dx in uses[k]
                        ):
                            continue
                        if not np.isfinite(P[k]):
                            continue
                        pk[k] = image(P[k])
                        e = 1.0
                        for c in [(z, y, x - 1), (z, y - 1, x), (z, y - 1, x - 1), (z - 1, y, x)]:
                            e += err[c][k]
                        if x + 1 < nx:
                            e += err[(z, y - 1, x + 1)][k]
                        num += (1.0 / e) * P[k]
                        den += 1.0 / e
                    q = num / den if den > 0 else float("nan")
                    p = image(q) if np.isfinite(q) else last
                err[(z, y, x)] = {k: min(abs(wrap(int(s[z, y, x]) - pk[k])), 1 << 30) for k in keys}
                for j, (dz, dy, dx) in enumerate(offsets):
                    if z >= dz and y >= dy and x >= dx and s[z - dz, y - dy, x - dx] == s[z, y, x]:
                        cp[z, y, x] = j + 1
                        break
                if not cp[z, y, x]:
                    res[z, y, x] = wrap(int(s[z, y, x]) - p)
                last = int(s[z, y, x])
    return res, cp, fl


# --- the local fit of the predictive stream (volume_codec/localfit.py) ---


def localfit_estimates(v, offsets, r=4, ru=3, min_samples=40, ridge=1e-3):
    """Every voxel's local-fit estimate in eighths (None where there is none), each
    window's training voxels listed afresh and its system solved by numpy; a voxel at
    odd ``x`` takes the weights of the voxel before it (fitted at even ``x``)."""
    import numpy as np

    nz, ny, nx = v.shape
    v = v.astype(np.float64)
    out = np.full(v.shape, None, dtype=object)

    def vector(z, y, x):
        return [v[z - dz, y - dy, x - dx] for dz, dy, dx in offsets] + [1.0]

    def weights(z, y, x):
        xs, ts = [], []
        for yy in range(max(2, y - r), y + 1):  # the rows above, then the row's left part
            for xx in range(max(2, x - r), min(nx - 2, x + r) + 1):
                if yy == y and xx >= x:
                    break
                xs.append(vector(z, yy, xx))
                ts.append(v[z, yy, xx])
        if z >= 3:
            for yy in range(max(2, y - ru), min(ny - 2, y + ru) + 1):
                for xx in range(max(2, x - ru), min(nx - 2, x + ru) + 1):
                    xs.append(vector(z - 1, yy, xx))
                    ts.append(v[z - 1, yy, xx])
        if len(ts) < min_samples or len(set(ts)) == 1:
            return None
        a, t = np.array(xs), np.array(ts)
        m = a.T @ a
        m += np.eye(len(m)) * (ridge * np.trace(m) / len(m) + 1e-9)
        return np.linalg.solve(m, a.T @ t)

    for z in range(2, nz):
        for y in range(2, ny - 1):
            w = None
            for x in range(2, nx - 1):
                if x % 2 == 0:
                    w = weights(z, y, x)
                if w is not None:
                    out[z, y, x] = int(np.floor(8 * (np.array(vector(z, y, x)) @ w) + 0.5))
    return out


# --- the fitted predictor of the predictive stream (volume_codec/predictfit.py) ---


def predict_fit_weights(v, offsets, mask=None, ncls=4, cf_bits=12, cf_limit=(1 << 15) - 1):
    """The fitted predictor's weights as the format's encoder defines them, by the book:
    the rows (neighbours at ``offsets``, target) of ``v[2:, 2:-1, 2:-1]`` not masked and
    not equal to all their neighbours, stacked whole; the gradient |W-NW|+|N-NW|+|N-NE|+
    |U-UN|+|U-UW| split at its quartiles; per class (and over all rows) least squares by
    the normal equations, rounded to 2^-cf_bits. Returns (per-class weights, thresholds,
    all-row weights)."""
    import numpy as np

    nz, ny, nx = v.shape
    f = v.astype(np.float64)
    target = f[2:, 2:-1, 2:-1]
    cols = [f[2 - a : nz - a, 2 - b : ny - 1 - b, 2 - c : nx - 1 - c] for a, b, c in offsets]
    keep = ~np.logical_and.reduce([c == target for c in cols])
    if mask is not None:
        keep &= ~np.asarray(mask, bool)[2:, 2:-1, 2:-1]
    x = np.stack([c[keep] for c in cols], axis=1)
    y = target[keep]
    W, N, U, NW, NE, UW, UN = (x[:, k] for k in range(7))
    g = np.abs(W - NW) + np.abs(N - NW) + np.abs(N - NE) + np.abs(U - UN) + np.abs(U - UW)
    th = np.quantile(g, np.arange(1, ncls) / ncls)
    cls = (g[:, None] > th[None, :]).sum(axis=1)

    def solve(xs, ys):
        w = np.linalg.solve(xs.T @ xs, xs.T @ ys)
        return np.clip(np.round(w * (1 << cf_bits)), -cf_limit, cf_limit).astype(np.int64)

    every = solve(x, y)
    per = [
        solve(x[cls == k], y[cls == k]) if (cls == k).sum() >= 4 * len(offsets) else every
        for k in range(ncls)
    ]
    return np.concatenate(per), th, every


# --- lossless float fit (volume_codec.floatfit) ---


def float_fit_residuals(a, face, w, box=None):
    """Residuals of mode 5's tool 3, voxel by voxel as ``formats/lossless-1.md`` step 10
    words it: the box fit ``box = ((rz, ry, rx), weights)`` where its whole box exists,
    else the 23 weights ``w`` where their neighbours exist, else (and where a sum is not
    finite) Lorenzo predictor ``face``; the sums on the values in float64, in four
    chains (product k into chain k mod 4, W's product added last)."""
    import numpy as np

    fit23 = [
        (0, 1, 0), (1, 0, 0), (0, 1, 1), (0, 1, -1), (1, 0, 1), (1, 1, 0), (1, 1, 1),
        (0, 0, 2), (0, 2, 0), (2, 0, 0), (1, 0, -1), (1, -1, 0), (1, 1, -1), (1, -1, 1),
        (1, -1, -1), (0, 1, 2), (0, 2, 1), (0, 2, -1), (2, 1, 0), (2, 0, 1), (1, 2, 0),
        (1, 0, 2), (0, 0, 1),
    ]  # fmt: skip
    lor = float_lorenzo_residuals(a, in_slice=face % 2 == 1, in_floats=face >= 2)
    s = float_signed_image(a)
    v = a.astype(np.float64)
    b = 8 * a.dtype.itemsize
    nz, ny, nx = a.shape

    def chains(z, y, x, offsets, weights, extra):
        acc = [0.0, 0.0, 0.0, 0.0]
        for k, (dz, dy, dx) in enumerate(offsets[:-1]):
            acc[k % 4 if k < extra else k - extra] += float(weights[k]) * v[z - dz, y - dy, x - dx]
        return ((acc[0] + acc[1]) + (acc[2] + acc[3])) + float(weights[-1]) * v[z, y, x - 1]

    if box is not None:
        (rz, ry, rx), wb = box
        offsets = float_box_offsets(rz, ry, rx)
        assert len(offsets) == len(wb)
    out = lor.copy()
    with np.errstate(all="ignore"):
        for z in range(nz):
            for y in range(ny):
                for x in range(nx):
                    q = None
                    if box is not None and z >= rz and ry <= y < ny - ry and rx <= x < nx - rx:
                        q = chains(z, y, x, offsets, wb, len(offsets))
                    if (q is None or not np.isfinite(q)) and w is not None:
                        if z >= 2 and 2 <= y < ny - 1 and 2 <= x < nx - 1:
                            q = chains(z, y, x, fit23, w, 20)
                    if q is None or not np.isfinite(q):
                        continue
                    p = int(float_signed_image(np.array([q]).astype(a.dtype))[0])
                    out[z, y, x] = (s[z, y, x] - p + (1 << (b - 1))) % (1 << b) - (1 << (b - 1))
    return out


def float_box_offsets(rz, ry, rx):
    """The box fit's neighbours as ``formats/lossless-1.md`` step 10 lists them: every
    causal (dz, dy, dx) within the box, farthest first (dz, then dy, then dx from the
    largest down), W = (0, 0, 1) moved to the end."""
    offsets = []
    for dz in reversed(range(rz + 1)):
        for dy in reversed(range(-ry, ry + 1)):
            for dx in reversed(range(-rx, rx + 1)):
                causal = dz > 0 or dy > 0 or (dy == 0 and dx > 0)
                if causal and (dz, dy, dx) != (0, 0, 1):
                    offsets.append((dz, dy, dx))
    return offsets + [(0, 0, 1)]


def float_box_weights(a, shape, max_rows=1 << 16, trim=16):
    """The box fit's weights by the row-matrix formula of session 21: per sampled slice
    (every k-th from ``rz``, about ``max_rows`` rows in all) a matrix stacked from the
    neighbours' windows, rows with a value that is not finite dropped; the normal
    equations (``x.T @ x``, ``x.T @ y``) summed, solved by ``lstsq``; then each slice's
    rows built again, those with a residual past ``trim`` medians taken out of the sums
    (``x[far].T @ x[far]``) and the equations solved again. The same numpy calls on the
    same numbers as the encoder, so the same float32 weights bit for bit."""
    import numpy as np

    rz, ry, rx = shape
    nz, ny, nx = a.shape
    offsets = float_box_offsets(rz, ry, rx)
    k = len(offsets)
    count = (nz - rz) * (ny - 2 * ry) * (nx - 2 * rx)
    if nz <= rz or ny <= 2 * ry or nx <= 2 * rx or count < 4 * k:
        return None
    with np.errstate(invalid="ignore"):
        v = a.astype(np.float64)
    ok = np.isfinite(v)
    top = np.abs(v[ok]).max() if ok.any() else 0.0
    if not top > 0:
        return None
    v = v / top

    def matrix(z):
        cols = [v[z - dz, ry - dy : ny - ry - dy, rx - dx : nx - rx - dx].reshape(-1)
                for dz, dy, dx in offsets]  # fmt: skip
        x = np.stack(cols, axis=1)
        y = v[z, ry : ny - ry, rx : nx - rx].reshape(-1)
        good = np.isfinite(x).all(axis=1) & np.isfinite(y)
        return x[good], y[good]

    def solve(m, b):
        with np.errstate(all="ignore"):
            try:
                sol = np.linalg.lstsq(m, b, rcond=None)[0].astype(np.float32)
            except np.linalg.LinAlgError:
                return None
        return sol if np.isfinite(sol).all() else None

    slices = list(range(rz, nz, -(-count // max_rows)))
    m, b, n = np.zeros((k, k)), np.zeros(k), 0
    for z in slices:
        x, y = matrix(z)
        m += x.T @ x
        b += x.T @ y
        n += len(y)
    sol = solve(m, b) if n >= 4 * k else None
    if sol is None:
        return None
    w = sol.astype(np.float64)
    res = [np.abs(y - x @ w) for x, y in map(matrix, slices)]
    cut = trim * np.median(np.concatenate(res))
    for z, r in zip(slices, res):
        x, y = matrix(z)
        m -= x[r > cut].T @ x[r > cut]
        b -= x[r > cut].T @ y[r > cut]
        n -= int((r > cut).sum())
    return solve(m, b) if n >= 4 * k else None


# --- render: 8-bit output ---


def render_rgb8(rgba, background=(0.0, 0.0, 0.0)):
    """Pre-multiplied RGBA over ``background``, pixel by pixel in float32 as the writer
    composites it: NaN as 0, each channel clipped to [0, 1], scaled to 255, rounded half
    to even."""
    import math

    import numpy as np

    f32 = np.float32
    h, w = rgba.shape[:2]
    out = np.zeros((h, w, 3), np.uint8)
    for i in range(h):
        for j in range(w):
            a = f32(rgba[i, j, 3])
            a = f32(0.0) if math.isnan(a) else min(max(a, f32(0.0)), f32(1.0))
            for c in range(3):
                v = f32(rgba[i, j, c])
                v = f32(0.0) if math.isnan(v) else v
                v = f32(v + f32(f32(1.0) - a) * f32(background[c]))
                v = min(max(v, f32(0.0)), f32(1.0))
                out[i, j, c] = int(np.rint(f32(v * f32(255.0))))
    return out


def rans_read_tables(body, nctx, nsym, bits=12):
    """``formats/lossy-1.md``'s rANS tables read row by row in plain Python: the rows as
    lists and the bytes read, or the error's text (``"cut"``, ``"past"``, ``"sum"``)."""
    words = [body[i] | body[i + 1] << 8 for i in range(0, len(body) - 1, 2)]
    rows, pos = [], 0
    for _ in range(nctx):
        if pos >= len(words):
            return "cut"
        m = words[pos]
        if m > nsym or pos + 1 + m > len(words):
            return "past"
        rows.append(words[pos + 1 : pos + 1 + m] + [0] * (nsym - m))
        pos += 1 + m
    for row in rows:
        if sum(row) not in (0, 1 << bits) or max(row) == 1 << bits:
            return "sum"
    return rows, 2 * pos


def palette_unpack(data, limit):
    """A palette read value by value (lossless-1.md): ``K`` and the zig-zagged first
    value, then ``K - 1`` gaps less one, each unsigned LEB128. Returns (values, bytes
    used), or raises FormatError naming what is wrong, as ``palette.unpack`` must."""
    from volpack.errors import FormatError

    data = bytes(data)

    def leb(pos):  # 7-bit groups, low first, while the byte before has bit 7 set
        groups = []
        while not groups or data[pos - 1] >= 0x80:
            if len(groups) == 10:
                raise FormatError("corrupt palette: a number longer than 64 bits")
            if pos == len(data):
                raise FormatError("corrupt palette: the stream ends inside a number")
            groups.append(data[pos] % 128)
            pos += 1
        return sum(g * 128**i for i, g in enumerate(groups)), pos

    k, pos = leb(0)
    if not 1 <= k <= limit:
        raise FormatError(f"corrupt palette: expected 1..{limit} values, found {k}")
    z, pos = leb(pos)
    values = [(z >> 1) ^ -(z & 1)]
    if values[0] < -(1 << 63):
        raise FormatError("corrupt palette: a value leaves the 64-bit range")
    for _ in range(k - 1):
        g, pos = leb(pos)
        values.append(values[-1] + g + 1)
        if values[-1] >= 1 << 63:
            raise FormatError("corrupt palette: a value leaves the 64-bit range")
    if values[0] >= 1 << 63:
        raise FormatError("corrupt palette: a value leaves the 64-bit range")
    return values, pos


# --- bounded codec: the reconstruction of the quantised voxels ---


def bounded_reconstruct(q, lo, step, dtype):
    """lossy-1.md step 3, voxel by voxel in Python numbers: integers ``lo + q * step``
    exactly, clipped to the dtype; floats ``q * step`` then ``+ lo`` in double precision,
    clipped to the dtype's largest finite magnitude, then rounded to the dtype."""
    import numpy as np

    dtype = np.dtype(dtype)
    flat = np.asarray(q).reshape(-1).tolist()
    if dtype.kind in "iu":
        info = np.iinfo(dtype)
        vals = [min(max(int(lo) + int(v) * int(step), int(info.min)), int(info.max)) for v in flat]
    else:
        big = float(np.finfo(dtype).max)
        vals = [min(max(float(v) * float(step) + float(lo), -big), big) for v in flat]
    return (
        np.array(vals, dtype=np.float64 if dtype.kind == "f" else np.int64)
        .astype(dtype)
        .reshape(np.shape(q))
    )


# --- bounded codec: the normal equations of the long-reach fit (bounded_longfit) ---


def longfit_normal(q, offs, box, s):
    """(A^T A, A^T y, y^T y) of ``offs`` over ``box`` at stride ``s`` along y and x, as
    bounded_longfit summed them before session 35: slab by slab along z, each slab's A
    stacked from slices (one column a step) and its products by numpy's matmul."""
    import numpy as np

    (z0, z1), (y0, y1), (x0, x1) = box
    n = len(offs)
    ata = np.zeros((n, n))
    aty = np.zeros(n)
    yty = 0.0
    for z in range(z0, z1):
        a = np.stack(
            [
                q[z - dz, y0 - dy : y1 - dy : s, x0 - dx : x1 - dx : s].ravel()
                for dz, dy, dx in offs
            ],
            axis=1,
        ).astype(np.float64)
        t = q[z, y0:y1:s, x0:x1:s].ravel().astype(np.float64)
        ata += a.T @ a
        aty += a.T @ t
        yty += float(t @ t)
    return ata, aty, yty
