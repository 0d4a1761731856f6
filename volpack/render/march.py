"""The ray caster's fast path: the common case in a small kernel of its own.

:func:`volpack.render.raycast.render` sends here every image of a plain volume (not a
multiresolution selection) with post-classification or pre-integration, unshaded or
Phong-shaded, and no isosurfaces; everything else goes through the general kernel.
Both march the same segments (``t0 = tnear + i * step``), sample the same positions,
use the same tables, leap the same empty bricks and composite in the same order, so
they give the same image up to float rounding (``tests/test_render_fast.py`` holds
them to 1e-5). What makes this one faster (issue 22, ``scripts/profile_render.py``):

* only the branches its case needs, so the loop keeps its values in registers;
* the volume read as it is stored (uint8, int16, ...) and interpolated in float32;
* the gradient read from the per-voxel gradient volume of
  :class:`volpack.render.prepared.PreparedVolume` when there is one;
* the specular power by repeated squaring when the exponent is a whole number;
* table look-ups returned as values, not written to a scratch array.
"""

from __future__ import annotations

import math

from .._jit import kernel
from .raycast import _leap, _normal, _ray_span, _trilinear, _trilinear3, _ucell


@kernel
def _powi(x, n):
    """``x ** n`` for a whole ``n >= 0`` by repeated squaring."""
    r = 1.0
    while n > 0:
        if n & 1:
            r *= x
        x *= x
        n >>= 1
    return r


@kernel
def _rgba1(tab, x):
    """Linear lookup of the (n, 4) table at fractional index ``x``, as a tuple."""
    i0, i1, f = _ucell(x, tab.shape[0])
    a0, a1, a2, a3 = tab[i0, 0], tab[i0, 1], tab[i0, 2], tab[i0, 3]
    return (a0 + (tab[i1, 0] - a0) * f, a1 + (tab[i1, 1] - a1) * f,
            a2 + (tab[i1, 2] - a2) * f, a3 + (tab[i1, 3] - a3) * f)  # fmt: skip


@kernel
def _rgba2(tab, xf, xb):
    """Bilinear lookup of the (n, n, 4) table at (front, back), as a tuple."""
    n = tab.shape[0]
    i0, i1, fi = _ucell(xf, n)
    j0, j1, fj = _ucell(xb, n)
    return (_bilerp(tab, 0, i0, i1, fi, j0, j1, fj), _bilerp(tab, 1, i0, i1, fi, j0, j1, fj),
            _bilerp(tab, 2, i0, i1, fi, j0, j1, fj), _bilerp(tab, 3, i0, i1, fi, j0, j1, fj))  # fmt: skip


@kernel
def _bilerp(tab, ch, i0, i1, fi, j0, j1, fj):
    a = tab[i0, j0, ch] + (tab[i0, j1, ch] - tab[i0, j0, ch]) * fj
    b = tab[i1, j0, ch] + (tab[i1, j1, ch] - tab[i1, j0, ch]) * fj
    return a + (b - a) * fi


@kernel
def _ndv(grad, z, y, x, gscale, vz, vy, vx, gmin):
    """``|n.v|`` from the gradient volume (inside ``[0, n - 1]``; -1 where the gradient
    vanishes): :func:`volpack.render.raycast._normal` without the normal itself."""
    g0, g1, g2 = _trilinear3(grad, z, y, x)
    gz = g0 * gscale[0]
    gy = g1 * gscale[1]
    gx = g2 * gscale[2]
    g = math.sqrt(gz * gz + gy * gy + gx * gx)
    if g <= gmin:
        return -1.0
    return abs(gz * vz + gy * vy + gx * vx) / g


