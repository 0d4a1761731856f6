"""Probe: where a semi-transparent unshaded pre-integrated frame's time goes (one thread).
Variants of raycast._march compiled from its source with one edit each, in this process,
taking turns with the unedited march; best CPU of N frames."""
import inspect, sys, time, textwrap, json, os
from volpack import _jit
import numpy as np
sys.path.insert(0, "scripts")
import bench_render_peers as peers, datasets
from volpack.render import raycast
from volpack.render.camera import Camera
from volpack.render.prepared import prepare_volume
from volpack.render.raycast import render
from volpack.render.transfer import TransferFunction

SRC = textwrap.dedent(inspect.getsource(raycast._march))
SPEC = textwrap.dedent(inspect.getsource(raycast._march_specialised))

from volpack._jit import kernel
from volpack.render.fixed import FRAC, WBITS, _WMASK
from volpack.render.raycast import fixed_sample, grid_sample

@kernel(inline=True)
def QS(quad, vol, k, lo, hi, bz, by, bx, sz, sy, sx):
    pz, py, px = bz + k * sz, by + k * sy, bx + k * sx
    if lo <= k <= hi:
        z0 = np.uint64(pz >> FRAC); fz = (pz >> (FRAC - WBITS)) & _WMASK
        y0 = np.uint64(py >> FRAC); fy = (py >> (FRAC - WBITS)) & _WMASK
        x0 = np.uint64(px >> FRAC); fx = (px >> (FRAC - WBITS)) & _WMASK
        q0 = np.int64(quad[z0, y0, x0]); q1 = np.int64(quad[z0 + np.uint64(1), y0, x0])
        c000 = q0 & 255
        c00 = (c000 << WBITS) + (((q0 >> 8) & 255) - c000) * fx
        c010 = (q0 >> 16) & 255
        c01 = (c010 << WBITS) + (((q0 >> 24) & 255) - c010) * fx
        c100 = q1 & 255
        c10 = (c100 << WBITS) + (((q1 >> 8) & 255) - c100) * fx
        c110 = (q1 >> 16) & 255
        c11 = (c110 << WBITS) + (((q1 >> 24) & 255) - c110) * fx
        c0 = c00 + (((c01 - c00) * fy) >> WBITS)
        c1 = c10 + (((c11 - c10) * fy) >> WBITS)
        return np.float64(c0 + (((c1 - c0) * fz) >> WBITS))
    return fixed_sample(vol, pz, py, px)

