"""Ray casting of tetrahedral meshes: exact cell traversal, pre-integrated segments.

A scalar given at the vertices is linear inside each tetrahedron, so along a ray it is
piecewise linear with one piece per cell crossed, and each piece is integrated in closed
form (seed 001's integral functions, the ``fast`` model of
:mod:`volpack.render.preint`): with the prefix integrals ``T(s) = int tau`` and
``K(s) = int c tau`` of the transfer function, a piece from ``s_f`` to ``s_b`` of length
``L`` has opacity ``A = 1 - exp(-L (T(s_b) - T(s_f)) / (s_b - s_f))`` and premultiplied
colour ``A (K(s_b) - K(s_f)) / (T(s_b) - T(s_f))``. The prefix integrals are exact at any
fractional value, so no (front, back, length) table is needed: every length is exact.

Traversal (no visibility sort, so non-convex meshes, cavities, several components and
visibility cycles need no special case): the boundary faces (faces with one cell) are
binned into 8 x 8 pixel tiles by their projected bounding boxes; a ray collects the
boundary faces it enters through (outward normal against the ray), sorted by distance,
and from each entry it walks cell to cell through the shared faces, leaving each cell by
the nearest face ahead of it, until it leaves the mesh; the next entry beyond that point
starts the next walk. Early ray termination as in the volume ray caster.

Geometry is in the mesh's units; ``points`` are ``(x, y, z)`` as in mesh files and are
viewed with the same :class:`~volpack.render.camera.Camera` conventions as volumes (+z
up). Opacity is per ``unit`` of length, by default 1/256 of the bounding-box diagonal, so
a mesh looks like a volume of about 256 voxels across with the same transfer function.
Degenerate (zero-volume) cells are crossed at zero length.
"""

from __future__ import annotations

import math
import time

import numpy as np

from .._jit import kernel
from ..errors import VolpackError
from ..parallel import parse_workers
from .camera import Camera
from .preint import extinction, prefix_integrals
from .raycast import ray_at
from .transfer import nonempty_range

TILE = 8
# face k of a tetrahedron is the one opposite vertex k
_FACES = np.array([[1, 2, 3], [0, 2, 3], [0, 1, 3], [0, 1, 2]], np.int64)