@kernel
def march_kernel(
    vol, grad, has_grad, origins, dirs, rows, mode, post_tab, pre2d, lo, scale, step,
    leap, brick, skip, ert, shade, shading, gscale, vscale, gmin, out, row_samples,
):  # fmt: skip
    """Rays of image rows ``rows``; ``mode`` 0 (post) or 2 (pre-integrated), ``shade``
    0 (none) or 1 (Phong at the segment midpoint). Arguments as for the general
    kernel of :mod:`volpack.render.raycast`."""
    nz, ny, nx = vol.shape
    w = out.shape[1]
    ka, kd, ks, shin = shading[0], shading[1], shading[2], shading[3]
    ishin = int(shin)
    whole = ishin == shin and ishin >= 0
    pre = mode == 2
    for k in range(rows.shape[0]):
        r = rows[k]
        count = 0
        for c in range(w):
            oz, oy, ox = origins[r, c, 0], origins[r, c, 1], origins[r, c, 2]
            dz, dy, dx = dirs[r, c, 0], dirs[r, c, 1], dirs[r, c, 2]
            tnear, tfar, nseg, vz, vy, vx = _ray_span(
                oz, oy, ox, dz, dy, dx, nz, ny, nx, vscale, step
            )
            if nseg == 0:
                continue
            ar = 0.0
            ag = 0.0
            ab = 0.0
            aa = 0.0
            xf = 0.0
            have_front = False
            next_check = -1.0
            i = 0
            while i < nseg:
                t0 = tnear + i * step
                if skip and t0 >= next_check:
                    state, i, next_check = _leap(
                        i, t0, tnear, tfar, step, next_check,
                        oz, oy, ox, dz, dy, dx, nz, ny, nx, leap, brick,
                    )  # fmt: skip
                    if state == 2:
                        break
                    if state == 1:
                        have_front = False
                        continue
                t1 = t0 + step
                if t1 > tfar:
                    t1 = tfar
                seglen = t1 - t0
                if seglen <= 0.0:
                    break
                tm = 0.5 * (t0 + t1)
                count += 1
                if pre:
                    if not have_front:
                        xf = (_trilinear(vol, oz + t0 * dz, oy + t0 * dy, ox + t0 * dx) - lo) * scale
                        have_front = True
                    xb = (_trilinear(vol, oz + t1 * dz, oy + t1 * dy, ox + t1 * dx) - lo) * scale
                    cr, cg, cb, a = _rgba2(pre2d, xf, xb)
                    xf = xb
                else:
                    s = _trilinear(vol, oz + tm * dz, oy + tm * dy, ox + tm * dx)
                    cr, cg, cb, a = _rgba1(post_tab, (s - lo) * scale)
                if a > 0.0:
                    if seglen < step:  # last, shorter segment
                        a2 = 1.0 - (1.0 - min(a, 1.0)) ** (seglen / step)
                        g = a2 / a
                        cr, cg, cb, a = cr * g, cg * g, cb * g, a2
                    f = 1.0
                    spec = 0.0
                    if shade:
                        pz, py, px = oz + tm * dz, oy + tm * dy, ox + tm * dx
                        if has_grad and (0.0 <= pz <= nz - 1 and 0.0 <= py <= ny - 1
                                         and 0.0 <= px <= nx - 1):  # fmt: skip
                            ndv = _ndv(grad, pz, py, px, gscale, vz, vy, vx, gmin)
                        else:
                            ndv = _normal(vol, grad, False, pz, py, px, gscale, vz, vy, vx,
                                          gmin)[3]  # fmt: skip
                        if ndv >= 0.0:
                            f = ka + kd * ndv
                            spec = ks * (_powi(ndv, ishin) if whole else ndv**shin) * a
                    wgt = 1.0 - aa
                    ar += wgt * (cr * f + spec)
                    ag += wgt * (cg * f + spec)
                    ab += wgt * (cb * f + spec)
                    aa += wgt * a
                    if aa > ert:
                        break
                i += 1
            out[r, c, 0] = ar
            out[r, c, 1] = ag
            out[r, c, 2] = ab
            out[r, c, 3] = aa
        row_samples[r] = count