@kernel(inline=True)
def L1S(flat, vol, k, lo, hi, bz, by, bx, sz, sy, sx):
    pz, py, px = bz + k * sz, by + k * sy, bx + k * sx
    if lo <= k <= hi:
        nz, ny, nx = vol.shape
        z0 = np.int64(pz >> FRAC); fz = (pz >> (FRAC - WBITS)) & _WMASK
        y0 = np.int64(py >> FRAC); fy = (py >> (FRAC - WBITS)) & _WMASK
        x0 = np.int64(px >> FRAC); fx = (px >> (FRAC - WBITS)) & _WMASK
        sy_ = np.int64(nx); sz_ = np.int64(nx * ny)
        b = np.uint64((z0 * sz_ + y0 * sy_ + x0) & 8191) + np.uint64(nx * ny * (nz // 2))
        o1 = np.uint64(1); oy = np.uint64(sy_); oz = np.uint64(sz_)
        c000 = np.int64(flat[b])
        c00 = (c000 << WBITS) + (np.int64(flat[b + o1]) - c000) * fx
        c010 = np.int64(flat[b + oy])
        c01 = (c010 << WBITS) + (np.int64(flat[b + oy + o1]) - c010) * fx
        c100 = np.int64(flat[b + oz])
        c10 = (c100 << WBITS) + (np.int64(flat[b + oz + o1]) - c100) * fx
        c110 = np.int64(flat[b + oz + oy])
        c11 = (c110 << WBITS) + (np.int64(flat[b + oz + oy + o1]) - c110) * fx
        c0 = c00 + (((c01 - c00) * fy) >> WBITS)
        c1 = c10 + (((c11 - c10) * fy) >> WBITS)
        return np.float64(c0 + (((c1 - c0) * fz) >> WBITS))
    return fixed_sample(vol, pz, py, px)

@kernel(inline=True)
def FS(flat, vol, k, lo, hi, bz, by, bx, sz, sy, sx):
    pz, py, px = bz + k * sz, by + k * sy, bx + k * sx
    if lo <= k <= hi:
        nz, ny, nx = vol.shape
        z0 = np.int64(pz >> FRAC); fz = (pz >> (FRAC - WBITS)) & _WMASK
        y0 = np.int64(py >> FRAC); fy = (py >> (FRAC - WBITS)) & _WMASK
        x0 = np.int64(px >> FRAC); fx = (px >> (FRAC - WBITS)) & _WMASK
        sy_ = np.int64(nx); sz_ = np.int64(nx * ny)
        b = np.uint64(z0 * sz_ + y0 * sy_ + x0)
        o1 = np.uint64(1); oy = np.uint64(sy_); oz = np.uint64(sz_)
        c000 = np.int64(flat[b])
        c00 = (c000 << WBITS) + (np.int64(flat[b + o1]) - c000) * fx
        c010 = np.int64(flat[b + oy])
        c01 = (c010 << WBITS) + (np.int64(flat[b + oy + o1]) - c010) * fx
        c100 = np.int64(flat[b + oz])
        c10 = (c100 << WBITS) + (np.int64(flat[b + oz + o1]) - c100) * fx
        c110 = np.int64(flat[b + oz + oy])
        c11 = (c110 << WBITS) + (np.int64(flat[b + oz + oy + o1]) - c110) * fx
        c0 = c00 + (((c01 - c00) * fy) >> WBITS)
        c1 = c10 + (((c11 - c10) * fy) >> WBITS)
        return np.float64(c0 + (((c1 - c0) * fz) >> WBITS))
    return fixed_sample(vol, pz, py, px)

from numba.extending import intrinsic
from numba.core import types as ntypes, cgutils
from llvmlite import ir as llir

@intrinsic
def prefetch3(typingctx, arr, z, y, x):
    sig = ntypes.void(arr, z, y, x)
    def codegen(context, builder, sig, args):
        aryty = sig.args[0]
        ary = context.make_array(aryty)(context, builder, args[0])
        idx = [context.cast(builder, a, t, ntypes.intp) for a, t in zip(args[1:], sig.args[1:])]
        ptr = cgutils.get_item_pointer2(context, builder, data=ary.data, shape=cgutils.unpack_tuple(builder, ary.shape), strides=cgutils.unpack_tuple(builder, ary.strides), layout=aryty.layout, inds=idx, wraparound=False)
        i8p = llir.IntType(8).as_pointer()
        fnty = llir.FunctionType(llir.VoidType(), [i8p, llir.IntType(32), llir.IntType(32), llir.IntType(32)])
        fn = cgutils.get_or_insert_function(builder.module, fnty, "llvm.prefetch.p0i8")
        builder.call(fn, [builder.bitcast(ptr, i8p), llir.Constant(llir.IntType(32), 0), llir.Constant(llir.IntType(32), 3), llir.Constant(llir.IntType(32), 1)])
        return context.get_dummy_value()
    return sig, codegen

PD = int(os.environ.get("PD", "8"))
OFF = int(os.environ.get("OFF", "1"))

@kernel(inline=True)
def PF(vol, k, lo, hi, bz, by, bx, sz, sy, sx):
    kk = k + PD
    if lo <= kk <= hi:
        pz, py, px = bz + kk * sz, by + kk * sy, bx + kk * sx
        z0 = np.uint64(pz >> FRAC); y0 = np.uint64(py >> FRAC); x0 = np.uint64(px >> FRAC)
        one = np.uint64(1)
        prefetch3(vol, z0, y0, x0)
        prefetch3(vol, z0, y0 + one, x0)
        prefetch3(vol, z0 + one, y0, x0)
        prefetch3(vol, z0 + one, y0 + one, x0)
    return grid_sample(vol, k, lo, hi, bz, by, bx, sz, sy, sx)

from volpack.render.fixed import trilinear_inner
from volpack.render.raycast import _nearest, _complete

@kernel(nrt=False, contract=True)
def RUN(vol, pre2d, bz, by, bx, sz, sy, sx, i, end, tnear, tfar, step, ii, vs, v0, n_tab,
        cl, ch_, xf, nsub, a_ref, ert, ar, ag, ab, aa):
    while i < end:
        t0 = tnear + i * step
        t1 = min(t0 + step, tfar)
        if t1 - t0 < step:
            break
        k = i + 1
        xb = trilinear_inner(vol, bz + k * sz, by + k * sy, bx + k * sx) * vs + v0
        jj = _nearest(xb, n_tab)
        if not ((xf < cl and xb < cl) or (xf > ch_ and xb > ch_)):
            a = pre2d[ii, jj, 3]
            if a > 0.0:
                if nsub > 1 and (1.0 - aa) * a > a_ref:
                    break
                cr, cg, cb = pre2d[ii, jj, 0], pre2d[ii, jj, 1], pre2d[ii, jj, 2]
                wgt = 1.0 - aa
                ar, ag, ab, aa = ar + wgt * cr, ag + wgt * cg, ab + wgt * cb, aa + wgt * a
                if aa > ert:
                    ar, ag, ab, aa = _complete(ar, ag, ab, aa, cr, cg, cb, a)
                    return i + 1, jj, xb, ar, ag, ab, aa, True
        ii = jj
        xf = xb
        i += 1
    return i, ii, xf, ar, ag, ab, aa, False

@kernel(nrt=False, contract=True)
def RUN2(vol, pre2d, bz, by, bx, sz, sy, sx, i, end, tnear, tfar, step, ii, vs, v0, n_tab,
        cl, ch_, xf, nsub, a_ref, ert, ar, ag, ab, aa):
    ar2 = ag2 = ab2 = aa2 = 0.0
    ii2 = ii
    xmax = np.int64(vol.shape[2] - 2) << 24
    while i < end:
        t0 = tnear + i * step
        t1 = min(t0 + step, tfar)
        if t1 - t0 < step:
            break
        k = i + 1
        xb = trilinear_inner(vol, bz + k * sz, by + k * sy, bx + k * sx) * vs + v0
        xb2 = trilinear_inner(vol, bz + k * sz, by + k * sy, min(bx + k * sx + (OFF << 24), xmax)) * vs + v0
        jj2 = _nearest(xb2, n_tab)
        a2 = pre2d[ii2, jj2, 3]
        w2 = 1.0 - aa2
        ar2, ag2, ab2, aa2 = ar2 + w2 * pre2d[ii2, jj2, 0], ag2 + w2 * pre2d[ii2, jj2, 1], ab2 + w2 * pre2d[ii2, jj2, 2], aa2 + w2 * a2
        ii2 = jj2
        jj = _nearest(xb, n_tab)
        if not ((xf < cl and xb < cl) or (xf > ch_ and xb > ch_)):
            a = pre2d[ii, jj, 3]
            if a > 0.0:
                if nsub > 1 and (1.0 - aa) * a > a_ref:
                    break
                cr, cg, cb = pre2d[ii, jj, 0], pre2d[ii, jj, 1], pre2d[ii, jj, 2]
                wgt = 1.0 - aa
                ar, ag, ab, aa = ar + wgt * cr, ag + wgt * cg, ab + wgt * cb, aa + wgt * a
                if aa > ert:
                    ar, ag, ab, aa = _complete(ar, ag, ab, aa, cr, cg, cb, a)
                    return i + 1, jj, xb, ar + 1e-300 * (ar2 + ag2 + ab2 + aa2), ag, ab, aa, True
        ii = jj
        xf = xb
        i += 1
    return i, ii, xf, ar + 1e-300 * (ar2 + ag2 + ab2 + aa2), ag, ab, aa, False

@kernel(nrt=False, contract=True)
def RUNP(vol, pre2d, bz, by, bx, sz, sy, sx, i, end, tnear, tfar, step, ii, vs, v0, n_tab,
        cl, ch_, xf, nsub, a_ref, ert, ar, ag, ab, aa):
    k = i + 1
    xn = trilinear_inner(vol, bz + k * sz, by + k * sy, bx + k * sx) * vs + v0
    jn = _nearest(xn, n_tab)
    while i < end:
        t0 = tnear + i * step
        t1 = min(t0 + step, tfar)
        if t1 - t0 < step:
            break
        xb = xn
        jj = jn
        if i + 1 < end:  # the next segment's back sample, ahead of this one's branches
            k = i + 2
            xn = trilinear_inner(vol, bz + k * sz, by + k * sy, bx + k * sx) * vs + v0
            jn = _nearest(xn, n_tab)
        if not ((xf < cl and xb < cl) or (xf > ch_ and xb > ch_)):
            a = pre2d[ii, jj, 3]
            if a > 0.0:
                if nsub > 1 and (1.0 - aa) * a > a_ref:
                    break
                cr, cg, cb = pre2d[ii, jj, 0], pre2d[ii, jj, 1], pre2d[ii, jj, 2]
                wgt = 1.0 - aa
                ar, ag, ab, aa = ar + wgt * cr, ag + wgt * cg, ab + wgt * cb, aa + wgt * a
                if aa > ert:
                    ar, ag, ab, aa = _complete(ar, ag, ab, aa, cr, cg, cb, a)
                    return i + 1, jj, xb, ar, ag, ab, aa, True
        ii = jj
        xf = xb
        i += 1
    return i, ii, xf, ar, ag, ab, aa, False

@kernel(nrt=False, contract=True)
def RUNQ(vol, pre2d, bz, by, bx, sz, sy, sx, i, end, tnear, tfar, step, ii, vs, v0, n_tab,
        cl, ch_, xf, nsub, a_ref, ert, ar, ag, ab, aa):
    k = i + 1
    xn = trilinear_inner(vol, bz + k * sz, by + k * sy, bx + k * sx) * vs + v0
    jn = _nearest(xn, n_tab)
    an = pre2d[ii, jn, 3]
    while i < end:
        t0 = tnear + i * step
        t1 = min(t0 + step, tfar)
        if t1 - t0 < step:
            break
        xb = xn
        jj = jn
        a = an
        if i + 1 < end:  # the next segment's back sample, ahead of this one's branches
            k = i + 2
            xn = trilinear_inner(vol, bz + k * sz, by + k * sy, bx + k * sx) * vs + v0
            jn = _nearest(xn, n_tab)
            an = pre2d[jj, jn, 3]
        if a > 0.0:
            if nsub > 1 and (1.0 - aa) * a > a_ref:
                break
            cr, cg, cb = pre2d[ii, jj, 0], pre2d[ii, jj, 1], pre2d[ii, jj, 2]
            wgt = 1.0 - aa
            ar, ag, ab, aa = ar + wgt * cr, ag + wgt * cg, ab + wgt * cb, aa + wgt * a
            if aa > ert:
                ar, ag, ab, aa = _complete(ar, ag, ab, aa, cr, cg, cb, a)
                return i + 1, jj, xb, ar, ag, ab, aa, True
        ii = jj
        xf = xb
        i += 1
    return i, ii, xf, ar, ag, ab, aa, False

@kernel(nrt=False, contract=True)
def RUNR(vol, pre2d, bz, by, bx, sz, sy, sx, i, end, tnear, tfar, step, ii, vs, v0, n_tab,
        cl, ch_, xf, nsub, a_ref, ert, ar, ag, ab, aa):
    k = i + 1
    xn = trilinear_inner(vol, bz + k * sz, by + k * sy, bx + k * sx) * vs + v0
    jn = _nearest(xn, n_tab)
    k = i + 2
    xn2 = trilinear_inner(vol, bz + k * sz, by + k * sy, bx + k * sx) * vs + v0 if i + 1 < end else 0.0
    while i < end:
        t0 = tnear + i * step
        t1 = min(t0 + step, tfar)
        if t1 - t0 < step:
            break
        xb = xn
        jj = jn
        xn = xn2
        jn = _nearest(xn, n_tab)
        if i + 2 < end:
            k = i + 3
            xn2 = trilinear_inner(vol, bz + k * sz, by + k * sy, bx + k * sx) * vs + v0
        if not ((xf < cl and xb < cl) or (xf > ch_ and xb > ch_)):
            a = pre2d[ii, jj, 3]
            if a > 0.0:
                if nsub > 1 and (1.0 - aa) * a > a_ref:
                    break
                cr, cg, cb = pre2d[ii, jj, 0], pre2d[ii, jj, 1], pre2d[ii, jj, 2]
                wgt = 1.0 - aa
                ar, ag, ab, aa = ar + wgt * cr, ag + wgt * cg, ab + wgt * cb, aa + wgt * a
                if aa > ert:
                    ar, ag, ab, aa = _complete(ar, ag, ab, aa, cr, cg, cb, a)
                    return i + 1, jj, xb, ar, ag, ab, aa, True
        ii = jj
        xf = xb
        i += 1
    return i, ii, xf, ar, ag, ab, aa, False

RUNPI = kernel(RUNP.py_func, inline=True)

@kernel(inline=True)
def NEAR2(p, n):
    return np.uint64(min(max(np.int64(p + 0.5), np.int64(0)), np.int64(n - 1)))

def variant(edits, rb=None):
    src = SRC
    for a, b in edits:
        assert a in src, a
        src = src.replace(a, b)
    _jit.CACHE = False; _jit._KERNEL_CACHE = None
    ns = dict(vars(raycast)); ns.update(RUNPI=RUNPI, RUNQ=RUNQ, RUNR=RUNR, RUNP=RUNP, RUN2=RUN2, RUN=RUN, PF=PF, QS=QS, FS=FS, L1S=L1S, CODES0=np.zeros((1,1,1,1), np.uint16))
    exec(compile(src, "<var>", "exec"), ns)
    ns["_march_inline"] = raycast.kernel(ns["_march"], inline=True)
    if rb:
        ns["ROW_BAND"] = rb
    exec(compile(SPEC, "<spec>", "exec"), ns)
    return ns["_march_specialised"](True, 0)

VARS = {
    "base": [],
    "noread": [("xb = grid_sample(vol, i + 1, klo, khi, bz, by, bx, sz, sy, sx) * vs + v0",
                "xb = xf + 0.0")],
    "nolookup": [("a = pre2d[ii, jj, 3]", "a = 0.004")],
    "quad": [("xb = grid_sample(vol, i + 1, klo, khi, bz, by, bx, sz, sy, sx) * vs + v0",
              "xb = QS(codes, vol, i + 1, klo, khi, bz, by, bx, sz, sy, sx) * vs + v0"), ("codes, light, sub2d, bz + i * sz", "CODES0, light, sub2d, bz + i * sz")],
    "flat": [("xb = grid_sample(vol, i + 1, klo, khi, bz, by, bx, sz, sy, sx) * vs + v0",
              "xb = FS(codes, vol, i + 1, klo, khi, bz, by, bx, sz, sy, sx) * vs + v0"), ("codes, light, sub2d, bz + i * sz", "CODES0, light, sub2d, bz + i * sz")],
    "l1": [("xb = grid_sample(vol, i + 1, klo, khi, bz, by, bx, sz, sy, sx) * vs + v0",
              "xb = L1S(codes, vol, i + 1, klo, khi, bz, by, bx, sz, sy, sx) * vs + v0"), ("codes, light, sub2d, bz + i * sz", "CODES0, light, sub2d, bz + i * sz")],
    "pf": [("xb = grid_sample(vol, i + 1, klo, khi, bz, by, bx, sz, sy, sx) * vs + v0",
              "xb = PF(vol, i + 1, klo, khi, bz, by, bx, sz, sy, sx) * vs + v0")],
    "nobranch": [("""                        jj = _nearest(xb, n_tab)
                        if not ((xf < cl and xb < cl) or (xf > ch_ and xb > ch_)):
                            a = pre2d[ii, jj, 3]""", """                        jj = _nearest(xb, n_tab)
                        a = pre2d[ii, jj, 3]"""),
        ("elif a > 0.0:  # colour only", "elif (pre and near) or a > 0.0:  # colour only"),
        ("                    if seglen < step:  # last, shorter segment", "                    if seglen < step and a > 0.0:  # last, shorter segment")],
    "run": [("""                    if state == 1:
                        have_front = False
""", """                    if state == 1:
                        have_front = False
                if pre and shade == 0 and near and have_front and i + 1 >= klo:
                    e = min(nseg - 1, khi)
                    if skip:
                        e = min(e, next_k)
                    if e > i:
                        i2, ii, xf, ar, ag, ab, aa, done = RUN(
                            vol, pre2d, bz, by, bx, sz, sy, sx, i, e, tnear, tfar, step, ii, vs,
                            v0, n_tab, cl, ch_, xf, nsub, a_ref, ert, ar, ag, ab, aa)
                        count += i2 - i
                        i = i2
                        if done:
                            break
                        if skip and i >= next_k:
                            continue
""")],
    "runp": [("""                    if state == 1:
                        have_front = False
""", """                    if state == 1:
                        have_front = False
                if pre and shade == 0 and near and have_front and i + 1 >= klo:
                    e = min(nseg - 1, khi)
                    if skip:
                        e = min(e, next_k)
                    if e > i:
                        i2, ii, xf, ar, ag, ab, aa, done = RUNP(
                            vol, pre2d, bz, by, bx, sz, sy, sx, i, e, tnear, tfar, step, ii, vs,
                            v0, n_tab, cl, ch_, xf, nsub, a_ref, ert, ar, ag, ab, aa)
                        count += i2 - i
                        i = i2
                        if done:
                            break
                        if skip and i >= next_k:
                            continue
""")],
    "runpcount": [("                count += 1\n", ""), ("""                    if state == 1:
                        have_front = False
""", """                    if state == 1:
                        have_front = False
                if pre and shade == 0 and near and have_front and i + 1 >= klo:
                    e = min(nseg - 1, khi)
                    if skip:
                        e = min(e, next_k)
                    if e > i:
                        i2, ii, xf, ar, ag, ab, aa, done = RUNP(
                            vol, pre2d, bz, by, bx, sz, sy, sx, i, e, tnear, tfar, step, ii, vs,
                            v0, n_tab, cl, ch_, xf, nsub, a_ref, ert, ar, ag, ab, aa)
                        count += i2 - i
                        i = i2
                        if done:
                            break
                        if skip and i >= next_k:
                            continue
""")],
    "runpi": [("""                    if state == 1:
                        have_front = False
""", """                    if state == 1:
                        have_front = False
                if pre and shade == 0 and near and have_front and i + 1 >= klo:
                    e = min(nseg - 1, khi)
                    if skip:
                        e = min(e, next_k)
                    if e > i:
                        i2, ii, xf, ar, ag, ab, aa, done = RUNPI(
                            vol, pre2d, bz, by, bx, sz, sy, sx, i, e, tnear, tfar, step, ii, vs,
                            v0, n_tab, cl, ch_, xf, nsub, a_ref, ert, ar, ag, ab, aa)
                        count += i2 - i
                        i = i2
                        if done:
                            break
                        if skip and i >= next_k:
                            continue
""")],
    "runpcount": [("                count += 1\n", ""), ("""                    if state == 1:
                        have_front = False
""", """                    if state == 1:
                        have_front = False
                if pre and shade == 0 and near and have_front and i + 1 >= klo:
                    e = min(nseg - 1, khi)
                    if skip:
                        e = min(e, next_k)
                    if e > i:
                        i2, ii, xf, ar, ag, ab, aa, done = RUNPI(
                            vol, pre2d, bz, by, bx, sz, sy, sx, i, e, tnear, tfar, step, ii, vs,
                            v0, n_tab, cl, ch_, xf, nsub, a_ref, ert, ar, ag, ab, aa)
                        count += i2 - i
                        i = i2
                        if done:
                            break
                        if skip and i >= next_k:
                            continue
""")],
    "runp2leap": [("""                    state, i, next_k = _leap_fixed(
                        i, nseg, lz + i * sz, ly + i * sy, lx + i * sx, sz, sy, sx, iz, iy, ix,
                        nz, ny, nx, leap, brick, sh,
                    )  # fmt: skip
""", """                    state2, i2x, nk2 = _leap_fixed(
                        i + 1, nseg, lz + (i + 1) * sz, ly + (i + 1) * sy, lx + (i + 1) * sx, sz, sy, sx, iz, iy, ix,
                        nz, ny, nx, leap, brick, sh,
                    )
                    state, i, next_k = _leap_fixed(
                        i, nseg, lz + i * sz, ly + i * sy, lx + i * sx, sz, sy, sx, iz, iy, ix,
                        nz, ny, nx, leap, brick, sh,
                    )  # fmt: skip
                    if state2 + i2x + nk2 == -12345:
                        i -= 1
"""), ("""                    if state == 1:
                        have_front = False
""", """                    if state == 1:
                        have_front = False
                if pre and shade == 0 and near and have_front and i + 1 >= klo:
                    e = min(nseg - 1, khi)
                    if skip:
                        e = min(e, next_k)
                    if e > i:
                        i2, ii, xf, ar, ag, ab, aa, done = RUNP(
                            vol, pre2d, bz, by, bx, sz, sy, sx, i, e, tnear, tfar, step, ii, vs,
                            v0, n_tab, cl, ch_, xf, nsub, a_ref, ert, ar, ag, ab, aa)
                        count += i2 - i
                        i = i2
                        if done:
                            break
                        if skip and i >= next_k:
                            continue
""")],
    "runpcount": [("                count += 1\n", ""), ("""                    if state == 1:
                        have_front = False
""", """                    if state == 1:
                        have_front = False
                if pre and shade == 0 and near and have_front and i + 1 >= klo:
                    e = min(nseg - 1, khi)
                    if skip:
                        e = min(e, next_k)
                    if e > i:
                        i2, ii, xf, ar, ag, ab, aa, done = RUNP(
                            vol, pre2d, bz, by, bx, sz, sy, sx, i, e, tnear, tfar, step, ii, vs,
                            v0, n_tab, cl, ch_, xf, nsub, a_ref, ert, ar, ag, ab, aa)
                        count += i2 - i
                        i = i2
                        if done:
                            break
                        if skip and i >= next_k:
                            continue
""")],
    "runpi": [("""                    if state == 1:
                        have_front = False
""", """                    if state == 1:
                        have_front = False
                if pre and shade == 0 and near and have_front and i + 1 >= klo:
                    e = min(nseg - 1, khi)
                    if skip:
                        e = min(e, next_k)
                    if e > i:
                        i2, ii, xf, ar, ag, ab, aa, done = RUNPI(
                            vol, pre2d, bz, by, bx, sz, sy, sx, i, e, tnear, tfar, step, ii, vs,
                            v0, n_tab, cl, ch_, xf, nsub, a_ref, ert, ar, ag, ab, aa)
                        count += i2 - i
                        i = i2
                        if done:
                            break
                        if skip and i >= next_k:
                            continue
""")],
    "runpcount": [("                count += 1\n", ""), ("""                    if state == 1:
                        have_front = False
""", """                    if state == 1:
                        have_front = False
                if pre and shade == 0 and near and have_front and i + 1 >= klo:
                    e = min(nseg - 1, khi)
                    if skip:
                        e = min(e, next_k)
                    if e > i:
                        i2, ii, xf, ar, ag, ab, aa, done = RUNPI(
                            vol, pre2d, bz, by, bx, sz, sy, sx, i, e, tnear, tfar, step, ii, vs,
                            v0, n_tab, cl, ch_, xf, nsub, a_ref, ert, ar, ag, ab, aa)
                        count += i2 - i
                        i = i2
                        if done:
                            break
                        if skip and i >= next_k:
                            continue
""")],
    "runq": [("""                    if state == 1:
                        have_front = False
""", """                    if state == 1:
                        have_front = False
                if pre and shade == 0 and near and have_front and i + 1 >= klo:
                    e = min(nseg - 1, khi)
                    if skip:
                        e = min(e, next_k)
                    if e > i:
                        i2, ii, xf, ar, ag, ab, aa, done = RUNQ(
                            vol, pre2d, bz, by, bx, sz, sy, sx, i, e, tnear, tfar, step, ii, vs,
                            v0, n_tab, cl, ch_, xf, nsub, a_ref, ert, ar, ag, ab, aa)
                        count += i2 - i
                        i = i2
                        if done:
                            break
                        if skip and i >= next_k:
                            continue
""")],
    "runp": [("""                    if state == 1:
                        have_front = False
""", """                    if state == 1:
                        have_front = False
                if pre and shade == 0 and near and have_front and i + 1 >= klo:
                    e = min(nseg - 1, khi)
                    if skip:
                        e = min(e, next_k)
                    if e > i:
                        i2, ii, xf, ar, ag, ab, aa, done = RUNP(
                            vol, pre2d, bz, by, bx, sz, sy, sx, i, e, tnear, tfar, step, ii, vs,
                            v0, n_tab, cl, ch_, xf, nsub, a_ref, ert, ar, ag, ab, aa)
                        count += i2 - i
                        i = i2
                        if done:
                            break
                        if skip and i >= next_k:
                            continue
""")],
    "runr": [("""                    if state == 1:
                        have_front = False
""", """                    if state == 1:
                        have_front = False
                if pre and shade == 0 and near and have_front and i + 1 >= klo:
                    e = min(nseg - 1, khi)
                    if skip:
                        e = min(e, next_k)
                    if e > i:
                        i2, ii, xf, ar, ag, ab, aa, done = RUNR(
                            vol, pre2d, bz, by, bx, sz, sy, sx, i, e, tnear, tfar, step, ii, vs,
                            v0, n_tab, cl, ch_, xf, nsub, a_ref, ert, ar, ag, ab, aa)
                        count += i2 - i
                        i = i2
                        if done:
                            break
                        if skip and i >= next_k:
                            continue
""")],
    "runp": [("""                    if state == 1:
                        have_front = False
""", """                    if state == 1:
                        have_front = False
                if pre and shade == 0 and near and have_front and i + 1 >= klo:
                    e = min(nseg - 1, khi)
                    if skip:
                        e = min(e, next_k)
                    if e > i:
                        i2, ii, xf, ar, ag, ab, aa, done = RUNP(
                            vol, pre2d, bz, by, bx, sz, sy, sx, i, e, tnear, tfar, step, ii, vs,
                            v0, n_tab, cl, ch_, xf, nsub, a_ref, ert, ar, ag, ab, aa)
                        count += i2 - i
                        i = i2
                        if done:
                            break
                        if skip and i >= next_k:
                            continue
""")],
    "run2": [("""                    if state == 1:
                        have_front = False
""", """                    if state == 1:
                        have_front = False
                if pre and shade == 0 and near and have_front and i + 1 >= klo:
                    e = min(nseg - 1, khi)
                    if skip:
                        e = min(e, next_k)
                    if e > i:
                        i2, ii, xf, ar, ag, ab, aa, done = RUN2(
                            vol, pre2d, bz, by, bx, sz, sy, sx, i, e, tnear, tfar, step, ii, vs,
                            v0, n_tab, cl, ch_, xf, nsub, a_ref, ert, ar, ag, ab, aa)
                        count += i2 - i
                        i = i2
                        if done:
                            break
                        if skip and i >= next_k:
                            continue
""")],
    "countclear": [("                count += 1\n", ""), ("                    if near:  # the entry alone",
        "                    if (xf < cl and xb < cl) or (xf > ch_ and xb > ch_):\n                        count += 1\n                    if near:  # the entry alone")],
    "countleaptest": [("                count += 1\n", ""), ("                if skip and i >= next_k:\n", "                if skip and i >= next_k:\n                    count += 1\n")],

}
name = sys.argv[1]
which = sys.argv[2:] or list(VARS)
vol, sp, _ = datasets.load(name)
sp = tuple(float(s) for s in sp)
tf = TransferFunction(points=peers.tf_points("semi", *peers.tf_base(vol)))
prep = prepare_volume(vol, sp)
import os
if os.environ.get("HUGE"):
    vol = np.array(vol)
    prep = prepare_volume(vol, sp)
    print(open('/proc/self/smaps_rollup').read().split("AnonHugePages:")[1].split("\n")[0])
VARS["brick2"] = VARS["base"]
VARS["brick8"] = VARS["base"]
kern = {k: (variant([], int(k.split(":")[1])) if k.startswith("tile") else variant(VARS[k])) for k in which}
v = prep.vol if hasattr(prep, "vol") else vol
quad = np.zeros(vol.shape, np.uint32)
vv = vol.astype(np.uint32)
quad[:, :-1, :-1] = vv[:, :-1, :-1] | (vv[:, :-1, 1:] << 8) | (vv[:, 1:, :-1] << 16) | (vv[:, 1:, 1:] << 24)
flat = np.ascontiguousarray(vol).reshape(-1)
EXTRA = {"quad": quad, "flat": flat, "l1": flat}
from volpack.render import raycast as _rc
_orig_render_march = None

orig = raycast._MARCH[True, 0]
res = {k: [] for k in which}
IMG = {}
samples = {}
for rnd in range(4):
    for k in which:
        raycast.TILE_COLS = int(k.split(":")[2]) if k.startswith("tile") else 32
        raycast.SMALL_BRICKS = (1 << 30) if k == "brick2" else (1 << 15)
        raycast.FINE_BRICKS = 1 if k == "brick8" else (1 << 21)
        if k in EXTRA:
            raycast._MARCH[True, 0] = (lambda kk, ex: lambda *a: kk(*a[:3], ex, *a[4:]))(kern[k], EXTRA[k])
        else:
            raycast._MARCH[True, 0] = kern[k]
        for j in range(3):
            cam = Camera(azimuth=40.0 + 10 * j, elevation=20.0, size=(512, 512))
            c = time.process_time()
            img, st = render(prep, tf=tf, camera=cam, step=0.5, workers=1, render_stats=True)
            dc = time.process_time() - c
            if j == 0 and rnd == 0:
                IMG[k] = img
            if rnd > 0:
                res[k].append(dc)
            samples[k, j] = st.samples
raycast._MARCH[True, 0] = orig
for k in which:
    s = sum(samples[k, j] for j in range(3)) / 3
    b = min(res[k]) / 1  # best frame
    print(f"{name} {k:10s} best {b*1e3:7.1f} ms median {np.median(res[k])*1e3:7.1f} ms  segments {s/1e6:.2f} M  {b/s*1e9:.1f} ns/seg")

for k in which:
    if k in IMG and "base" in IMG:
        print(k, "max abs diff vs base", float(np.abs(IMG[k] - IMG["base"]).max()))
if os.environ.get("ASM"):
    for sig, a in RUN.inspect_asm().items():
        open("/tmp/r24/run.s", "w").write(a)