def render_mesh(
    points,
    tets,
    scalars,
    *,
    tf,
    camera: Camera | None = None,
    value_range: tuple[float, float] | None = None,
    unit: float | None = None,
    shading: str = "none",
    table_size: int = 256,
    ert: float = 0.99,
    workers: int | None = None,
    progress=None,
    render_stats: bool = False,
):
    """Ray-cast a tetrahedral mesh with a vertex scalar into a pre-multiplied RGBA image.

    Parameters
    ----------
    points : (n, 3) float
        Vertex coordinates ``(x, y, z)``.
    tets : (m, 4) int
        Vertex indices of each tetrahedron (any orientation).
    scalars : (n,) float
        The field rendered, at the vertices (non-finite values are refused).
    tf : TransferFunction or (k, 4) RGBA table
        As for :func:`volpack.render.raycast.render`; opacity per ``unit`` of length.
    camera : Camera
        Framing the mesh's bounding box as it frames a volume's.
    value_range : (lo, hi)
        The value interval of the TF table; default the scalar range.
    unit : float
        Length over which the TF's opacity applies; default 1/256 of the bounding-box
        diagonal.
    shading : {"none", "phong"}
        Phong with a headlight from each cell's (constant) scalar gradient.
    workers : int or None
        Threads (None or 0: every core); the image does not depend on it.

    Returns
    -------
    ndarray (h, w, 4) float32, or (image, RenderStats) with ``render_stats``; the stats
    count cell segments as samples.
    """
    from .raycast import (
        KA,
        KD,
        KS,
        SHININESS,
        RenderStats,
        finish_render,
        run_row_sets,
        transfer_table,
    )

    t_start = time.perf_counter()
    pts = np.asarray(points, np.float64)
    cells = np.asarray(tets)
    vals = np.asarray(scalars, np.float64)
    if pts.ndim != 2 or pts.shape[1] != 3:
        raise VolpackError(f"expected points of shape (n, 3), found {pts.shape}")
    if cells.ndim != 2 or cells.shape[1] != 4 or cells.dtype.kind not in "iu":
        raise VolpackError(
            f"expected integer tetrahedra of shape (m, 4), found {cells.shape} {cells.dtype}"
        )
    if vals.shape != (len(pts),):
        raise VolpackError(f"expected one scalar per point ({len(pts)}), found shape {vals.shape}")
    if not (np.all(np.isfinite(pts)) and np.all(np.isfinite(vals))):
        raise VolpackError("expected finite point coordinates and scalars, found NaN or Inf")
    cells = cells.astype(np.int64)
    if cells.size and (cells.min() < 0 or cells.max() >= len(pts)):
        raise VolpackError(
            f"expected vertex indices in 0..{len(pts) - 1}, found {cells.min()}..{cells.max()}"
        )
    if shading not in ("none", "phong"):
        raise VolpackError(f"expected shading 'none' or 'phong', found {shading!r}")
    camera = Camera() if camera is None else camera
    w, h = camera.size
    out = np.zeros((h, w, 4), np.float32)
    if len(cells) == 0:
        stats = RenderStats(0, time.perf_counter() - t_start, w * h, 0)
        return (out, stats) if render_stats else out

    p = np.ascontiguousarray(pts[:, ::-1])  # (z, y, x), like volumes
    used = np.unique(cells)
    lo_b, hi_b = p[used].min(axis=0), p[used].max(axis=0)
    centre = 0.5 * (lo_b + hi_b)
    radius = max(0.5 * float(np.linalg.norm(hi_b - lo_b)), 1e-12)
    if unit is None:
        unit = 2.0 * radius / 256.0
    unit = float(unit)
    if not (math.isfinite(unit) and unit > 0):
        raise VolpackError(f"expected a unit length > 0, found {unit}")
    if value_range is None:
        lo, hi = float(vals[used].min()), float(vals[used].max())
    else:
        lo, hi = (float(v) for v in value_range)
    lo, hi = nonempty_range(lo, hi)
    n = int(table_size)
    base = transfer_table(tf, lo, hi, n).astype(np.float64)
    tau = extinction(base[:, 3])
    col = np.ascontiguousarray(base[:, :3])
    tp, kp, _ = prefix_integrals(tau, col, False)

    planes = np.empty((len(cells), 4, 4))
    grad = np.empty((len(cells), 4))
    _cell_geometry_kernel(p, cells, _FACES, (vals - lo) * ((n - 1) / (hi - lo)), planes, grad)
    nb, nbf = _face_neighbours(cells)
    bt, bk = np.nonzero(nb < 0)
    tri = p[cells[bt[:, None], _FACES[bk]]]  # (nb, 3 vertices, 3)
    col_px, row_px, _ = camera.project(tri.reshape(-1, 3), centre, radius)
    col_px = col_px.reshape(-1, 3)
    row_px = row_px.reshape(-1, 3)
    ntx, nty = -(-w // TILE), -(-h // TILE)
    start, faces = _bin_faces(col_px, row_px, ntx, nty)
    origins, dirs = camera.world_rays(centre, radius)
    shade = np.array([KA, KD, KS, SHININESS]) if shading == "phong" else np.zeros(0)
    nthreads = parse_workers(workers)
    row_segments = np.zeros(h, np.int64)
    btri = np.ascontiguousarray(tri)
    bt64, bk64 = bt.astype(np.int64), bk.astype(np.int64)

    def run(rows: np.ndarray) -> None:
        _render_mesh_kernel(
            origins, dirs, rows, start, faces, btri, bt64, bk64, planes, grad, nb, nbf,
            tp, kp, tau, col, 1.0 / unit, float(ert), shade, out, row_segments,
        )  # fmt: skip

    run_row_sets(run, h, nthreads, progress)
    return finish_render(out, row_segments, t_start, render_stats)


# --------------------------------------------------------------------------- helpers


def _face_neighbours(cells: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Cell and face index across each face, -1 on the boundary (faces of more than two
    cells pair two of them: :func:`volpack.tetra.mesh.face_adjacency`)."""
    from ..tetra.mesh import face_adjacency

    nb, _ = face_adjacency(cells)
    nbf = np.full(nb.shape, -1, np.int64)
    t, k = np.nonzero(nb >= 0)
    # the face of the neighbour that points back (two valid cells share one face at most)
    back = nb[nb[t, k]] == t[:, None]
    nbf[t, k] = np.argmax(back, axis=1)
    return nb, nbf


def _bin_faces(col_px, row_px, ntx, nty):
    """CSR lists of boundary faces per 8 x 8 pixel tile (projected bounding boxes, one
    pixel of slack; a face with a vertex behind a perspective eye goes everywhere)."""
    bad = ~(np.all(np.isfinite(col_px), axis=1) & np.all(np.isfinite(row_px), axis=1))
    c0 = np.where(bad, 0, np.floor((np.nan_to_num(col_px.min(axis=1)) - 1) / TILE))
    c1 = np.where(bad, ntx - 1, np.floor((np.nan_to_num(col_px.max(axis=1)) + 1) / TILE))
    r0 = np.where(bad, 0, np.floor((np.nan_to_num(row_px.min(axis=1)) - 1) / TILE))
    r1 = np.where(bad, nty - 1, np.floor((np.nan_to_num(row_px.max(axis=1)) + 1) / TILE))
    c0 = np.clip(c0, 0, ntx).astype(np.int64)
    c1 = np.clip(c1, -1, ntx - 1).astype(np.int64)
    r0 = np.clip(r0, 0, nty).astype(np.int64)
    r1 = np.clip(r1, -1, nty - 1).astype(np.int64)
    count = np.zeros(ntx * nty + 1, np.int64)
    _bin_kernel(c0, c1, r0, r1, ntx, count, np.zeros(0, np.int64), False)
    start = np.zeros(ntx * nty + 1, np.int64)
    start[1:] = np.cumsum(count[:-1])
    faces = np.empty(int(start[-1]), np.int64)
    fill = start.copy()
    _bin_kernel(c0, c1, r0, r1, ntx, fill, faces, True)
    return start, faces


# --------------------------------------------------------------------------- kernels


@kernel
def _bin_kernel(c0, c1, r0, r1, ntx, cursor, faces, write):
    for f in range(c0.shape[0]):
        for r in range(r0[f], r1[f] + 1):
            for c in range(c0[f], c1[f] + 1):
                k = r * ntx + c
                if write:
                    faces[cursor[k]] = f
                cursor[k] += 1


@kernel
def _cell_geometry_kernel(p, cells, fidx, x, planes, grad):
    """Outward face planes ``(n, d)`` (inside: ``n.q <= d``) and the linear field
    ``x(q) = g.q + g0`` (in TF table units) of each cell; zero planes and gradient for a
    degenerate cell."""
    for t in range(cells.shape[0]):
        v = cells[t]
        a = p[v[0]]
        e1 = p[v[1]] - a
        e2 = p[v[2]] - a
        e3 = p[v[3]] - a
        det = (
            e1[0] * (e2[1] * e3[2] - e2[2] * e3[1])
            - e1[1] * (e2[0] * e3[2] - e2[2] * e3[0])
            + e1[2] * (e2[0] * e3[1] - e2[1] * e3[0])
        )
        scale = max(np.abs(e1).max(), np.abs(e2).max(), np.abs(e3).max())
        if abs(det) <= 1e-12 * scale**3 or scale == 0.0:
            for k in range(4):
                for q in range(4):
                    planes[t, k, q] = 0.0
                grad[t, k] = 0.0
            continue
        for k in range(4):
            pa = p[v[fidx[k, 0]]]
            u = p[v[fidx[k, 1]]] - pa
            w = p[v[fidx[k, 2]]] - pa
            nz = u[1] * w[2] - u[2] * w[1]
            ny = u[2] * w[0] - u[0] * w[2]
            nx = u[0] * w[1] - u[1] * w[0]
            opp = p[v[k]]
            if nz * (opp[0] - pa[0]) + ny * (opp[1] - pa[1]) + nx * (opp[2] - pa[2]) > 0.0:
                nz, ny, nx = -nz, -ny, -nx
            planes[t, k, 0] = nz
            planes[t, k, 1] = ny
            planes[t, k, 2] = nx
            planes[t, k, 3] = nz * pa[0] + ny * pa[1] + nx * pa[2]
        # gradient: solve [e1; e2; e3] g = [x1 - x0, x2 - x0, x3 - x0] by Cramer's rule
        b1 = x[v[1]] - x[v[0]]
        b2 = x[v[2]] - x[v[0]]
        b3 = x[v[3]] - x[v[0]]
        gz = (
            b1 * (e2[1] * e3[2] - e2[2] * e3[1])
            - e1[1] * (b2 * e3[2] - e2[2] * b3)
            + e1[2] * (b2 * e3[1] - e2[1] * b3)
        ) / det
        gy = (
            e1[0] * (b2 * e3[2] - e2[2] * b3)
            - b1 * (e2[0] * e3[2] - e2[2] * e3[0])
            + e1[2] * (e2[0] * b3 - b2 * e3[0])
        ) / det
        gx = (
            e1[0] * (e2[1] * b3 - b2 * e3[1])
            - e1[1] * (e2[0] * b3 - b2 * e3[0])
            + b1 * (e2[0] * e3[1] - e2[1] * e3[0])
        ) / det
        grad[t, 0] = gz
        grad[t, 1] = gy
        grad[t, 2] = gx
        grad[t, 3] = x[v[0]] - (gz * a[0] + gy * a[1] + gx * a[2])


@kernel
def _prefix_at(tp, kp, tau, col, x, out):
    """``T(x)`` returned, ``K(x)`` in ``out``: the prefix integrals at fractional index x."""
    n = tau.shape[0]
    if n == 1:
        for ch in range(3):
            out[ch] = col[0, ch] * tau[0] * x
        return tau[0] * x
    if x <= 0.0:
        for ch in range(3):
            out[ch] = col[0, ch] * tau[0] * x
        return tau[0] * x
    k = int(x)
    if k > n - 2:
        k = n - 2
    f = x - k
    if f > 1.0:  # beyond the last entry: constant extension
        e = f - 1.0
        for ch in range(3):
            out[ch] = kp[n - 1, ch] + col[n - 1, ch] * tau[n - 1] * e
        return tp[n - 1] + tau[n - 1] * e
    t0 = tau[k]
    dt = tau[k + 1] - t0
    for ch in range(3):
        c0 = col[k, ch]
        dc = col[k + 1, ch] - c0
        out[ch] = (
            kp[k, ch] + c0 * t0 * f + (c0 * dt + dc * t0) * f * f / 2 + dc * dt * f * f * f / 3
        )
    return tp[k] + t0 * f + dt * f * f / 2


@kernel
def _value_at(tau, col, x, out):
    """``tau(x)`` returned, ``c(x)`` in ``out`` (linear between entries, clamped)."""
    n = tau.shape[0]
    if x <= 0.0 or n == 1:
        for ch in range(3):
            out[ch] = col[0, ch]
        return tau[0]
    if x >= n - 1:
        for ch in range(3):
            out[ch] = col[n - 1, ch]
        return tau[n - 1]
    k = int(x)
    f = x - k
    for ch in range(3):
        out[ch] = col[k, ch] + (col[k + 1, ch] - col[k, ch]) * f
    return tau[k] + (tau[k + 1] - tau[k]) * f


@kernel
def _render_mesh_kernel(
    origins, dirs, rows, start, faces, tri, btet, bface, planes, grad, nb, nbf,
    tp, kp, tau, col, inv_unit, ert, shade, out, row_segments,
):  # fmt: skip
    w = out.shape[1]
    ntx = (w + TILE - 1) // TILE
    m = planes.shape[0]
    kf = np.empty(3)
    kb = np.empty(3)
    cc = np.empty(3)
    shaded = shade.shape[0] == 4
    cap = 1
    for i in range(start.shape[0] - 1):
        cap = max(cap, start[i + 1] - start[i])
    ht = np.empty(cap)
    hc = np.empty(cap, np.int64)
    for q in range(rows.shape[0]):
        r = rows[q]
        segs = 0
        for c in range(w):
            oz, oy, ox, dz, dy, dx = ray_at(origins, dirs, r, c)
            tile = (r // TILE) * ntx + c // TILE
            s0, s1 = start[tile], start[tile + 1]
            # entries: boundary faces crossed against their outward normal
            nh = 0
            for i in range(s0, s1):
                f = faces[i]
                t, k = btet[f], bface[f]
                den = planes[t, k, 0] * dz + planes[t, k, 1] * dy + planes[t, k, 2] * dx
                if not den < 0.0:
                    continue
                # Moller-Trumbore, inclusive edges so shared edges leave no crack
                az, ay, ax = tri[f, 0, 0], tri[f, 0, 1], tri[f, 0, 2]
                e1z, e1y, e1x = tri[f, 1, 0] - az, tri[f, 1, 1] - ay, tri[f, 1, 2] - ax
                e2z, e2y, e2x = tri[f, 2, 0] - az, tri[f, 2, 1] - ay, tri[f, 2, 2] - ax
                pz = dy * e2x - dx * e2y
                py = dx * e2z - dz * e2x
                px = dz * e2y - dy * e2z
                det = e1z * pz + e1y * py + e1x * px
                if det == 0.0:
                    continue
                inv = 1.0 / det
                sz, sy, sx = oz - az, oy - ay, ox - ax
                u = (sz * pz + sy * py + sx * px) * inv
                if u < -1e-9 or u > 1.0 + 1e-9:
                    continue
                qz = sy * e1x - sx * e1y
                qy = sx * e1z - sz * e1x
                qx = sz * e1y - sy * e1z
                v = (dz * qz + dy * qy + dx * qx) * inv
                if v < -1e-9 or u + v > 1.0 + 1e-9:
                    continue
                tt = (e2z * qz + e2y * qy + e2x * qx) * inv
                # insertion in distance order
                j = nh
                while j > 0 and ht[j - 1] > tt:
                    ht[j] = ht[j - 1]
                    hc[j] = hc[j - 1]
                    j -= 1
                ht[j] = tt
                hc[j] = f
                nh += 1
            ar = 0.0
            ag = 0.0
            ab = 0.0
            aa = 0.0
            t_done = -np.inf
            steps = 0
            for e in range(nh):
                if aa > ert:
                    break
                t_in = ht[e]
                if t_in < t_done - 1e-9 * (1.0 + abs(t_done)):
                    continue  # an entry inside a stretch already walked
                cell = btet[hc[e]]
                k_in = bface[hc[e]]
                if t_in < 0.0:
                    t_in = 0.0  # the eye is inside the mesh
                t_out = t_in
                while cell >= 0 and steps < 4 * m + 16:
                    steps += 1
                    # leave through the nearest face ahead
                    t_out = np.inf
                    k_out = -1
                    for k in range(4):
                        if k == k_in:
                            continue
                        den = (
                            planes[cell, k, 0] * dz
                            + planes[cell, k, 1] * dy
                            + planes[cell, k, 2] * dx
                        )
                        if den > 0.0:
                            tk = (
                                planes[cell, k, 3]
                                - planes[cell, k, 0] * oz
                                - planes[cell, k, 1] * oy
                                - planes[cell, k, 2] * ox
                            ) / den
                            if tk < t_out:
                                t_out = tk
                                k_out = k
                    if k_out < 0:  # degenerate cell: cross it at zero length
                        t_out = t_in
                        for k in range(4):
                            if k != k_in and nb[cell, k] >= 0:
                                k_out = k
                                break
                        if k_out < 0:
                            break
                    if t_out < t_in:
                        t_out = t_in
                    length = (t_out - t_in) * inv_unit
                    if length > 0.0 and t_out > 0.0:
                        segs += 1
                        gz, gy, gx, g0 = grad[cell, 0], grad[cell, 1], grad[cell, 2], grad[cell, 3]
                        xf = (
                            gz * (oz + t_in * dz)
                            + gy * (oy + t_in * dy)
                            + gx * (ox + t_in * dx)
                            + g0
                        )
                        xb = (
                            gz * (oz + t_out * dz)
                            + gy * (oy + t_out * dy)
                            + gx * (ox + t_out * dx)
                            + g0
                        )
                        if abs(xb - xf) > 1e-7:
                            tf_ = _prefix_at(tp, kp, tau, col, xf, kf)
                            tb_ = _prefix_at(tp, kp, tau, col, xb, kb)
                            dt = tb_ - tf_
                            a = -math.expm1(-length * dt / (xb - xf))
                            for ch in range(3):
                                cc[ch] = a * (kb[ch] - kf[ch]) / dt if dt != 0.0 else 0.0
                        else:
                            tv = _value_at(tau, col, 0.5 * (xf + xb), cc)
                            a = -math.expm1(-length * tv)
                            for ch in range(3):
                                cc[ch] *= a
                        if a > 0.0:
                            fct = 1.0
                            spec = 0.0
                            if shaded:
                                gn = math.sqrt(gz * gz + gy * gy + gx * gx)
                                if gn > 0.0:
                                    ndv = abs(gz * dz + gy * dy + gx * dx) / gn
                                    fct = shade[0] + shade[1] * ndv
                                    spec = shade[2] * ndv ** shade[3] * a
                            wgt = 1.0 - aa
                            ar += wgt * (min(max(cc[0], 0.0), a) * fct + spec)
                            ag += wgt * (min(max(cc[1], 0.0), a) * fct + spec)
                            ab += wgt * (min(max(cc[2], 0.0), a) * fct + spec)
                            aa += wgt * a
                            if aa > ert:
                                break
                    nxt = nb[cell, k_out]
                    if nxt < 0:
                        break
                    k_in = nbf[cell, k_out]
                    cell = nxt
                    t_in = t_out
                t_done = t_out if t_out > t_done else t_done
            out[r, c, 0] = ar
            out[r, c, 1] = ag
            out[r, c, 2] = ab
            out[r, c, 3] = aa
        row_segments[r] = segs
