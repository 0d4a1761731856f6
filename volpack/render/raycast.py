"""CPU ray caster: front-to-back compositing of classified ray segments.

Rays come from :class:`~volpack.render.camera.Camera` in voxel index space. Each ray is
clipped to the box ``[-0.5, n - 0.5]`` per axis (so a volume one voxel thick is one voxel
deep) and cut into equal segments of ``step`` reference lengths (the smallest spacing),
the last one shorter. Samples are trilinear; positions outside ``[0, n - 1]`` take the
nearest edge value. Every sample position is computed as ``origin + t * direction``
(never accumulated), so an image does not depend on the thread count; the fast path
holds it in fixed point (:mod:`volpack.render.fixed`: entry point plus ``k`` steps, an
exact integer multiply-add) and samples integer volumes with integer weights.

Threads: image rows are split into interleaved sets of bands of 16 rows
(:func:`run_row_sets`; the fast path traces a band in tiles of 32 columns,
:data:`TILE_COLS`) that run on ``workers`` threads through the nogil kernel
(:func:`volpack.parallel.completed_map`), rather than a numba ``prange``: the parallel
build of this kernel took three times as long to compile (about 9 s against 3 s), and
interleaving balances the threads however the volume sits in the image. On orthographic
frames the fast path traces only the columns of each row whose rays may meet the
volume's box (:meth:`Camera.box_columns`): a small volume fills a fraction of a 512^2
frame, and its missing rays took 8 ms of CPU (1.7 ms since; session 36).

Classification (``classification=``):

``"post"``
    The scalar at the segment midpoint is looked up in the transfer-function table
    (linear in value) whose opacity was corrected for ``step`` once, up front:
    ``alpha = 1 - (1 - a) ** step``, colours pre-multiplied by it.
``"pre"``
    Every voxel is classified first (the same corrected, pre-multiplied table) into an
    RGBA volume, and the four channels are interpolated at the midpoint.
``"preintegrated"``
    The scalars at the segment's front and back ends index the 2-D table of
    :func:`volpack.render.preint.preintegrate` (bilinear lookup) for a segment of
    ``step`` reference lengths.

The last, shorter segment of a ray uses the same entry with its opacity corrected for
the shorter length (``1 - (1 - alpha) ** (len / step)``, colour scaled alike).

Nearest entries: a pre-integrated table whose neighbouring entries differ by at most
:data:`NEAREST_STEP` (2^-10, every channel, both axes: a faint, semi-transparent TF) is
read at the entry nearest the two samples' positions (4 reads instead of 16 and no
lerps), since there the bilinear look-up moves a segment's premultiplied colour and
opacity by at most twice that. Opaque TFs, whose tables jump by 0.04 and more between
entries, keep the bilinear look-up. Measured on the benchmark's semi-transparent TF
(``scripts/bench_render_peers.py``, one thread, CPU): the head CT's frame 0.75-0.82x, the
MNI152 MRI's 0.80-0.84x; the step-0.5 image 0.1-0.4 dB further from the bilinear
step-0.125 one (71.9 against 72.0 dB on the CT, 77.5 against 77.9 on the MRI, 65.4
against 65.5 on the z-map), where VTK's image is 42-63 dB from its own.

Refinement (``refine=m``, pre-integrated): a segment's table entry assumes the scalar
linear between its two samples, while the trilinear field is cubic along the ray, and a
chord cuts every peak and shifts where a ray enters a surface. Where that matters, in
segments that carry more than :data:`REFINE_OPACITY` of the pixel's opacity
(``(1 - A_acc) A``), the segment is marched again as ``m`` sub-segments, with ``m - 1``
samples more, through the table of a segment ``step / m`` long (built beside the
other). On semi-transparent transfer functions no segment is that thick at step 0.5;
on opaque ones it is the few segments where a ray meets a surface or crosses a thin
sheet. Measured on the benchmark's opaque TF (``scripts/bench_render_peers.py``):
the step-0.5 image 8-15 dB nearer its step-0.125 one for 3-8 % more segments (more
CPU than that: the refined segments are the visible, shaded ones). The chord's error in
a sub-segment falls as the square of its length, so three sub-segments leave 4/9 of
two's; the third is taken only where the scalar bends along the ray (the second
difference of the samples, :func:`sub_count`, at least :data:`REFINE_BEND` table
entries), where the chord errs: ``refine=3``, the default, gave the benchmark's opaque
frames 0.9-1.9 dB more on ten volumes for 1-8 % more CPU (three sub-segments wherever
refined: 2-10 %; ``results/render/psnr25``).

Shading (``shading="phong"``): a headlight (light and eye directions equal), two-sided,
``ka + kd |n.v| + ks |n.v|^shininess`` with white specular. The normal is the world
gradient by central differences (one voxel either way) of the trilinear field, taken at
the segment midpoint; with pre-integration the whole segment is shaded with that
midpoint gradient (the pre-integrated colour times the lighting factor, as in Engel et
al.'s volume shading). Where the gradient vanishes the sample is left unshaded.
On orthographic frames of the fast path (``normals="quantised"``, the default) the
normals are instead per-voxel quantised directions (:mod:`volpack.render.normals`),
computed once per volume, and the diffuse and specular factors of the sample's eight
corner voxels, looked up in one table per frame, are interpolated (as VTK's CPU ray
caster shades): 27 against 80 ns a shaded segment on the MNI152 MRI, an image within
45 dB of the exact normals'.

Pre-integrated lighting (``shading="preintegrated"``, with pre-integrated
classification): normals at the segment's two ends (the back one is reused as the next
segment's front), ``n.v`` taken linear between them and integrated with the emission
through the back-weighted table of :func:`volpack.render.preint.preintegrate`
(``lighting=True``): ``ka C + kd (l_f (C - B) + l_b B) + ks (n*.v)^shininess A`` with
``n*`` the normal at the segment's emission centroid ``B / C``. It costs what ``phong``
costs (one gradient per segment). ``shading="centroid"`` uses the same table only to
place the one Phong evaluation at the segment's emission centroid instead of its
midpoint (the two agree where emission is even along the segment). Measured
(``scripts/bench_shading.py``) against per-sample Phong at step 1/50: ``centroid`` is the
most accurate of the three; linear ``n.l`` is the least, since the normals come from
the segment ends, and a linear blend of end values errs twice as much as the midpoint
on smoothly turning normals.

Isosurfaces (``isos=[(value, (r, g, b), opacity), ...]``): the table of
:func:`volpack.render.preint.iso_table` gives the first isosurface a segment crosses
(nearest-entry lookup, so a hit is never blurred away). The hit point along the segment
is found from the iso values themselves (``IP = (s_iso - s_f) / (s_b - s_f)``) and the
surface is shaded with the gradient there. With ``tf`` as well the surface is
composited in front of the segment's volume contribution (mixed mode); with
``tf=None`` only the surfaces are drawn.

Acceleration: early ray termination once the accumulated opacity exceeds ``ert``
(0.99; the transmittance left is given the colour of the last segment, see
:func:`_complete`), and empty-space skipping over 8^3 bricks whose value range (the brick plus one
voxel of overlap, everything trilinear samples inside it can reach) maps to table
entries that are all zero (4^3 bricks on volumes of up to 2^21 of them, else 8^3). A
leap map holds, for each empty brick, its Chebyshev distance ``d`` (in bricks) to the
nearest visible one, so a ray jumps out of the whole cube of ``2d - 1`` bricks around it
at once, to the last segment that still starts inside; and for each visible brick its
distance to the nearest empty one, so a ray inside visible space is tested again only
where it leaves the cube of visible bricks around it (not at every brick: on the
benchmark's MRI the tests took 40 % of a semi-transparent frame). The sample grid, and
the image, stay exactly those of the full march. The fast path tests in its fixed-point
positions (:func:`_leap_fixed`): the brick by shifts, the cube's exit in steps by one
multiply an axis; the float test's four divisions made the tests half of a frame of the
benchmark's z-map, whose scattered blobs leave rays crossing a brick border every few
segments.

Multiresolution volumes (:class:`volpack.render.lod.PagedVolume`) go through the same
kernels: :func:`sample` is resolved at compile time to plain trilinear sampling or to a
page-table lookup into an atlas of bordered node bricks (:func:`_paged`), and the leap
map is built over the pages.

Non-finite voxels (NaN, +-Inf) are empty: they are replaced before sampling by a value
whose table entry is transparent (the data minimum when that is transparent, else the
value in range nearest to it that is); when no value is transparent they take the data
minimum and a warning is logged.

It stays one file on purpose: the three classification modes, shading and empty-space
skipping are branches of one march kernel, and the common case has a lean copy of that
march (:func:`_march`, the fast path), both with their inline sampling kernels,
kept beside the public :func:`render` that sets them up.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import threading
import time
from collections.abc import Callable, Sequence

import numpy as np

from .._jit import JIT_DISABLED, kernel, leading_zeros, read_only
from ..errors import VolpackError
from ..parallel import completed_map, ordered_map, parse_workers
from .camera import Camera, pixel_ray
from .fixed import FRAC, interior, lerp_cell, to_fixed, trilinear_fixed, trilinear_inner, value_unit
from .normals import light_table
from .prepared import prepare_volume, unpack_volume
from .transfer import nonempty_range

log = logging.getLogger(__name__)

MODES = {"post": 0, "pre": 1, "preintegrated": 2}
SHADINGS = ("none", "phong", "preintegrated", "centroid")
BRICK = 8
#: Plain volumes with at most this many 4^3 bricks skip empty space by 4^3 bricks (a
#: finer fit around what the TF shows: 10-45 % fewer samples on the benchmark's
#: volumes), larger ones by BRICK^3; the per-brick ranges (8 bytes) and leap map (4
#: bytes) stay under 25 MB.
FINE_BRICK, FINE_BRICKS = 4, 1 << 21
#: (Volumes of up to 2^15 2^3 bricks skipped by 2^3 bricks from session 25 to 35: fewer
#: segments on the benchmark's 64^3 skull, but twice the empty-space tests a ray, each
#: with a clamped front sample after it; on five small volumes the 4^3 bricks took
#: 0.74-0.92x the CPU of semi-transparent frames and 0.95-1.02x of opaque ones, the
#: skull's opaque frames 1.02-1.05x; session 36, ``results/render/rend36/``.)
TABLE_SIZE = 256
#: Send the common case through the fast path, :func:`_march` (tests turn it
#: off to compare the two kernels).
FAST_PATH = True
#: Read smooth pre-integrated tables at the nearest entry (:data:`NEAREST_STEP`; tests
#: turn it off to compare with the bilinear look-up).
NEAREST = True
#: March the fast path's unshaded nearest-entry frames with the kernel that sends their
#: segments through :func:`_near_run` (tests turn it off to check that it gives the plain
#: loop's image bit for bit).
NEAR_RUN = True
#: Refine the fast path's unshaded segments through :func:`_refined_plain`, and those of
#: frames lit through quantised normals through :func:`_refined_lit` (tests turn it off
#: to check that they give :func:`_refined`'s image bit for bit).
LEAN_REFINE = True
#: Trace only the columns of each image row whose rays may meet the volume's box
#: (:meth:`Camera.box_columns`; tests turn it off to check the image is the same).
BOX_SPANS = True
#: Tables span the transfer function's points (clipped to the data) instead of the data
#: range when the points cover less than this share of it: a fill value or an outlier
#: (-9999 on a climate grid, 1e20) otherwise squeezes what the TF shows into a few of
#: the ``table_size`` entries. Samples beyond the tables take the TF's end values, and a
#: pre-integrated segment whose ends lie beyond them is cut where its scalar crosses
#: the tables' ends (:func:`_clip_chord`). Session 37, ``results/render/rend37/``.
NARROW_SHARE = 0.25
#: A segment with an end beyond the tables is sampled again (:func:`_clip_refined`) only
#: where its opacity at its end inside the tables (the table's diagonal entry there: a
#: segment of that value throughout), times the pixel's transmittance so far, is at least
#: this (half a level of an 8-bit image): the extra samples move a segment's share of
#: the pixel by about that much at most. On storm_u's semi-transparent frames three in
#: four segments sampled again were fainter; their extra samples took 11-14 % of the
#: frame's CPU and moved its PSNR by under 0.1 dB (session 37, rend37b,
#: ``results/render/rend37b/probe_clip.txt``). 0: every cut segment sampled again.
CLIP_MIN = 1.0 / 512.0
#: Refinement: a pre-integrated segment carrying more than this share of its pixel's
#: opacity is marched again in ``refine`` sub-segments (see :func:`render`).
REFINE_OPACITY = 0.1
#: Sub-segments of a refined segment by default (``render(refine=)``), where the scalar
#: bends along the ray (:data:`REFINE_BEND`; elsewhere two).
REFINE = 3
#: A refined segment whose samples' second difference along the ray (this one's two and
#: the one before) is under this many table entries takes two sub-segments, not
#: ``refine`` (:func:`sub_count`).
REFINE_BEND = 1.0
#: Pre-integrated tables whose neighbouring entries differ by at most this (every
#: channel, along both axes) are read at the nearest entry instead of bilinearly: the
#: two differ by at most twice this per segment, and the look-up costs 4 reads instead
#: of 16 (see :func:`render`, module docstring).
NEAREST_STEP = 2.0**-10
# Phong constants (headlight)
KA, KD, KS, SHININESS = 0.25, 0.75, 0.35, 24.0


@dataclasses.dataclass(frozen=True)
class RenderStats:
    """What a render did: classified samples (segments composited or tested), wall
    seconds (table building included), rays cast and rays that hit the volume box."""

    samples: int
    seconds: float
    rays: int
    hits: int

    @property
    def samples_per_s(self) -> float:
        return self.samples / self.seconds if self.seconds > 0 else float("inf")


# --------------------------------------------------------------------------- kernels


@kernel
def _cell(p, n):
    """Clamp coordinate ``p`` to ``[0, n-1]``; return (lower index, upper index, weight)."""
    if p <= 0.0:
        return 0, 0, 0.0
    if p >= n - 1:
        return n - 1, n - 1, 0.0
    i = int(p)
    return i, i + 1, p - i


@kernel(inline=True)
def _cell3(nz, ny, nx, z, y, x):
    """Corner indices (unsigned, so indexing needs no wrap-around test) and float32
    weights of the trilinear cell at (z, y, x), positions clamped to ``[0, n - 1]``:
    :func:`_cell` per axis, without branches (min and max compile to single
    instructions, so the per-sample cost does not depend on where the sample lies)."""
    z0, z1, fz = _clamp_cell(z, nz)
    y0, y1, fy = _clamp_cell(y, ny)
    x0, x1, fx = _clamp_cell(x, nx)
    return z0, z1, fz, y0, y1, fy, x0, x1, fx


@kernel(inline=True)
def _clamp_cell(p, n):
    """:func:`_cell` with unsigned indices and a float32 weight, branch-free: the same
    numbers (at ``p >= n - 1`` both indices are ``n - 1`` and the weight 0)."""
    q = min(max(p, 0.0), n - 1.0)
    i = int(q)
    return np.uint64(i), np.uint64(min(i + 1, n - 1)), np.float32(q - i)


@kernel(inline=True)
def _trilinear(vol, z, y, x):
    """Trilinear sample (float32) of a volume of any real dtype, read as it is stored."""
    nz, ny, nx = vol.shape
    z0, z1, fz, y0, y1, fy, x0, x1, fx = _cell3(nz, ny, nx, z, y, x)
    return lerp_cell(vol, 0, z0, z1, fz, y0, y1, fy, x0, x1, fx)


@kernel(inline=True)
def _trilinear3(grad, node, z, y, x):
    """Trilinear sample of the three channels of brick ``node`` of a ``(bricks, nz, ny,
    nx, 3)`` stack of gradient volumes (a plain volume's is one brick)."""
    nz, ny, nx = grad.shape[1], grad.shape[2], grad.shape[3]
    z0, z1, fz, y0, y1, fy, x0, x1, fx = _cell3(nz, ny, nx, z, y, x)
    return (_lerp8(grad, node, 0, z0, z1, fz, y0, y1, fy, x0, x1, fx),
            _lerp8(grad, node, 1, z0, z1, fz, y0, y1, fy, x0, x1, fx),
            _lerp8(grad, node, 2, z0, z1, fz, y0, y1, fy, x0, x1, fx))  # fmt: skip


@kernel(inline=True)
def _lit8(codes, node, light, z, y, x):
    """Diffuse and specular factors at (z, y, x) of brick ``node`` of a stack of normal
    code volumes (:mod:`volpack.render.normals`; a plain volume's is one brick): those
    of the eight corner voxels' codes in the frame's ``light`` table, interpolated
    trilinearly."""
    nz, ny, nx = codes.shape[1], codes.shape[2], codes.shape[3]
    z0, z1, fz, y0, y1, fy, x0, x1, fx = _cell3(nz, ny, nx, z, y, x)
    d000, s000 = light[codes[node, z0, y0, x0], 0], light[codes[node, z0, y0, x0], 1]
    d001, s001 = light[codes[node, z0, y0, x1], 0], light[codes[node, z0, y0, x1], 1]
    d010, s010 = light[codes[node, z0, y1, x0], 0], light[codes[node, z0, y1, x0], 1]
    d011, s011 = light[codes[node, z0, y1, x1], 0], light[codes[node, z0, y1, x1], 1]
    d100, s100 = light[codes[node, z1, y0, x0], 0], light[codes[node, z1, y0, x0], 1]
    d101, s101 = light[codes[node, z1, y0, x1], 0], light[codes[node, z1, y0, x1], 1]
    d110, s110 = light[codes[node, z1, y1, x0], 0], light[codes[node, z1, y1, x0], 1]
    d111, s111 = light[codes[node, z1, y1, x1], 0], light[codes[node, z1, y1, x1], 1]
    d00 = d000 + (d001 - d000) * fx
    d01 = d010 + (d011 - d010) * fx
    d10 = d100 + (d101 - d100) * fx
    d11 = d110 + (d111 - d110) * fx
    s00 = s000 + (s001 - s000) * fx
    s01 = s010 + (s011 - s010) * fx
    s10 = s100 + (s101 - s100) * fx
    s11 = s110 + (s111 - s110) * fx
    d0 = d00 + (d01 - d00) * fy
    d1 = d10 + (d11 - d10) * fy
    s0 = s00 + (s01 - s00) * fy
    s1 = s10 + (s11 - s10) * fy
    return d0 + (d1 - d0) * fz, s0 + (s1 - s0) * fz


@kernel(inline=True)
def _lerp8(stack, node, ch, z0, z1, fz, y0, y1, fy, x0, x1, fx):
    """Trilinear interpolation (float32) of channel ``ch`` of brick ``node`` of a 5-D
    stack, indexed through the brick rather than a view of it: a view's reference count
    would be an atomic write per sample on memory every thread shares."""
    c000 = np.float32(stack[node, z0, y0, x0, ch])
    c00 = c000 + (np.float32(stack[node, z0, y0, x1, ch]) - c000) * fx
    c010 = np.float32(stack[node, z0, y1, x0, ch])
    c01 = c010 + (np.float32(stack[node, z0, y1, x1, ch]) - c010) * fx
    c100 = np.float32(stack[node, z1, y0, x0, ch])
    c10 = c100 + (np.float32(stack[node, z1, y0, x1, ch]) - c100) * fx
    c110 = np.float32(stack[node, z1, y1, x0, ch])
    c11 = c110 + (np.float32(stack[node, z1, y1, x1, ch]) - c110) * fx
    c0 = c00 + (c01 - c00) * fy
    c1 = c10 + (c11 - c10) * fy
    return c0 + (c1 - c0) * fz


def _paged(atlas, page, meta, inv, offset, fill, z, y, x):
    """Trilinear sample (float32) of a paged multiresolution volume at level-0 index
    (z, y, x).

    ``page`` maps cells of ``meta[3]`` level-0 voxels (``meta[4]``: its log2, or -1)
    to a node (-1: none, which reads ``fill[0]``); node ``i`` is ``atlas[i]``, voxels of
    level ``l`` with one voxel of its neighbours around them, stored in any dtype the
    plain sampler reads; level-0 position ``p`` is at ``p inv[i] + offset[i]`` in it
    (``inv = 2^-l``; see :func:`page_tuple`).
    """
    node, qz, qy, qx, _ = _page_find(page, meta, inv, offset, atlas.shape[1] - 1, z, y, x)
    if node < 0:
        return np.float32(fill[0])
    n = atlas.shape[1]
    z0, z1, fz, y0, y1, fy, x0, x1, fx = _cell3(n, n, n, qz, qy, qx)
    return _lerp8(atlas, node, 0, z0, z1, fz, y0, y1, fy, x0, x1, fx)


@kernel(inline=True)  # a call passing arrays costs their reference counts
def _page_find(page, meta, inv, offset, b, z, y, x):
    """``(node, qz, qy, qx, inv)``: the node whose page cell holds level-0 position
    (z, y, x) (clamped to the volume; -1: none), the position in its bordered brick of
    ``b + 1`` voxels a side (clamped to it) and the node's ``inv``. A power-of-two cell
    (``meta[4] >= 0``) is found by shifts, not divisions."""
    nz, ny, nx, g, sh = meta[0], meta[1], meta[2], meta[3], meta[4]
    pz = min(max(z, 0.0), nz - 1.0)
    py = min(max(y, 0.0), ny - 1.0)
    px = min(max(x, 0.0), nx - 1.0)
    if sh >= 0:
        cz, cy, cx = int(pz) >> sh, int(py) >> sh, int(px) >> sh
    else:
        cz, cy, cx = int(pz) // g, int(py) // g, int(px) // g
    node = page[min(cz, page.shape[0] - 1), min(cy, page.shape[1] - 1),
                min(cx, page.shape[2] - 1)]  # fmt: skip
    if node < 0:
        return node, 0.0, 0.0, 0.0, 1.0
    s = inv[node]
    qz = min(max(pz * s + offset[node, 0], 0.0), b)
    qy = min(max(py * s + offset[node, 1], 0.0), b)
    qx = min(max(px * s + offset[node, 2], 0.0), b)
    return node, qz, qy, qx, s


def page_tuple(volume, fill: float) -> tuple:
    """The arguments :func:`_paged` samples a :class:`volpack.render.lod.PagedVolume`
    through (the node's voxel grid at level ``l`` has voxel ``j`` centred on level-0
    position ``(j + 0.5) 2^l - 0.5``; the brick's border shifts it by one)."""
    inv = np.ldexp(1.0, -volume.level.astype(np.int64))
    offset = 0.5 * inv[:, None] + 0.5 - volume.origin
    g = int(volume.cell)
    sh = g.bit_length() - 1 if g & (g - 1) == 0 else -1
    meta = np.array([*volume.shape, g, sh], np.int64)
    # the fast march's fixed-point positions: level-0 p sits at (p >> level) + offx
    offx = np.floor(offset * (1 << FRAC) + 0.5).astype(np.int64)
    return (volume.atlas[..., None], volume.page, meta, inv, np.ascontiguousarray(offset, np.float64),
            np.array([fill], np.float64), volume.level.astype(np.int64), offx)  # fmt: skip


def _paged_fixed(atlas, page, meta, level, offx, fill, pz, py, px):
    """:func:`_paged` at fixed-point level-0 position (pz, py, px), in units of
    :func:`value_unit` of the atlas: the page cell by shifts, the node's position by a
    shift and an add, the brick sampled by :func:`trilinear_fixed` (integer lerps on an
    integer atlas)."""
    nz, ny, nx, g, sh = meta[0], meta[1], meta[2], meta[3], meta[4]
    qz = min(max(pz, 0), (nz - 1) << FRAC)
    qy = min(max(py, 0), (ny - 1) << FRAC)
    qx = min(max(px, 0), (nx - 1) << FRAC)
    if sh >= 0:
        cz, cy, cx = qz >> (FRAC + sh), qy >> (FRAC + sh), qx >> (FRAC + sh)
    else:
        cz, cy, cx = (qz >> FRAC) // g, (qy >> FRAC) // g, (qx >> FRAC) // g
    node = page[min(cz, page.shape[0] - 1), min(cy, page.shape[1] - 1),
                min(cx, page.shape[2] - 1)]  # fmt: skip
    if node < 0:
        return fill[0] * value_unit(atlas)
    lv = level[node]
    return trilinear_fixed(atlas, node, (qz >> lv) + offx[node, 0], (qy >> lv) + offx[node, 1],
                           (qx >> lv) + offx[node, 2])  # fmt: skip


_paged_fixed_kernel = kernel(_paged_fixed, inline=True)


_paged_kernel = kernel(_paged, inline=True)


def sample(vol, z, y, x):
    """Trilinear sample of a volume: a 3-D array, or a paged volume tuple (see
    :func:`_paged`); in kernels the choice is made at compile time."""
    if isinstance(vol, tuple):
        return _paged(*vol[:6], z, y, x)
    return _trilinear(vol, z, y, x)


def fixed_sample(vol, pz, py, px):
    """Trilinear sample at fixed-point position (pz, py, px) (:mod:`volpack.render.fixed`),
    float64 in units of :func:`fixed_unit`: integer lerps on an integer array, float32
    on a float one; a paged volume through :func:`_paged_fixed`."""
    if isinstance(vol, tuple):
        return _paged_fixed(vol[0], vol[1], vol[2], vol[6], vol[7], vol[5], pz, py, px)
    return trilinear_fixed(vol, 0, pz, py, px)


def grid_sample(vol, k, lo, hi, bz, by, bx, sz, sy, sx):
    """:func:`fixed_sample` at point ``k`` of a ray's grid ``b + k s`` (fixed point); for a
    3-D array without clamping where ``lo <= k <= hi``, the steps at which the trilinear
    cell lies inside the volume (:func:`volpack.render.fixed.interior`): the same value."""
    pz, py, px = bz + k * sz, by + k * sy, bx + k * sx
    if not isinstance(vol, tuple) and lo <= k <= hi:
        return trilinear_inner(vol, pz, py, px)
    return fixed_sample(vol, pz, py, px)


def interior_sample(vol, pz, py, px):
    """:func:`fixed_sample` at a position whose trilinear cell lies inside the volume
    (see :func:`grid_sample`): for a 3-D array without clamping, the same value."""
    if isinstance(vol, tuple):
        return fixed_sample(vol, pz, py, px)
    return trilinear_inner(vol, pz, py, px)


def fixed_unit(vol):
    """What :func:`fixed_sample` scales a value of ``vol`` by."""
    return value_unit(vol[0] if isinstance(vol, tuple) else vol)


def grad_ndv(vol, grad, z, y, x, gscale, vz, vy, vx, gmin):
    """``|n.v|`` from precomputed gradients at (z, y, x) inside ``[0, n - 1]`` (-1 where
    the gradient vanishes): ``grad`` is the gradient volume of a 3-D array, or for a
    paged volume the gradient bricks of its nodes (:func:`_paged_ndv`)."""
    if isinstance(vol, tuple):
        return _paged_ndv(vol[1], vol[2], vol[3], vol[4], grad, z, y, x, gscale, vz, vy, vx, gmin)
    return _ndv(grad, 0, z, y, x, gscale, vz, vy, vx, gmin, 1.0)


def _paged_ndv(page, meta, inv, offset, grad, z, y, x, gscale, vz, vy, vx, gmin):
    """:func:`_ndv` from the gradient brick of the node holding (z, y, x): central
    differences of the node's voxels at its level, scaled to level-0 units."""
    node, qz, qy, qx, s = _page_find(page, meta, inv, offset, grad.shape[1] - 1, z, y, x)
    if node < 0:
        return -1.0
    return _ndv(grad, node, qz, qy, qx, gscale, vz, vy, vx, gmin, s)


_paged_ndv_kernel = kernel(_paged_ndv, inline=True)


def lit_codes(vol, codes, light, z, y, x):
    """:func:`_lit8` at level-0 position (z, y, x): ``codes`` is the stack of one code
    volume of a 3-D array, or for a paged volume its nodes' code bricks."""
    if isinstance(vol, tuple):
        return _paged_lit(vol[1], vol[2], vol[3], vol[4], codes, light, z, y, x)
    return _lit8(codes, 0, light, z, y, x)


def _paged_lit(page, meta, inv, offset, codes, light, z, y, x):
    """:func:`_lit8` in the code brick of the node holding (z, y, x); unshaded where no
    node does."""
    node, qz, qy, qx, _ = _page_find(page, meta, inv, offset, codes.shape[1] - 1, z, y, x)
    if node < 0:
        return np.float32(1.0), np.float32(0.0)
    return _lit8(codes, node, light, qz, qy, qx)


_paged_lit_kernel = kernel(_paged_lit, inline=True)


def extent(vol):
    """``(nz, ny, nx)`` of a volume in level-0 voxels (array or paged tuple)."""
    if isinstance(vol, tuple):
        return vol[2][0], vol[2][1], vol[2][2]
    return vol.shape


if not JIT_DISABLED:
    from numba import types
    from numba.extending import overload

    @overload(sample, jit_options={"nogil": True})
    def _sample_overload(vol, z, y, x):
        if isinstance(vol, types.BaseTuple):
            return lambda vol, z, y, x: _paged_kernel(
                vol[0], vol[1], vol[2], vol[3], vol[4], vol[5], z, y, x
            )
        return lambda vol, z, y, x: _trilinear(vol, z, y, x)

    @overload(fixed_sample, jit_options={"nogil": True})
    def _fixed_sample_overload(vol, pz, py, px):
        if isinstance(vol, types.BaseTuple):
            return lambda vol, pz, py, px: _paged_fixed_kernel(
                vol[0], vol[1], vol[2], vol[6], vol[7], vol[5], pz, py, px
            )
        return lambda vol, pz, py, px: trilinear_fixed(vol, 0, pz, py, px)

    @overload(grid_sample, jit_options={"nogil": True}, inline="always")
    def _grid_sample_overload(vol, k, lo, hi, bz, by, bx, sz, sy, sx):
        if isinstance(vol, types.BaseTuple):  # pages: no interior shortcut
            return lambda vol, k, lo, hi, bz, by, bx, sz, sy, sx: fixed_sample(
                vol, bz + k * sz, by + k * sy, bx + k * sx
            )

        def inner_or_clamped(vol, k, lo, hi, bz, by, bx, sz, sy, sx):
            pz, py, px = bz + k * sz, by + k * sy, bx + k * sx
            if lo <= k and k <= hi:
                return trilinear_inner(vol, pz, py, px)
            return trilinear_fixed(vol, 0, pz, py, px)

        return inner_or_clamped

    @overload(interior_sample, jit_options={"nogil": True}, inline="always")
    def _interior_sample_overload(vol, pz, py, px):
        if isinstance(vol, types.BaseTuple):  # pages: no interior shortcut
            return lambda vol, pz, py, px: fixed_sample(vol, pz, py, px)
        return lambda vol, pz, py, px: trilinear_inner(vol, pz, py, px)

    @overload(fixed_unit, jit_options={"nogil": True})
    def _fixed_unit_overload(vol):
        if isinstance(vol, types.BaseTuple):
            return lambda vol: value_unit(vol[0])
        return lambda vol: value_unit(vol)

    @overload(lit_codes, jit_options={"nogil": True})
    def _lit_codes_overload(vol, codes, light, z, y, x):
        if isinstance(vol, types.BaseTuple):
            return lambda vol, codes, light, z, y, x: _paged_lit_kernel(
                vol[1], vol[2], vol[3], vol[4], codes, light, z, y, x
            )
        return lambda vol, codes, light, z, y, x: _lit8(codes, 0, light, z, y, x)

    @overload(extent, jit_options={"nogil": True})
    def _extent_overload(vol):
        if isinstance(vol, types.BaseTuple):
            return lambda vol: (vol[2][0], vol[2][1], vol[2][2])
        return lambda vol: (vol.shape[0], vol.shape[1], vol.shape[2])

    @overload(grad_ndv, jit_options={"nogil": True})
    def _grad_ndv_overload(vol, grad, z, y, x, gscale, vz, vy, vx, gmin):
        if isinstance(vol, types.BaseTuple):
            return lambda vol, grad, z, y, x, gscale, vz, vy, vx, gmin: _paged_ndv_kernel(
                vol[1], vol[2], vol[3], vol[4], grad, z, y, x, gscale, vz, vy, vx, gmin
            )
        return lambda vol, grad, z, y, x, gscale, vz, vy, vx, gmin: _ndv(
            grad, 0, z, y, x, gscale, vz, vy, vx, gmin, 1.0
        )


@kernel
def _trilinear4(rgba, z, y, x, out):
    nz, ny, nx = rgba.shape[0], rgba.shape[1], rgba.shape[2]
    z0, z1, fz = _cell(z, nz)
    y0, y1, fy = _cell(y, ny)
    x0, x1, fx = _cell(x, nx)
    for ch in range(4):
        c00 = rgba[z0, y0, x0, ch] + (rgba[z0, y0, x1, ch] - rgba[z0, y0, x0, ch]) * fx
        c01 = rgba[z0, y1, x0, ch] + (rgba[z0, y1, x1, ch] - rgba[z0, y1, x0, ch]) * fx
        c10 = rgba[z1, y0, x0, ch] + (rgba[z1, y0, x1, ch] - rgba[z1, y0, x0, ch]) * fx
        c11 = rgba[z1, y1, x0, ch] + (rgba[z1, y1, x1, ch] - rgba[z1, y1, x0, ch]) * fx
        c0 = c00 + (c01 - c00) * fy
        c1 = c10 + (c11 - c10) * fy
        out[ch] = c0 + (c1 - c0) * fz


@kernel(inline=True)
def _ucell(p, n):
    """:func:`_cell` with unsigned indices and a float32 weight (table look-ups)."""
    return _clamp_cell(p, n)


@kernel
def _lookup1(tab, x, out):
    """Linear lookup of the (n, 4) table at fractional index ``x``."""
    i0, i1, f = _ucell(x, tab.shape[0])
    for ch in range(4):
        a = tab[i0, ch]
        out[ch] = a + (tab[i1, ch] - a) * f


@kernel
def _lookup2(tab, xf, xb, out):
    """Bilinear lookup of the (n, n, k) table at fractional indices (front, back)."""
    n = tab.shape[0]
    i0, i1, fi = _ucell(xf, n)
    j0, j1, fj = _ucell(xb, n)
    for ch in range(tab.shape[2]):
        a = tab[i0, j0, ch] + (tab[i0, j1, ch] - tab[i0, j0, ch]) * fj
        b = tab[i1, j0, ch] + (tab[i1, j1, ch] - tab[i1, j0, ch]) * fj
        out[ch] = a + (b - a) * fi


@kernel(inline=True)
def _nearest(p, n):
    """The table entry nearest fractional index ``p`` (clamped to ``[0, n - 1]``): the
    clamp after the conversion, in integers (the same entry as clamping ``p`` first, two
    float operations fewer on the path from a sample to its look-up)."""
    return np.uint64(min(max(np.int64(p + 0.5), np.int64(0)), np.int64(n - 1)))


@kernel
def _lookup2_nearest(tab, xf, xb, out):
    """:func:`_lookup2` at the nearest entry (see :data:`NEAREST_STEP`)."""
    n = tab.shape[0]
    ii = _nearest(xf, n)
    jj = _nearest(xb, n)
    for ch in range(tab.shape[2]):
        out[ch] = tab[ii, jj, ch]


@kernel
def _normal(vol, grad, has_grad, z, y, x, gscale, vz, vy, vx, gmin):
    """Unit world gradient at (z, y, x) turned towards the eye, and ``|n.v|``.

    The gradient is the central difference (one voxel either way) of the trilinear
    field; with ``has_grad`` it is read from the per-voxel central differences in
    ``grad`` (:func:`volpack.render.prepared.gradient_volume`, as a stack of one), the same
    thing inside ``[0, n - 1]``, at three trilinear look-ups fewer (in the half-voxel
    shell outside, where positions are clamped, it is taken on the fly as without it).
    ``(0, 0, 0, -1)`` where the gradient vanishes.
    """
    if has_grad and (0.0 <= z <= grad.shape[1] - 1 and 0.0 <= y <= grad.shape[2] - 1
                     and 0.0 <= x <= grad.shape[3] - 1):  # fmt: skip
        g0, g1, g2 = _trilinear3(grad, 0, z, y, x)
        gz = g0 * gscale[0]
        gy = g1 * gscale[1]
        gx = g2 * gscale[2]
    else:
        gz, gy, gx = _fly_gradient(vol, z, y, x, gscale)
    g = math.sqrt(gz * gz + gy * gy + gx * gx)
    if g <= gmin:
        return 0.0, 0.0, 0.0, -1.0
    d = (gz * vz + gy * vy + gx * vx) / g
    if d < 0.0:  # two-sided
        g = -g
        d = -d
    return gz / g, gy / g, gx / g, d


@kernel
def _fly_gradient(vol, z, y, x, gscale):
    """World gradient at (z, y, x) by central differences of six samples."""
    gz = (sample(vol, z + 1.0, y, x) - sample(vol, z - 1.0, y, x)) * gscale[0]
    gy = (sample(vol, z, y + 1.0, x) - sample(vol, z, y - 1.0, x)) * gscale[1]
    gx = (sample(vol, z, y, x + 1.0) - sample(vol, z, y, x - 1.0)) * gscale[2]
    return gz, gy, gx


@kernel
def _fly_ndv(vol, z, y, x, gscale, vz, vy, vx, gmin):
    """``|n.v|`` from :func:`_fly_gradient` (-1 where the gradient vanishes)."""
    gz, gy, gx = _fly_gradient(vol, z, y, x, gscale)
    g = math.sqrt(gz * gz + gy * gy + gx * gx)
    if g <= gmin:
        return -1.0
    return abs(gz * vz + gy * vy + gx * vx) / g


@kernel
def _headlight(vol, grad, has_grad, z, y, x, gscale, vz, vy, vx, gmin):
    """|n.v| for the world gradient at (z, y, x); -1 where the gradient vanishes."""
    return _normal(vol, grad, has_grad, z, y, x, gscale, vz, vy, vx, gmin)[3]


@kernel
def _box_hit(oz, oy, ox, dz, dy, dx, nz, ny, nx):
    """Entry and exit ``t`` of the ray with the box ``[-0.5, n-0.5]``; (1, 0) on a miss."""
    az, bz = _slab(oz, dz, nz)
    ay, by = _slab(oy, dy, ny)
    ax, bx = _slab(ox, dx, nx)
    t0 = max(az, ay, ax)
    t1 = min(bz, by, bx)
    if not t0 <= t1:  # a miss (or a parallel ray outside a slab)
        return 1.0, 0.0
    return t0, t1


@kernel(inline=True)
def _slab(o, d, n):
    """``t`` interval of the ray ``o + t d`` inside ``[-0.5, n - 0.5]`` along one axis
    (everything when it runs parallel inside, (inf, -inf) when parallel outside)."""
    lo = -0.5
    hi = n - 0.5
    if d == 0.0:
        if o < lo or o > hi:
            return np.inf, -np.inf
        return -np.inf, np.inf
    a = (lo - o) / d
    b = (hi - o) / d
    return min(a, b), max(a, b)


@kernel(inline=True)
def _exact_log2(n):
    """``log2(n)`` when ``n >= 1`` is a power of two, else -1 (one count-leading-zeros)."""
    sh = 63 - leading_zeros(np.uint64(n))
    return sh if (1 << sh) == n else -1


@kernel(inline=True)
def _brick_of(p, n, brick, sh):
    """Brick index along one axis of position ``p`` clamped to ``[0, n - 1]``."""
    q = int(min(max(p, 0.0), n - 1.0))
    return q >> sh if sh >= 0 else q // brick


@kernel(inline=True)
def _brick_exit(pz, py, px, oz, oy, ox, dz, dy, dx, nz, ny, nx, leap, brick):
    """(leap value, exit t) at the (clamped) point p: ``leap`` of its brick (k >= 1:
    empty, with every brick within Chebyshev distance k - 1 empty too; k <= -1:
    visible, every brick within -k - 1 visible too) and the ``t`` where the ray leaves
    that cube of bricks around it."""
    nbz, nby, nbx = leap.shape
    sh = _exact_log2(brick)  # a shift, not a division, for power-of-two bricks
    bz = min(_brick_of(pz, nz, brick, sh), nbz - 1)
    by = min(_brick_of(py, ny, brick, sh), nby - 1)
    bx = min(_brick_of(px, nx, brick, sh), nbx - 1)
    lv = leap[bz, by, bx]
    r = abs(lv) - 1 if lv != 0 else 0
    te = min(_axis_exit(bz, nbz, oz, dz, r, brick), _axis_exit(by, nby, oy, dy, r, brick),
             _axis_exit(bx, nbx, ox, dx, r, brick))  # fmt: skip
    return lv, te


@kernel(inline=True)
def _axis_exit(b, nb, o, d, r, brick):
    """``t`` where the ray ``o + t d`` leaves bricks ``b - r .. b + r`` along one axis
    (inf when that side is the volume's edge or the ray runs parallel)."""
    if d > 0.0 and b + r < nb - 1:
        return ((b + r + 1) * brick - o) / d
    if d < 0.0 and b - r > 0:
        return ((b - r) * brick - o) / d
    return np.inf


@kernel(inline=True)
def ray_at(origins, dirs, r, c):
    """Origin and direction ``(oz, oy, ox, dz, dy, dx)`` of the ray of pixel ``(r, c)``."""
    return (
        origins[r, c, 0], origins[r, c, 1], origins[r, c, 2], dirs[r, c, 0], dirs[r, c, 1],
        dirs[r, c, 2],
    )  # fmt: skip


@kernel(inline=True)
def _over(ar, ag, ab, aa, cr, cg, cb, a, f, spec):
    """Composite a segment behind the pre-multiplied ``(ar, ag, ab, aa)`` so far: its
    colour times the diffuse factor ``f`` plus the specular ``spec``, opacity ``a``."""
    wgt = 1.0 - aa
    r = ar + wgt * (cr * f + spec)
    g = ag + wgt * (cg * f + spec)
    b = ab + wgt * (cb * f + spec)
    return r, g, b, aa + wgt * a


@kernel(inline=True)
def _complete(ar, ag, ab, aa, pr, pg, pb, a):
    """End a ray that early termination stops, ``(ar, ag, ab, aa)`` composited so far:
    the transmittance left, ``1 - aa`` (up to ``1 - ert``), is given the colour of the
    last segment (premultiplied ``(pr, pg, pb)``, opacity ``a > 0``), as if the ray went
    on through more of the same, rather than black. A ray stops wherever its opacity
    happens to cross ``ert``: a step of 0.5 overshoots to 0.997 where one of 0.125 stops
    at 0.990, so leaving the rest black made the image depend on the step by up to
    ``1 - ert`` of the colour (most of the gap between the step-0.5 and the step-0.125
    images of opaque transfer functions); the completed image is also nearer the one
    without termination."""
    rem = (1.0 - aa) / a
    return ar + rem * pr, ag + rem * pg, ab + rem * pb, 1.0


@kernel
def _ray_span(oz, oy, ox, dz, dy, dx, nz, ny, nx, vscale, step):
    """``(tnear, tfar, nseg, vz, vy, vx)`` of one ray: its part inside the box from the
    eye on, its number of segments (0 when it misses) and the unit view vector (towards
    the eye) in world space."""
    tnear, tfar = _box_hit(oz, oy, ox, dz, dy, dx, nz, ny, nx)
    if tnear < 0.0:
        tnear = 0.0
    if not (tfar > tnear and tfar < np.inf):  # NaN or unbounded rays index nothing
        return tnear, tfar, 0, 0.0, 0.0, 0.0
    vz, vy, vx = -dz * vscale[0], -dy * vscale[1], -dx * vscale[2]
    vn = math.sqrt(vz * vz + vy * vy + vx * vx)
    nseg = int(math.ceil((tfar - tnear) / step))
    return tnear, tfar, max(nseg, 1), vz / vn, vy / vn, vx / vn


@kernel(inline=True)
def _leap(i, t0, tnear, tfar, step, next_check, oz, oy, ox, dz, dy, dx, nz, ny, nx, leap, brick):
    """Empty-space test at segment ``i`` (starting at ``t0``): ``(state, i, next_check)``
    with state 0 (march segment ``i``), 1 (jumped to segment ``i``, test again) or 2
    (the ray leaves the volume through empty space)."""
    lv, te = _brick_exit(
        oz + t0 * dz, oy + t0 * dy, ox + t0 * dx, oz, oy, ox, dz, dy, dx, nz, ny, nx, leap, brick
    )
    if lv <= 0:
        return 0, i, te  # the ray stays among visible bricks until te: no test till then
    if te >= tfar:
        return 2, i, next_check
    inext = int(math.floor((te - tnear - 1e-7) / step))
    if inext > i:  # segment inext straddles the exit: it is marched, untested
        return 1, inext, te
    return 0, i, next_check


@kernel(inline=True)
def _fixed_brick(p, n, nb, brick, sh):
    """Brick index along one axis of fixed-point position ``p`` clamped to ``[0, n - 1]``
    (a shift when ``brick`` is ``2^sh``)."""
    q = min(max(p, np.int64(0)), np.int64(n - 1) << FRAC)
    b = q >> (FRAC + sh) if sh >= 0 else (q >> FRAC) // brick
    return min(b, nb - 1)


@kernel(inline=True)
def _fixed_exit(b, nb, p, s, inv, r, brick):
    """Steps (a float, ``inv = 1 / s``) from fixed-point position ``p`` to the plane where
    a ray of stride ``s`` leaves bricks ``b - r .. b + r`` along one axis (inf when that
    side is the volume's edge or the ray runs parallel)."""
    if s > 0 and b + r < nb - 1:
        return np.float64((np.int64((b + r + 1) * brick) << FRAC) - p) * inv
    if s < 0 and b - r > 0:
        return np.float64((np.int64((b - r) * brick) << FRAC) - p) * inv
    return np.inf


@kernel(inline=True)
def _leap_fixed(i, nseg, pz, py, px, sz, sy, sx, iz, iy, ix, nz, ny, nx, leap, brick, sh):
    """:func:`_leap` for the fast march, in its fixed-point positions: segment ``i``
    starts at (pz, py, px), the next at ``+ (sz, sy, sx)`` (``iz = 1 / sz``...).
    Returns ``(state, i, next test)``: the brick by shifts, the cube's exit in steps by one
    multiply an axis (no division), the last segment still starting inside it rounded
    down (1e-6 step: a jump may stop one segment short, never past one that shows). A
    ray leaves through empty space only when even segment ``nseg + 1`` would start in
    the cube, so the shorter last segment is never skipped on a rounding."""
    nbz, nby, nbx = leap.shape
    bz = _fixed_brick(pz, nz, nbz, brick, sh)
    by = _fixed_brick(py, ny, nby, brick, sh)
    bx = _fixed_brick(px, nx, nbx, brick, sh)
    lv = leap[bz, by, bx]
    r = abs(lv) - 1
    x = min(_fixed_exit(bz, nbz, pz, sz, iz, r, brick), _fixed_exit(by, nby, py, sy, iy, r, brick),
            _fixed_exit(bx, nbx, px, sx, ix, r, brick), nseg + 2.0)  # fmt: skip
    last = i + int(math.floor(x - 1e-6))  # the last segment starting in the cube
    if lv <= 0:
        return 0, i, max(last + 1, i + 1)  # among visible bricks: no test till then
    if last > nseg:
        return 2, i, 0
    last = min(last, nseg - 1)
    if last > i:  # marched, untested: it may straddle the exit
        return 1, last, last + 1
    return 0, i, i + 1


@kernel
def _leap_kernel(empty, out):
    """The leap map: on an empty brick its Chebyshev distance (in bricks) to the nearest
    visible one, on a visible brick minus its distance to the nearest empty one (a
    large value where there is none of the other kind)."""
    far_vis = np.empty(empty.shape, np.int32)
    far_empty = np.empty(empty.shape, np.int32)
    _chebyshev(empty, far_vis)
    _chebyshev(~empty, far_empty)
    for z in range(empty.shape[0]):
        for y in range(empty.shape[1]):
            for x in range(empty.shape[2]):
                out[z, y, x] = far_vis[z, y, x] if empty[z, y, x] else -far_empty[z, y, x]


@kernel
def _chebyshev(mask, out):
    """Chebyshev distance (in bricks) of each True brick to the nearest False one, 0 on
    False ones: two raster passes, forward over the 13 neighbours already passed and
    backward over the other 13 (the chamfer masks, exact for this metric), on a copy
    padded with a value that never lowers a distance (no bounds tests: 3-4x faster
    than the whole 26-neighbourhood in both passes with them, the same numbers)."""
    nbz, nby, nbx = mask.shape
    big = nbz + nby + nbx + 1
    d = np.full((nbz + 2, nby + 2, nbx + 2), big, np.int32)
    for z in range(nbz):
        for y in range(nby):
            for x in range(nbx):
                d[z + 1, y + 1, x + 1] = big if mask[z, y, x] else 0
    for rev in range(2):
        s = -1 if rev else 1  # the passed side: z - s, then y - s in the plane, x - s
        for zz in range(nbz):
            z = nbz - zz if rev else zz + 1
            for yy in range(nby):
                y = nby - yy if rev else yy + 1
                for xx in range(nbx):
                    x = nbx - xx if rev else xx + 1
                    v = d[z, y, x]
                    if v == 0:
                        continue
                    m = d[z, y, x - s]
                    for dx in range(-1, 2):
                        m = min(m, d[z, y - s, x + dx])
                    for dy in range(-1, 2):
                        for dx in range(-1, 2):
                            m = min(m, d[z - s, y + dy, x + dx])
                    d[z, y, x] = min(v, m + 1)
    for z in range(nbz):
        for y in range(nby):
            for x in range(nbx):
                out[z, y, x] = d[z + 1, y + 1, x + 1]


@kernel
def _render_kernel(
    vol,
    grad,
    has_grad,
    rgba,
    origins,
    dirs,
    rows,
    mode,
    has_vol,
    post_tab,
    pre2d,
    subs,
    refine,
    iso2d,
    iso_vals,
    has_iso,
    lo,
    scale,
    step,
    leap,
    brick,
    skip,
    ert,
    shade,
    shading,
    gscale,
    vscale,
    gmin,
    out,
    row_samples,
):
    nz, ny, nx = extent(vol)
    w = out.shape[1]
    niso = iso_vals.shape[0]
    ka, kd, ks, shin = shading[0], shading[1], shading[2], shading[3]
    nsub = int(refine[0])
    a_ref = refine[1]
    near = refine[2] > 0.0
    bend_min = refine[3]
    clip = refine[5] > 0.0  # tables narrower than the data (NARROW_SHARE)
    cmin = refine[6]  # CLIP_MIN
    top = pre2d.shape[0] - 1.0
    need_ends = mode == 2 or has_iso
    for k in range(rows.shape[0]):
        r = rows[k]
        c4 = np.zeros(7, dtype=np.float32)
        count = 0
        for c in range(w):
            oz, oy, ox, dz, dy, dx = ray_at(origins, dirs, r, c)
            tnear, tfar, nseg, vz, vy, vx = _ray_span(
                oz, oy, ox, dz, dy, dx, nz, ny, nx, vscale, step
            )
            if nseg == 0:
                continue
            ar = 0.0
            ag = 0.0
            ab = 0.0
            aa = 0.0
            sf = 0.0
            sp_ = math.nan  # the front sample of the segment before (NaN: not known)
            have_front = False
            # front normal of the segment, carried over from the last one's back
            nfz, nfy, nfx, lf = 0.0, 0.0, 0.0, -1.0
            have_nf = False
            next_check = -1.0  # ray parameter of the next empty-brick test
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
                        have_nf = False
                        sp_ = math.nan
                        continue
                t1 = min(t0 + step, tfar)
                seglen = t1 - t0
                if seglen <= 0.0:
                    break
                sb = 0.0
                if need_ends:
                    if not have_front:
                        sf = sample(vol, oz + t0 * dz, oy + t0 * dy, ox + t0 * dx)
                    sb = sample(vol, oz + t1 * dz, oy + t1 * dy, ox + t1 * dx)
                    have_front = True
                tm = 0.5 * (t0 + t1)
                count += 1
                er, eg, eb, ea = 0.0, 0.0, 0.0, 0.0  # the last composite of this segment
                # isosurface first (it lies inside the segment, in front of what follows)
                if has_iso:
                    xf = (sf - lo) * scale
                    xb = (sb - lo) * scale
                    m = iso2d.shape[0]
                    fi = int(math.floor(min(max(xf, 0.0), m - 1.0) + 0.5))
                    bi = int(math.floor(min(max(xb, 0.0), m - 1.0) + 0.5))
                    ia = iso2d[fi, bi, 3]
                    if ia > 0.0:
                        ip = 0.5
                        if sb > sf:
                            for q in range(niso):
                                if iso_vals[q] > sf and iso_vals[q] <= sb:
                                    ip = (iso_vals[q] - sf) / (sb - sf)
                                    break
                        elif sb < sf:
                            for q in range(niso - 1, -1, -1):
                                if iso_vals[q] < sf and iso_vals[q] >= sb:
                                    ip = (iso_vals[q] - sf) / (sb - sf)
                                    break
                        th = t0 + ip * seglen
                        f = 1.0
                        spec = 0.0
                        if shade > 0:
                            ndv = _headlight(
                                vol, grad, has_grad, oz + th * dz, oy + th * dy, ox + th * dx,
                                gscale, vz, vy, vx, gmin,
                            )  # fmt: skip
                            if ndv >= 0.0:
                                f = ka + kd * ndv
                                spec = ks * ndv**shin
                        # the table colour is pre-multiplied
                        er = iso2d[fi, bi, 0] * f + spec * ia
                        eg = iso2d[fi, bi, 1] * f + spec * ia
                        eb = iso2d[fi, bi, 2] * f + spec * ia
                        ea = ia
                        ar, ag, ab, aa = _over(ar, ag, ab, aa, er, eg, eb, ea, 1.0, 0.0)
                if has_vol:
                    if mode == 0:
                        s = sample(vol, oz + tm * dz, oy + tm * dy, ox + tm * dx)
                        _lookup1(post_tab, (s - lo) * scale, c4)
                    elif mode == 1:
                        _trilinear4(rgba, oz + tm * dz, oy + tm * dy, ox + tm * dx, c4)
                    elif near:
                        _lookup2_nearest(pre2d, (sf - lo) * scale, (sb - lo) * scale, c4)
                    else:
                        _lookup2(pre2d, (sf - lo) * scale, (sb - lo) * scale, c4)
                    clipped = False
                    if mode == 2 and clip and c4[3] > 0.0:
                        xf = (sf - lo) * scale
                        xb = (sb - lo) * scale
                        if min(xf, xb) < 0.0 or max(xf, xb) > top:  # as in _march
                            m = nsub if seglen == step else 1
                            if m > 1 and _faint_cut(pre2d, xf, xb, top, 1.0 - aa, cmin):
                                m = 1
                            _clip_into(vol, pre2d, subs[max(m - 2, 0)], m, oz, oy, ox, dz, dy,
                                       dx, t0, step, lo, scale, xf, xb, top, c4)  # fmt: skip
                            count += m - 1
                            clipped = True
                    # one piece, or (refinement, as in _march) m sub-segments of an
                    # optically thick segment through the table of their length
                    npieces = 1
                    hq = seglen
                    if (mode == 2 and nsub > 1 and c4[3] > 0.0 and (1.0 - aa) * c4[3] > a_ref
                            and i < nseg - 1 and not clipped):  # fmt: skip
                        npieces = sub_count(abs(sb - 2.0 * sf + sp_) * scale, bend_min, nsub)
                        hq = step / npieces
                    s_prev = sf
                    for q in range(npieces):
                        p0 = t0 + q * hq
                        p1 = t1 if q == npieces - 1 else p0 + hq
                        if npieces > 1:
                            sq = sb
                            if q < npieces - 1:
                                sq = sample(vol, oz + p1 * dz, oy + p1 * dy, ox + p1 * dx)
                            _lookup2(subs[npieces - 2], (s_prev - lo) * scale,
                                     (sq - lo) * scale, c4)  # fmt: skip
                            s_prev = sq
                        a = c4[3]
                        lit_now = False
                        if a > 0.0:
                            if npieces == 1 and seglen < step:  # last, shorter segment
                                a2 = 1.0 - (1.0 - min(a, 1.0)) ** (seglen / step)
                                g = a2 / a
                                for ch in (0, 1, 2, 4, 5, 6):
                                    c4[ch] *= g
                                a = a2
                            f = 1.0
                            spec = 0.0
                            if shade == 2:
                                # pre-integrated lighting: n.l linear from front to back
                                if not have_nf:
                                    nfz, nfy, nfx, lf = _normal(
                                        vol, grad, has_grad, oz + p0 * dz, oy + p0 * dy,
                                        ox + p0 * dx, gscale, vz, vy, vx, gmin,
                                    )  # fmt: skip
                                qbz, qby, qbx, lb = _normal(
                                    vol, grad, has_grad, oz + p1 * dz, oy + p1 * dy, ox + p1 * dx,
                                    gscale, vz, vy, vx, gmin,
                                )  # fmt: skip
                                lit_now = True
                                if lf >= 0.0 or lb >= 0.0:
                                    l0 = lf if lf >= 0.0 else lb
                                    l1 = lb if lb >= 0.0 else lf
                                    csum = c4[0] + c4[1] + c4[2]
                                    wb = 0.5
                                    if csum > 0.0:
                                        wb = (c4[4] + c4[5] + c4[6]) / csum
                                    mz = (1.0 - wb) * nfz + wb * qbz
                                    my = (1.0 - wb) * nfy + wb * qby
                                    mx = (1.0 - wb) * nfx + wb * qbx
                                    mn = math.sqrt(mz * mz + my * my + mx * mx)
                                    if lf < 0.0 or lb < 0.0 or mn <= 1e-12:
                                        ls = l0 if lf >= 0.0 else l1
                                    else:
                                        ls = abs(mz * vz + my * vy + mx * vx) / mn
                                    spec = ks * ls**shin * a
                                    for ch in range(3):
                                        cb = c4[4 + ch]
                                        c4[ch] = ka * c4[ch] + kd * (l0 * (c4[ch] - cb) + l1 * cb)
                                nfz, nfy, nfx, lf = qbz, qby, qbx, lb
                            elif shade == 1 or shade == 3:
                                # phong: the midpoint; centroid: the emission centroid
                                tc = 0.5 * (p0 + p1)
                                if shade == 3:
                                    csum = c4[0] + c4[1] + c4[2]
                                    if csum > 0.0:
                                        tc = p0 + (c4[4] + c4[5] + c4[6]) / csum * (p1 - p0)
                                ndv = _headlight(
                                    vol, grad, has_grad, oz + tc * dz, oy + tc * dy, ox + tc * dx,
                                    gscale, vz, vy, vx, gmin,
                                )  # fmt: skip
                                if ndv >= 0.0:
                                    f = ka + kd * ndv
                                    spec = ks * ndv**shin * a
                            er, eg, eb, ea = c4[0] * f + spec, c4[1] * f + spec, c4[2] * f + spec, a
                            ar, ag, ab, aa = _over(ar, ag, ab, aa, er, eg, eb, ea, 1.0, 0.0)
                        have_nf = lit_now
                        if aa > ert:
                            break
                sp_ = sf
                sf = sb
                if aa > ert:
                    if ea > 0.0:
                        ar, ag, ab, aa = _complete(ar, ag, ab, aa, er, eg, eb, ea)
                    break
                i += 1
            out[r, c, 0], out[r, c, 1], out[r, c, 2], out[r, c, 3] = ar, ag, ab, aa
        row_samples[r] = count


# --------------------------------------------------------------------------- fast path
# The common case in a small kernel of its own: every image of a plain volume or a
# multiresolution selection with post-classification or pre-integration, unshaded or
# Phong-shaded, and no isosurfaces; everything else goes through _render_kernel. Both
# march the same segments, sample the same positions, use the same tables, leap the
# same empty bricks and composite in the same order, so they give the same image up to
# float rounding (tests/test_render_fast.py holds them to 1e-5). What makes this one
# faster (issue 22, scripts/profile_render.py): only the branches its case needs, so
# the loop keeps its values in registers; the volume read as stored and interpolated in
# float32; the gradient read from the PreparedVolume's gradient volume when there is
# one (for a selection, each node's gradient brick, :mod:`volpack.render.lod`); the
# specular power by repeated squaring when the exponent is a whole number; table
# look-ups returned as values, not written to a scratch array.


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


@kernel(inline=True)
def _bilerp(tab, ch, i0, i1, fi, j0, j1, fj):
    a = tab[i0, j0, ch] + (tab[i0, j1, ch] - tab[i0, j0, ch]) * fj
    b = tab[i1, j0, ch] + (tab[i1, j1, ch] - tab[i1, j0, ch]) * fj
    return a + (b - a) * fi


@kernel(inline=True)
def _ndv(grad, node, z, y, x, gscale, vz, vy, vx, gmin, s):
    """``|n.v|`` from brick ``node`` of the gradient stack (inside ``[0, n - 1]``; -1
    where the gradient vanishes), the gradient scaled by ``s`` as well: :func:`_normal`
    without the normal itself."""
    g0, g1, g2 = _trilinear3(grad, node, z, y, x)
    gz = g0 * (gscale[0] * s)
    gy = g1 * (gscale[1] * s)
    gx = g2 * (gscale[2] * s)
    g = math.sqrt(gz * gz + gy * gy + gx * gx)
    if g <= gmin:
        return -1.0
    return abs(gz * vz + gy * vy + gx * vx) / g


@kernel(inline=True)
def _part(r, g, b, a, f):
    """A pre-integrated piece ``(r, g, b, a)`` (pre-multiplied, over a whole segment)
    over the share ``f`` of its length (the opacity of a scalar range crossed over a
    shorter length: its optical depth times ``f``)."""
    if a <= 0.0 or f <= 0.0:
        return 0.0, 0.0, 0.0, 0.0
    a2 = 1.0 - (1.0 - min(a, 1.0)) ** f
    g2 = a2 / a
    return r * g2, g * g2, b * g2, a2


@kernel
def _clip_chord(tab, xf, xb, top):
    """``(r, g, b, a)`` of a pre-integrated segment whose scalar runs linearly from
    table position ``xf`` to ``xb`` (front to back) where an end lies beyond the table
    ``[0, top]`` (:data:`NARROW_SHARE`): the TF is constant beyond its points, so the
    piece below position 0 takes entry ``(0, 0)`` and the piece above ``top`` entry
    ``(top, top)``, each over its share of the length, and the piece between the
    bilinear entry of the clamped ends over its share; composited in ray order. With
    the tables over the data range no end lies beyond them and this is never called."""
    lo_ = min(xf, xb)
    hi_ = max(xf, xb)
    d = hi_ - lo_
    n = tab.shape[0]
    if d <= 0.0:  # both ends at one position (beyond the table): a constant segment
        k = 0 if xf < 0.0 else n - 1
        return tab[k, k, 0], tab[k, k, 1], tab[k, k, 2], tab[k, k, 3]
    fb = min(max(-lo_ / d, 0.0), 1.0)  # shares of the length below, above, inside
    fa = min(max((hi_ - top) / d, 0.0), 1.0)
    fi = max(1.0 - fb - fa, 0.0)
    i0, i1, fi0 = _ucell(xf, n)
    j0, j1, fj0 = _ucell(xb, n)
    ir, ig, ib, ia = _part(_bilerp(tab, 0, i0, i1, fi0, j0, j1, fj0),
                           _bilerp(tab, 1, i0, i1, fi0, j0, j1, fj0),
                           _bilerp(tab, 2, i0, i1, fi0, j0, j1, fj0),
                           _bilerp(tab, 3, i0, i1, fi0, j0, j1, fj0), fi)  # fmt: skip
    br, bg, bb, ba = _part(tab[0, 0, 0], tab[0, 0, 1], tab[0, 0, 2], tab[0, 0, 3], fb)
    tr, tg, tb, ta = _part(tab[n - 1, n - 1, 0], tab[n - 1, n - 1, 1], tab[n - 1, n - 1, 2],
                           tab[n - 1, n - 1, 3], fa)  # fmt: skip
    if xf > xb:  # descending: above, inside, below
        br, bg, bb, ba, tr, tg, tb, ta = tr, tg, tb, ta, br, bg, bb, ba
    r, g, b, a = br, bg, bb, ba
    w = 1.0 - a
    r, g, b, a = r + w * ir, g + w * ig, b + w * ib, a + w * ia
    w = 1.0 - a
    return r + w * tr, g + w * tg, b + w * tb, a + w * ta


@kernel(inline=True)
def _chord(tab, xp, xq, top):
    """``(r, g, b, a)`` of the chord from table position ``xp`` to ``xq``: bilinear, or
    cut at the table's ends (:func:`_clip_chord`) where it reaches beyond them."""
    if min(xp, xq) < 0.0 or max(xp, xq) > top:
        return _clip_chord(tab, xp, xq, top)
    n = tab.shape[0]
    u0, u1, fu = _ucell(xp, n)
    w0, w1, fw = _ucell(xq, n)
    return (_bilerp(tab, 0, u0, u1, fu, w0, w1, fw), _bilerp(tab, 1, u0, u1, fu, w0, w1, fw),
            _bilerp(tab, 2, u0, u1, fu, w0, w1, fw), _bilerp(tab, 3, u0, u1, fu, w0, w1, fw))


@kernel(inline=True)
def _faint_cut(tab, xf, xb, top, trans, cmin):
    """Whether a segment cut at the tables' ends (from table position ``xf`` to ``xb``)
    keeps its chord: its opacity at its end inside the tables ``[0, top]`` (the diagonal
    entry nearest it), times the pixel's transmittance ``trans``, is under ``cmin``
    (:data:`CLIP_MIN`). A segment with no end inside (from below the tables to above
    them) is sampled again."""
    if cmin <= 0.0:
        return False
    x = xf if 0.0 <= xf <= top else xb
    if not (0.0 <= x <= top):
        return False
    k = int(x + 0.5)
    return trans * tab[k, k, 3] < cmin


@kernel(nrt=False, contract=True)
def _clip_refined(vol, sub2d, pz0, py0, px0, sz, sy, sx, nsub, vs, v0, xf, xb, top):
    """``(r, g, b, a)`` of a full segment of the fast march from table position ``xf``
    to ``xb`` with an end beyond the tables (:func:`_clip_chord`), as ``nsub``
    sub-segments through their table ``sub2d`` (``nsub - 1`` samples more), each cut
    at the tables' ends where it reaches beyond them. Such a segment crosses from a
    fill value or an outlier to the data inside one voxel, where the trilinear field is
    far from straight along the ray (a corner of -9999 beside ones of 20): its chord
    alone put what the TF shows at the wrong depth (storm_u's opaque images 2-4 dB below
    VTK's PSNR; session 37). Lit, if at all, as one segment by the march."""
    r = g = b = a = 0.0
    xp = xf
    for q in range(1, nsub + 1):
        xq = xb
        if q < nsub:
            xq = fixed_sample(vol, pz0 + (q * sz) // nsub, py0 + (q * sy) // nsub,
                              px0 + (q * sx) // nsub) * vs + v0  # fmt: skip
        cr, cg, cb, aq = _chord(sub2d, xp, xq, top)
        wgt = 1.0 - a
        r, g, b, a = r + wgt * cr, g + wgt * cg, b + wgt * cb, a + wgt * aq
        xp = xq
    return r, g, b, a


@kernel
def _clip_into(vol, tab, sub2d, nsub, oz, oy, ox, dz, dy, dx, t0, step, lo, scale, xf, xb, top,
               c4):  # fmt: skip
    """The general kernel's segment with an end beyond the tables, into its look-up
    ``c4``: as the fast march, :func:`_clip_refined` (``nsub`` > 1, samples at the
    positions this kernel samples) or :func:`_clip_chord`; channels 4-6 of lit
    tables, the back-weighted colour, scaled as the colour."""
    if nsub > 1:
        r = g = b = a = 0.0
        xp = xf
        for q in range(1, nsub + 1):
            xq = xb
            if q < nsub:
                tq = t0 + q * (step / nsub)
                xq = (sample(vol, oz + tq * dz, oy + tq * dy, ox + tq * dx) - lo) * scale
            cr, cg, cb, aq = _chord(sub2d, xp, xq, top)
            wgt = 1.0 - a
            r, g, b, a = r + wgt * cr, g + wgt * cg, b + wgt * cb, a + wgt * aq
            xp = xq
    else:
        r, g, b, a = _clip_chord(tab, xf, xb, top)
    if tab.shape[2] > 4:
        c4[4] = c4[4] * (r / c4[0]) if c4[0] > 0.0 else 0.0
        c4[5] = c4[5] * (g / c4[1]) if c4[1] > 0.0 else 0.0
        c4[6] = c4[6] * (b / c4[2]) if c4[2] > 0.0 else 0.0
    c4[0], c4[1], c4[2], c4[3] = r, g, b, a


def _march(
    vol, grad, has_grad, codes, light, frame, u, v, rows, pre, post_tab, pre2d, subs,
    lo, scale, step, leap, brick, skip, ert, shade, shading, gscale, vscale, gmin, clear,
    refine, cols, out, row_cols,
):  # fmt: skip
    """Rays of image rows ``rows``; ``pre``: pre-integrated (else post-classified),
    ``shade``: 0 unshaded, 1 Phong at the segment midpoint from gradients, 2 Phong lit
    through the quantised normal ``codes`` and the frame's ``light`` table
    (:func:`_lit8`; positions clamped to the volume like the samples', so the kernel
    holds no gradient code at all); ``pre`` 2 (a constant too): pre-integrated, and full
    segments of unshaded rays read at nearest entries go through :func:`_near_run`.
    Other arguments as for :func:`_render_kernel`.
    Inlined into one small kernel per (``pre``, ``shade``) pair, where both are
    constants: each kernel's loop holds only its own branch (measured: a third of the
    time per segment on the benchmark's volumes, against one loop testing both).
    ``clear``: table positions ``(below, above)`` outside which every entry a look-up
    reads is zero (:func:`clear_bounds`): a segment with both ends there (a sample, for
    post-classification) skips its look-up, as it would read zero opacity. ``cols``:
    the image columns ``[cols[0], cols[1])`` of those rows (a tile, see
    :func:`_march_specialised`), of which row ``r`` traces only ``[row_cols[r, 0],
    row_cols[r, 1])`` (:meth:`Camera.box_columns`: no ray outside meets the volume's
    box); ``row_cols[r, 2]`` gains the row's segments there (one array for both: a call
    of more than 30 arguments is one numba cannot inline).
    ``refine = (m, threshold)``: a full pre-integrated segment whose share of the
    pixel's opacity, ``(1 - A_acc) A``, exceeds ``threshold`` is marched again as ``k``
    sub-segments through ``subs[k - 2]``, the table for ``step / k``: ``k = m``, or 2
    where the samples show the scalar nearly straight (:func:`sub_count`; see
    :func:`render`, ``refine``); ``m = 1`` never does."""
    nz, ny, nx = extent(vol)
    nsub = int(refine[0])
    a_ref = refine[1]
    near = refine[2] > 0.0
    bend_min = refine[3]
    lean = refine[4] > 0.0
    clip = refine[5] > 0.0  # tables narrower than the data (NARROW_SHARE)
    cmin = refine[6]  # CLIP_MIN
    runs = pre == 2  # a constant: one kernel of its own (_march_specialised)
    cl, ch_ = clear[0], clear[1]
    n_tab = pre2d.shape[0] if pre else post_tab.shape[0]
    top = n_tab - 1.0
    ka, kd, ks, shin = shading[0], shading[1], shading[2], shading[3]
    ishin = int(shin)
    whole = ishin == shin and ishin >= 0
    sh = _exact_log2(brick)
    vs = scale / fixed_unit(vol)  # table position = sample * vs + v0
    v0 = -lo * scale
    for k in range(rows.shape[0]):
        r = rows[k]
        count = 0
        for c in range(max(cols[0], row_cols[r, 0]), min(cols[1], row_cols[r, 1])):
            oz, oy, ox, dz, dy, dx = pixel_ray(frame, u, v, r, c)
            tnear, tfar, nseg, vz, vy, vx = _ray_span(
                oz, oy, ox, dz, dy, dx, nz, ny, nx, vscale, step
            )
            if nseg == 0:
                continue
            # fixed-point positions (volpack.render.fixed): segment end k (pre-
            # integrated) or the midpoint of full segment k (post) at base + k * stride
            t_base = tnear if pre else tnear + 0.5 * step
            bz, by, bx = (to_fixed(oz + t_base * dz), to_fixed(oy + t_base * dy),
                          to_fixed(ox + t_base * dx))  # fmt: skip
            sz, sy, sx = to_fixed(step * dz), to_fixed(step * dy), to_fixed(step * dx)
            # the empty-space test looks at segment starts (post: base is a midpoint)
            lz, ly, lx = bz, by, bx
            if not pre:
                lz, ly, lx = (to_fixed(oz + tnear * dz), to_fixed(oy + tnear * dy),
                              to_fixed(ox + tnear * dx))  # fmt: skip
            iz, iy, ix = 1.0 / sz, 1.0 / sy, 1.0 / sx
            next_k = 0  # the next segment tested for empty space
            i = 0
            if skip:  # tested first, before the rest of the set-up: a ray that crosses
                # only empty space ends here (6 integer divisions fewer)
                state, i, next_k = _leap_fixed(
                    0, nseg, lz, ly, lx, sz, sy, sx, iz, iy, ix, nz, ny, nx, leap, brick, sh
                )  # fmt: skip
                if state == 2:
                    continue  # its pixel stays clear (out is zeroed)
            # the grid points whose trilinear cell lies inside the volume: sampled
            # without clamps (most of a ray; the same values)
            klo_z, khi_z = interior(bz, sz, nz)
            klo_y, khi_y = interior(by, sy, ny)
            klo_x, khi_x = interior(bx, sx, nx)
            klo, khi = max(klo_z, klo_y, klo_x), min(khi_z, khi_y, khi_x)
            ar = 0.0
            ag = 0.0
            ab = 0.0
            aa = 0.0
            xf = 0.0
            i0, i1, fi = _ucell(0.0, n_tab)  # the front's table cell, carried along
            j0, j1, fj = i0, i1, fi
            ii = jj = np.uint64(0)  # the front's and back's nearest entries (near)
            xfront = math.nan  # the segment's front (NaN: the one before is not known)
            xprev = math.nan
            have_front = False
            qr = qg = qb = 0.0  # a clipped segment's colour (_clip_chord)
            while i < nseg:
                if skip and i >= next_k:
                    state, i, next_k = _leap_fixed(
                        i, nseg, lz + i * sz, ly + i * sy, lx + i * sx, sz, sy, sx, iz, iy, ix,
                        nz, ny, nx, leap, brick, sh,
                    )  # fmt: skip
                    if state == 2:
                        break
                    if state == 1:
                        have_front = False
                        xfront = math.nan
                if runs and pre and shade == 0 and near and have_front:
                    # full segments whose back sample is interior and before the next
                    # empty-space test: marched by _near_run (the same values)
                    e = min(nseg - 1, khi)
                    if skip:
                        e = min(e, next_k)
                    if e > i and i + 1 >= klo:
                        i2, ii, xf, xp, ar, ag, ab, aa, done = _near_run(
                            vol, pre2d, bz, by, bx, sz, sy, sx, klo, khi, i, e, tnear, tfar, step,
                            ii, xf, vs, v0, n_tab, cl, ch_, nsub, a_ref, ert, ar, ag, ab, aa,
                        )  # fmt: skip
                        count += i2 - i
                        if i2 > i:  # the front of the segment before the next
                            xfront = xp
                        i = i2
                        if done:
                            break
                        if skip and i >= next_k:
                            continue
                t0 = tnear + i * step
                t1 = min(t0 + step, tfar)
                seglen = t1 - t0
                if seglen <= 0.0:
                    break
                tm = 0.5 * (t0 + t1)
                count += 1
                a = 0.0
                clipped = False
                if pre:
                    if not have_front:
                        # clamped: taken only after a leap, and one inlined sampler
                        # fewer to compile (29 -> 44 -> 32 CPU s for two marches)
                        xf = fixed_sample(vol, bz + i * sz, by + i * sy, bx + i * sx) * vs + v0
                        if near:
                            ii = _nearest(xf, n_tab)
                        else:
                            i0, i1, fi = _ucell(xf, n_tab)
                        have_front = True
                    if seglen < step:  # the back end is the ray's exit
                        xb = fixed_sample(vol, to_fixed(oz + t1 * dz), to_fixed(oy + t1 * dy),
                                          to_fixed(ox + t1 * dx)) * vs + v0  # fmt: skip
                    else:
                        xb = grid_sample(vol, i + 1, klo, khi, bz, by, bx, sz, sy, sx) * vs + v0
                    if near:  # the entry alone; the cells only where a segment is refined
                        jj = _nearest(xb, n_tab)
                        if not ((xf < cl and xb < cl) or (xf > ch_ and xb > ch_)):
                            a = pre2d[ii, jj, 3]
                    else:
                        j0, j1, fj = _ucell(xb, n_tab)
                        if not ((xf < cl and xb < cl) or (xf > ch_ and xb > ch_)):
                            a = _bilerp(pre2d, 3, i0, i1, fi, j0, j1, fj)
                    if clip and a > 0.0 and (min(xf, xb) < 0.0 or max(xf, xb) > top):
                        if (nsub > 1 and seglen == step
                                and not _faint_cut(pre2d, xf, xb, top, 1.0 - aa, cmin)):  # fmt: skip
                            # sampled again: see _clip_refined
                            qr, qg, qb, a = _clip_refined(
                                vol, subs[nsub - 2], bz + i * sz, by + i * sy, bx + i * sx, sz,
                                sy, sx, nsub, vs, v0, xf, xb, top,
                            )  # fmt: skip
                            count += nsub - 1
                        else:
                            qr, qg, qb, a = _clip_chord(pre2d, xf, xb, top)
                        clipped = True
                    xprev, xfront = xfront, xf
                    xf = xb
                else:
                    if seglen < step:
                        xs = fixed_sample(vol, to_fixed(oz + tm * dz), to_fixed(oy + tm * dy),
                                          to_fixed(ox + tm * dx)) * vs + v0  # fmt: skip
                    else:
                        xs = grid_sample(vol, i, klo, khi, bz, by, bx, sz, sy, sx) * vs + v0
                    i0, i1, fi = _ucell(xs, n_tab)
                    j0, j1, fj = i0, i1, fi
                    if not (xs < cl or xs > ch_):
                        a = _lerp2(post_tab, 3, i0, i1, fi)
                if (pre and nsub > 1 and a > 0.0 and (1.0 - aa) * a > a_ref and i < nseg - 1
                        and not clipped):  # fmt: skip
                    # an optically thick segment: m sub-segments, with m - 1 more samples
                    if near:
                        i0, i1, fi = _ucell(xfront, n_tab)
                        j0, j1, fj = _ucell(xf, n_tab)
                    m = sub_count(abs(xf - 2.0 * xfront + xprev), bend_min, nsub)
                    if shade == 0 and lean:  # the same sums, a third of the arguments
                        ar, ag, ab, aa, done = _refined_plain(
                            vol, subs[m - 2], bz + i * sz, by + i * sy, bx + i * sx, sz, sy, sx,
                            m, vs, v0, i0, i1, fi, j0, j1, fj, ert, ar, ag, ab, aa,
                        )  # fmt: skip
                    elif shade == 2 and lean:  # lit through the codes: no gradients
                        ar, ag, ab, aa, done = _refined_lit(
                            vol, codes, light, subs[m - 2], bz + i * sz, by + i * sy, bx + i * sx,
                            sz, sy, sx, m, vs, v0, i0, i1, fi, j0, j1, fj, oz, oy, ox, dz, dy,
                            dx, t0, step, ert, ar, ag, ab, aa,
                        )  # fmt: skip
                    else:
                        ar, ag, ab, aa, done = _refined(
                            vol, grad, has_grad, codes, light, subs, bz + i * sz, by + i * sy,
                            bx + i * sx, sz, sy, sx, m, vs, v0, i0, i1, fi, j0, j1, fj, t0, step,
                            shade, oz, oy, ox, dz, dy, dx, gscale, vz, vy, vx, gmin, shading, ert,
                            ar, ag, ab, aa,
                        )  # fmt: skip
                    count += m - 1
                    if done:
                        break
                elif a > 0.0:  # colour only where there is opacity
                    if clipped:
                        cr, cg, cb = qr, qg, qb
                    elif pre and near:
                        cr, cg, cb = pre2d[ii, jj, 0], pre2d[ii, jj, 1], pre2d[ii, jj, 2]
                    elif pre:
                        cr = _bilerp(pre2d, 0, i0, i1, fi, j0, j1, fj)
                        cg = _bilerp(pre2d, 1, i0, i1, fi, j0, j1, fj)
                        cb = _bilerp(pre2d, 2, i0, i1, fi, j0, j1, fj)
                    else:
                        cr = _lerp2(post_tab, 0, i0, i1, fi)
                        cg = _lerp2(post_tab, 1, i0, i1, fi)
                        cb = _lerp2(post_tab, 2, i0, i1, fi)
                    if seglen < step:  # last, shorter segment
                        a2 = 1.0 - (1.0 - min(a, 1.0)) ** (seglen / step)
                        g = a2 / a
                        cr, cg, cb, a = cr * g, cg * g, cb * g, a2
                    if shade:
                        f, sp = _light_at(
                            shade, vol, grad, has_grad, codes, light, oz + tm * dz, oy + tm * dy,
                            ox + tm * dx, nz, ny, nx, gscale, vz, vy, vx, gmin, ka, kd, ks, shin,
                            ishin, whole,
                        )  # fmt: skip
                        cr, cg, cb = cr * f + sp * a, cg * f + sp * a, cb * f + sp * a
                    wgt = 1.0 - aa
                    ar, ag, ab, aa = ar + wgt * cr, ag + wgt * cg, ab + wgt * cb, aa + wgt * a
                    if aa > ert:
                        ar, ag, ab, aa = _complete(ar, ag, ab, aa, cr, cg, cb, a)
                        break
                i0, i1, fi = j0, j1, fj
                ii = jj
                i += 1
            out[r, c, 0], out[r, c, 1], out[r, c, 2], out[r, c, 3] = ar, ag, ab, aa
        row_cols[r, 2] += count


_march_inline = kernel(_march, inline=True)


@kernel(nrt=False, contract=True)
def _near_run(vol, pre2d, bz, by, bx, sz, sy, sx, klo, khi, i, end, tnear, tfar, step, ii, xf,
              vs, v0, n_tab, cl, ch_, nsub, a_ref, ert, ar, ag, ab, aa):  # fmt: skip
    """Segments ``i .. end - 1`` of the fast march's unshaded, pre-integrated ray read at
    nearest table entries (see :func:`_march`), where each back sample ``k + 1`` is
    interior (:func:`volpack.render.fixed.interior`: ``klo <= k + 1 <= khi``) and no
    empty-space test falls: the
    loop of :func:`_march` computing the same values, with the next segment's back
    sample and table entry taken *before* this segment's branches. Those branches (a
    clear segment or not, a visible one or not) follow the data and are often
    mispredicted; a mispredicted branch discards the work issued after it, so in the
    plain loop the next sample's latency (eight reads, three lerps, the entry) started
    over behind each one. Stops before a segment that is shorter than ``step`` or
    that needs refining (the caller's loop takes it), or after the one that ends the
    ray. Returns ``(i, ii, xf, xp, ar, ag, ab, aa, done)``: the next segment, its
    front's entry and position, the position of the front before (for
    :func:`sub_count`; NaN if no segment was taken), the pixel so far and whether the
    ray ended. Measured on the
    benchmark's semi-transparent MRIs, one thread: the frame 0.86-0.89x."""
    k = i + 1
    xp = math.nan
    pz, py, px = bz + k * sz, by + k * sy, bx + k * sx  # the next back sample's position
    xn = interior_sample(vol, pz, py, px) * vs + v0
    jn = _nearest(xn, n_tab)
    while i < end:
        t0 = tnear + i * step
        if min(t0 + step, tfar) - t0 < step:
            break
        xb, jj = xn, jn
        if i + 1 < end:
            pz, py, px = pz + sz, py + sy, px + sx
            xn = interior_sample(vol, pz, py, px) * vs + v0
            jn = _nearest(xn, n_tab)
        if not ((xf < cl and xb < cl) or (xf > ch_ and xb > ch_)):
            a = pre2d[ii, jj, 3]
            if a > 0.0:
                wgt = 1.0 - aa
                if nsub > 1 and wgt * a > a_ref:
                    break
                cr, cg, cb = pre2d[ii, jj, 0], pre2d[ii, jj, 1], pre2d[ii, jj, 2]
                ar, ag, ab, aa = ar + wgt * cr, ag + wgt * cg, ab + wgt * cb, aa + wgt * a
                if aa > ert:
                    ar, ag, ab, aa = _complete(ar, ag, ab, aa, cr, cg, cb, a)
                    return i + 1, jj, xb, xf, ar, ag, ab, aa, True
        ii, xp, xf = jj, xf, xb
        i += 1
    return i, ii, xf, xp, ar, ag, ab, aa, False


@kernel(nrt=False, contract=True)
def _refined(vol, grad, has_grad, codes, light, subs, pz0, py0, px0, sz, sy, sx, nsub, vs, v0,
             u0, u1, fu, j0, j1, fj, t0, step, shade, oz, oy, ox, dz, dy, dx, gscale, vz, vy,
             vx, gmin, shading, ert, ar, ag, ab, aa):  # fmt: skip
    """A thick segment of the fast march (see :func:`_march`, ``refine``) composited as
    ``nsub`` sub-segments through their table ``subs[nsub - 2]``: from fixed-point
    ``p0`` (the front, in table cell ``u``) by ``nsub - 1`` samples more to the back (cell ``j``). Returns the pixel
    so far and whether it terminated. A call of its own, not inlined: the few segments
    that take it (none on semi-transparent TFs) keep it out of the march's loop, whose
    registers it crowded (measured: the loop without it 5-13 % faster on the
    benchmark's head CT)."""
    nz, ny, nx = extent(vol)
    sub2d = subs[nsub - 2]
    ka, kd, ks, shin = shading[0], shading[1], shading[2], shading[3]
    ishin = int(shin)
    whole = ishin == shin and ishin >= 0
    for q in range(1, nsub + 1):
        w0, w1, fw, aq, cr, cg, cb = _sub_look(vol, sub2d, pz0, py0, px0, sz, sy, sx, q, nsub,
                                               vs, v0, u0, u1, fu, j0, j1, fj)  # fmt: skip
        if aq > 0.0:
            f, sp = 1.0, 0.0
            if shade:
                tq = t0 + (q - 0.5) * (step / nsub)
                f, sp = _light_at(
                    shade, vol, grad, has_grad, codes, light, oz + tq * dz, oy + tq * dy,
                    ox + tq * dx, nz, ny, nx, gscale, vz, vy, vx, gmin, ka, kd, ks, shin,
                    ishin, whole,
                )  # fmt: skip
            ar, ag, ab, aa, done = _lit_over(ar, ag, ab, aa, cr, cg, cb, aq, f, sp, ert)
            if done:
                return ar, ag, ab, aa, True
        u0, u1, fu = w0, w1, fw
    return ar, ag, ab, aa, False


@kernel(inline=True)  # see the docstring's last sentences
def _refined_plain(vol, sub2d, pz0, py0, px0, sz, sy, sx, nsub, vs, v0, u0, u1, fu, j0, j1, fj,
                   ert, ar, ag, ab, aa):  # fmt: skip
    """:func:`_refined` of an unshaded frame (the same sums in the same order), called
    with the table of its ``nsub`` sub-segments alone and nothing of the shading: an
    array passes as its every field, and the shaded call's 43 arguments came to about
    110 values a call, the march's registers saved around it. On small volumes' opaque
    frames refinement took 22-39 % of the CPU, mostly for entering it (two sub-segments
    against none 17-31 ms a 512^2 frame, three against two 3-5 ms); this call took the
    unshaded frames of five of them to 0.91-0.96x, the same images (session 36,
    ``results/render/rend36/``). Inlined into the march since session 39: entering the
    call (the march's registers saved around it) was most of what a refined segment cost
    on engine_u8's opaque frame: two sub-segments 57 ns more than none, a third 21 ns;
    inlined, the opaque unshaded frames of 10 volumes took 0.92-0.98x the CPU, their
    semi-transparent ones 0.99-1.00x, the same images (``results/render/rend39/``).
    :func:`_refined_lit` stays a call (numba cannot inline the dispatch of
    :func:`lit_codes`)."""
    for q in range(1, nsub + 1):
        w0, w1, fw, aq, cr, cg, cb = _sub_look(vol, sub2d, pz0, py0, px0, sz, sy, sx, q, nsub,
                                               vs, v0, u0, u1, fu, j0, j1, fj)  # fmt: skip
        if aq > 0.0:
            ar, ag, ab, aa, done = _sub_over(ar, ag, ab, aa, cr, cg, cb, aq, ert)
            if done:
                return ar, ag, ab, aa, True
        u0, u1, fu = w0, w1, fw
    return ar, ag, ab, aa, False


@kernel(nrt=False, contract=True)
def _refined_lit(vol, codes, light, sub2d, pz0, py0, px0, sz, sy, sx, nsub, vs, v0, u0, u1, fu,
                 j0, j1, fj, oz, oy, ox, dz, dy, dx, t0, step, ert, ar, ag, ab, aa):  # fmt: skip
    """:func:`_refined` of an orthographic Phong frame lit through the quantised normal
    ``codes`` (``shade`` 2; the same sums in the same order), called with the table of
    its ``nsub`` sub-segments and the codes alone: nothing of the gradients, the
    shading constants or the other tables (as :func:`_refined_plain` for unshaded
    frames; session 37)."""
    for q in range(1, nsub + 1):
        w0, w1, fw, aq, cr, cg, cb = _sub_look(vol, sub2d, pz0, py0, px0, sz, sy, sx, q, nsub,
                                               vs, v0, u0, u1, fu, j0, j1, fj)  # fmt: skip
        if aq > 0.0:
            tq = t0 + (q - 0.5) * (step / nsub)
            f, sp = lit_codes(vol, codes, light, oz + tq * dz, oy + tq * dy, ox + tq * dx)
            ar, ag, ab, aa, done = _lit_over(ar, ag, ab, aa, cr, cg, cb, aq, f, sp, ert)
            if done:
                return ar, ag, ab, aa, True
        u0, u1, fu = w0, w1, fw
    return ar, ag, ab, aa, False


@kernel(inline=True)
def _lit_over(ar, ag, ab, aa, cr, cg, cb, aq, f, sp, ert):
    """:func:`_sub_over` of a sub-segment lit by the Phong factors ``(f, sp)``
    (:func:`_light_at`; ``(1, 0)`` leaves it as it is)."""
    return _sub_over(ar, ag, ab, aa, cr * f + sp * aq, cg * f + sp * aq, cb * f + sp * aq, aq,
                     ert)  # fmt: skip


@kernel(inline=True)
def _sub_look(vol, sub2d, pz0, py0, px0, sz, sy, sx, q, nsub, vs, v0, u0, u1, fu, j0, j1, fj):
    """Sub-segment ``q`` of ``nsub`` of a refined segment (:func:`_refined`): the table
    cell of its back end (a sample, or the segment's back cell ``j`` for the last) and
    its opacity and colours (colours 0 where the opacity is)."""
    if q < nsub:
        xq = fixed_sample(vol, pz0 + (q * sz) // nsub, py0 + (q * sy) // nsub,
                          px0 + (q * sx) // nsub) * vs + v0  # fmt: skip
        w0, w1, fw = _ucell(xq, sub2d.shape[0])
    else:
        w0, w1, fw = j0, j1, fj
    aq = _bilerp(sub2d, 3, u0, u1, fu, w0, w1, fw)
    cr = cg = cb = 0.0
    if aq > 0.0:
        cr = _bilerp(sub2d, 0, u0, u1, fu, w0, w1, fw)
        cg = _bilerp(sub2d, 1, u0, u1, fu, w0, w1, fw)
        cb = _bilerp(sub2d, 2, u0, u1, fu, w0, w1, fw)
    return w0, w1, fw, aq, cr, cg, cb


@kernel(inline=True)
def _sub_over(ar, ag, ab, aa, cr, cg, cb, aq, ert):
    """Composite a sub-segment behind the pixel so far; ``(ar, ag, ab, aa, ended)``."""
    wgt = 1.0 - aa
    ar, ag, ab = ar + wgt * cr, ag + wgt * cg, ab + wgt * cb
    aa = aa + wgt * aq
    if aa > ert:
        ar, ag, ab, aa = _complete(ar, ag, ab, aa, cr, cg, cb, aq)
        return ar, ag, ab, aa, True
    return ar, ag, ab, aa, False


@kernel(inline=True)
def _light_at(shade, vol, grad, has_grad, codes, light, pz, py, px, nz, ny, nx, gscale,
              vz, vy, vx, gmin, ka, kd, ks, shin, ishin, whole):  # fmt: skip
    """The fast march's Phong factors at (pz, py, px): ``(f, s)``, the colour times
    ``f`` plus ``s`` times the opacity (``shade`` 1: from gradients, 2: from the
    quantised normal ``codes``; see :func:`_march`)."""
    if shade == 2:
        return lit_codes(vol, codes, light, pz, py, px)
    if has_grad and (0.0 <= pz <= nz - 1 and 0.0 <= py <= ny - 1
                     and 0.0 <= px <= nx - 1):  # fmt: skip
        ndv = grad_ndv(vol, grad, pz, py, px, gscale, vz, vy, vx, gmin)
    else:
        ndv = _fly_ndv(vol, pz, py, px, gscale, vz, vy, vx, gmin)
    if ndv < 0.0:
        return 1.0, 0.0
    return ka + kd * ndv, ks * (_powi(ndv, ishin) if whole else ndv**shin)


@kernel(inline=True)
def sub_count(bend, bend_min, nsub):
    """Sub-segments for a refined segment: ``nsub``, but at most 2 where the scalar is
    nearly straight along the ray there. ``bend`` is the second difference of the
    samples ending the segment and the one before (``x_b - 2 x_f + x_p``, table
    entries; NaN when the one before is not known): below ``bend_min`` the chord of
    two sub-segments strays from the curve by about ``bend / 32`` of an entry or less.
    Where the scalar bends, a third sub-segment leaves 4/9 of two's chord error (it
    falls as the square of the length)."""
    if nsub > 2 and bend < bend_min:
        return 2
    return nsub


@kernel(inline=True)
def _lerp2(tab, ch, i0, i1, f):
    """Linear lookup of channel ``ch`` of the (n, 4) table."""
    a = tab[i0, ch]
    return a + (tab[i1, ch] - a) * f


def _march_specialised(pre, shade):
    """The fast kernel for one (pre-integrated?, shaded?) pair (see :func:`_march`);
    ``pre`` 2: unshaded pre-integrated frames read at nearest entries, their segments
    through :func:`_near_run`. A kernel of its own: compiled into the one that also
    marches opaque (bilinear) frames, the unused call slowed those by 6-10 %."""

    def run(vol, grad, has_grad, codes, light, frame, u, v, rows, post_tab, pre2d, subs,
            lo, scale, step, leap, brick, skip, ert, shading, gscale, vscale, gmin, clear,
            refine, tiles, out, row_cols):  # fmt: skip
        # rows (ascending) in bands of at most ROW_BAND consecutive ones, each band traced
        # tile by tile (column edges ``tiles``), so that the voxels a tile's rays read stay
        # in the thread's cache for the tile's next rows (a whole row of rays read more
        # than it holds: on the benchmark's int16 CT with two threads, 4-15 % less CPU a
        # frame); in the kernel, where a call a tile from Python cost 512 calls a frame
        k0 = 0
        while k0 < rows.shape[0]:
            k1 = band_end(rows, k0, ROW_BAND)
            for t in range(tiles.shape[0] - 1):
                _march_inline(
                    vol, grad, has_grad, codes, light, frame, u, v, rows[k0:k1], pre, post_tab,
                    pre2d, subs, lo, scale, step, leap, brick, skip, ert, shade, shading, gscale,
                    vscale, gmin, clear, refine, tiles[t : t + 2], out, row_cols,
                )  # fmt: skip
            k0 = k1

    run.__name__ = run.__qualname__ = (
        f"_march_{'pre' if pre else 'post'}_{SHADE_NAMES[shade]}{'_runs' if pre == 2 else ''}")
    # allocates nothing: no reference counts in the loops; multiply-adds fused (12-15 %
    # faster on the benchmark's volumes, the image moves by at most 6e-8)
    return kernel(run, nrt=False, contract=True)


#: The fast path's shading variants: unshaded, Phong from gradients, Phong from codes.
SHADE_NAMES = ("none", "phong", "codes")
#: The fast path's kernels by (pre-integrated, shading variant).
_MARCH = {(p, sh): _march_specialised(p, sh) for p in (False, True) for sh in range(3)}
#: The fast path's kernel for unshaded pre-integrated frames read at nearest entries.
_NEAR_MARCH = _march_specialised(2, 0)


@kernel
def _box_range(a, z0, z1, y0, y1, x0, x1):
    """Min and max of ``a[z0:z1, y0:y1, x0:x1]`` (inf and -inf when empty)."""
    mn = np.inf
    mx = -np.inf
    for z in range(z0, z1):
        for y in range(y0, y1):
            for x in range(x0, x1):
                v = a[z, y, x]
                if v < mn:
                    mn = v
                if v > mx:
                    mx = v
    return mn, mx


#: Volumes with fewer voxels have their brick ranges found on the calling thread: a
#: walk rewrites about 90 node boxes of 16^3-32^3 voxels a frame on the MRI octree, and a
#: thread pool for each (two threads started, 0.1-0.2 ms of work) took 0.28 s a frame.
SMALL_RANGES = 1 << 18


def brick_ranges(vol, brick: int, mins, maxs, workers: int = 1) -> None:
    """Fill ``mins`` and ``maxs`` with the range of each ``brick``^3 brick of ``vol``
    plus one voxel of overlap on the high side (what trilinear samples inside the brick
    read), slabs of bricks on ``workers`` threads."""
    nbz = mins.shape[0]
    vol = read_only(vol)  # one compiled signature for every caller
    # integers have no NaN to skip: their ranges come from whole planes and rows
    fn = _int_brick_range_kernel if vol.dtype.kind in "iu" else _brick_range_kernel
    if workers <= 1 or vol.size < SMALL_RANGES:  # a walk's rewritten box: a pool per
        fn(vol, brick, 0, nbz, mins, maxs)  # call cost more than it
        return
    per = max(1, -(-nbz // (4 * workers)))
    for _ in ordered_map(lambda b0: fn(vol, brick, b0, min(b0 + per, nbz), mins, maxs),
                         range(0, nbz, per), workers=workers):  # fmt: skip
        pass


@kernel
def _int_brick_range_kernel(vol, brick, bz0, bz1, mins, maxs):
    """:func:`brick_ranges` of brick slabs ``bz0 .. bz1 - 1`` of an integer volume: the
    element-wise min and max of a slab's planes (its overlap plane included), then of a
    brick row's rows, then of each brick's voxels along x. The first two are branch-free
    loops over contiguous rows that LLVM vectorises (the voxel-by-voxel kernel with its
    NaN test does not: 85 ms against 8 on the MRI walk's grid). The ranges are the same
    numbers: the float32 rounding of integers keeps their order, so it commutes with
    min and max."""
    nz, ny, nx = vol.shape
    nby, nbx = mins.shape[1], mins.shape[2]
    pmin = np.empty((ny, nx), vol.dtype)
    pmax = np.empty((ny, nx), vol.dtype)
    rmin = np.empty(nx, vol.dtype)
    rmax = np.empty(nx, vol.dtype)
    for bz in range(bz0, bz1):
        z0 = bz * brick
        for y in range(ny):
            src = vol[z0, y]
            lo_row, hi_row = pmin[y], pmax[y]
            for x in range(nx):
                lo_row[x] = src[x]
                hi_row[x] = src[x]
        for z in range(z0 + 1, min(z0 + brick + 1, nz)):
            for y in range(ny):
                src = vol[z, y]
                lo_row, hi_row = pmin[y], pmax[y]
                for x in range(nx):
                    v = src[x]
                    lo_row[x] = min(lo_row[x], v)
                    hi_row[x] = max(hi_row[x], v)
        for by in range(nby):
            y0 = by * brick
            for x in range(nx):
                rmin[x] = pmin[y0, x]
                rmax[x] = pmax[y0, x]
            for y in range(y0 + 1, min(y0 + brick + 1, ny)):
                lo_row, hi_row = pmin[y], pmax[y]
                for x in range(nx):
                    rmin[x] = min(rmin[x], lo_row[x])
                    rmax[x] = max(rmax[x], hi_row[x])
            for bx in range(nbx):
                x0 = bx * brick
                mn = rmin[x0]
                mx = rmax[x0]
                for x in range(x0 + 1, min(x0 + brick + 1, nx)):
                    mn = min(mn, rmin[x])
                    mx = max(mx, rmax[x])
                mins[bz, by, bx] = mn
                maxs[bz, by, bx] = mx


@kernel
def _brick_range_kernel(vol, brick, bz0, bz1, mins, maxs):
    """:func:`brick_ranges` of brick slabs ``bz0 .. bz1 - 1``, reading each voxel row
    once: a row's range in each brick column (plus its overlap voxel), found in the
    volume's own dtype (no float conversion a voxel: twice as fast on 8-bit data), then
    merged into the bricks that hold the row, two along an axis where it is one's
    overlap layer. NaN voxels are skipped."""
    nz, ny, nx = vol.shape
    nby, nbx = mins.shape[1], mins.shape[2]
    for bz in range(bz0, bz1):
        for by in range(nby):
            for bx in range(nbx):
                mins[bz, by, bx] = np.inf
                maxs[bz, by, bx] = -np.inf
    rmin = np.empty(nbx, np.float32)
    rmax = np.empty(nbx, np.float32)
    for z in range(bz0 * brick, min(bz1 * brick + 1, nz)):
        cz1 = min(z // brick, bz1 - 1)
        cz0 = max(z // brick - 1 if z % brick == 0 else cz1, bz0)
        for y in range(ny):
            cy1 = min(y // brick, nby - 1)
            cy0 = max(y // brick - 1 if y % brick == 0 else cy1, 0)
            for bx in range(nbx):
                x0, x1 = bx * brick, min((bx + 1) * brick + 1, nx)
                mn = vol[z, y, x0]
                mx = mn
                for x in range(x0 + 1, x1):
                    v = vol[z, y, x]
                    if v < mn:
                        mn = v
                    if v > mx:
                        mx = v
                rmin[bx] = mn
                rmax[bx] = mx
                if not (mn == mn):  # a NaN first voxel (never for integers): skip NaNs
                    rmin[bx], rmax[bx] = _box_range(vol, z, z + 1, y, y + 1, x0, x1)
            for cz in range(cz0, cz1 + 1):
                for cy in range(cy0, cy1 + 1):
                    for bx in range(nbx):
                        if rmin[bx] < mins[cz, cy, bx]:
                            mins[cz, cy, bx] = rmin[bx]
                        if rmax[bx] > maxs[cz, cy, bx]:
                            maxs[cz, cy, bx] = rmax[bx]


@kernel
def _paged_range_kernel(atlas, page, meta, inv, offset, brick, mins, maxs):
    """Min and max of the node voxels that trilinear samples inside each level-0 brick
    of a paged volume read (NaN where no node covers the brick). A brick lies inside
    one page cell, as ``brick`` divides the cell size."""
    g = meta[3]
    b = atlas.shape[1] - 1
    nbz, nby, nbx = mins.shape
    for bz in range(nbz):
        for by in range(nby):
            for bx in range(nbx):
                node = page[min(bz * brick // g, page.shape[0] - 1),
                            min(by * brick // g, page.shape[1] - 1),
                            min(bx * brick // g, page.shape[2] - 1)]  # fmt: skip
                if node < 0:
                    mins[bz, by, bx] = np.nan
                    maxs[bz, by, bx] = np.nan
                    continue
                lo3 = np.empty(3, np.int64)
                hi3 = np.empty(3, np.int64)
                for a, c in enumerate((bz, by, bx)):
                    # level-0 samples in [c brick - 0.5, (c + 1) brick + 0.5] (the
                    # step may cross a border): their atlas cells, plus the next voxel
                    p0 = c * brick - 0.5
                    p1 = (c + 1) * brick + 0.5
                    q0 = p0 * inv[node] + offset[node, a]
                    q1 = p1 * inv[node] + offset[node, a]
                    lo3[a] = min(max(int(math.floor(q0)), 0), b)
                    hi3[a] = min(max(int(math.floor(q1)) + 1, 0), b)
                mins[bz, by, bx], maxs[bz, by, bx] = _box_range(
                    atlas[node], lo3[0], hi3[0] + 1, lo3[1], hi3[1] + 1, lo3[2], hi3[2] + 1
                )


#: Pre-classification keeps an RGBA float32 copy of the volume, 16 bytes a voxel (a 512^3
#: uint8 volume rendered in 3.2 GB, a 1024^3 one would need 16 GiB more): refused past this.
PRECLASSIFIED_BUDGET = 4 << 30


def _check_preclassified(voxels: int) -> None:
    """Refuse ``classification='pre'`` when its RGBA copy would pass the budget."""
    need = 16 * int(voxels)
    if need > PRECLASSIFIED_BUDGET:
        raise VolpackError(
            f"expected at most {PRECLASSIFIED_BUDGET // 16:,} voxels for classification 'pre' "
            f"(an RGBA copy of 16 bytes a voxel, at most {PRECLASSIFIED_BUDGET / 2**30:g} GiB), "
            f"found {int(voxels):,} ({need / 2**30:.1f} GiB); 'post' and 'preintegrated' "
            "classify along the rays and need no copy"
        )


@kernel
def _classify_kernel(vol, tab, lo, scale, out):
    """Pre-classification: the (n, 4) table looked up (linearly) at every voxel."""
    nz, ny, nx = vol.shape
    for z in range(nz):
        c4 = np.zeros(7, dtype=np.float64)
        for y in range(ny):
            for x in range(nx):
                _lookup1(tab, (vol[z, y, x] - lo) * scale, c4)
                for ch in range(4):
                    out[z, y, x, ch] = c4[ch]


# --------------------------------------------------------------------------- API


def render(
    volume,
    *,
    spacing: Sequence[float] | None = None,
    tf=None,
    camera: Camera | None = None,
    step: float = 0.5,
    classification: str = "preintegrated",
    shading: str = "none",
    isos: Sequence[tuple] | None = None,
    preint_method: str = "fast",
    value_range: tuple[float, float] | None = None,
    table_size: int = TABLE_SIZE,
    ert: float = 0.99,
    skip_empty: bool = True,
    normals: str = "quantised",
    refine: int = REFINE,
    workers: int | None = None,
    progress: Callable[[int, int], None] | None = None,
    render_stats: bool = False,
):
    """Ray-cast ``volume`` into a pre-multiplied RGBA image on black.

    Parameters
    ----------
    volume : ndarray (z, y, x) or :class:`volpack.volume.Volume`
        Any integer or float dtype; non-finite voxels are empty (module docstring). A
        ``Volume`` brings its spacing (and its mask: masked voxels are empty too).
    spacing : (dz, dy, dx)
        Voxel size; defaults to the Volume's, else 1.
    tf : TransferFunction, (n, 4) table, or None
        Colour and opacity over the value range; opacity per reference length (the
        smallest spacing). ``None`` (only with ``isos``) draws surfaces alone.
    camera : Camera
        Default ``Camera()`` (512 x 512, orthographic).
    step : float
        Segment length in reference lengths.
    classification : {"preintegrated", "post", "pre"}
    shading : {"none", "phong", "preintegrated", "centroid"}
    isos : list of (value, (r, g, b), opacity)
        Isosurfaces, drawn through :func:`volpack.render.preint.iso_table`.
    preint_method : {"fast", "exact"}
        Passed to :func:`volpack.render.preint.preintegrate`.
    value_range : (lo, hi)
        The value interval the tables span (default the finite data range), or the
        TF's points within it where they cover less than :data:`NARROW_SHARE` of it (a
        fill value or an outlier; values beyond take the TF's end values).
    table_size : int
        Entries of the TF table (and of each side of the 2-D tables). Pre-integrated
        tables smooth at the entry scale are read at the nearest entry (module
        docstring, :data:`NEAREST_STEP`), others bilinearly.
    ert : float
        Early ray termination threshold on the accumulated opacity (>= 1 disables it).
    skip_empty : bool
        Empty-space skipping over 8^3 bricks (the image does not change).
    normals : {"quantised", "exact"}
        How Phong shading finds normals on orthographic frames of a plain volume:
        per-voxel quantised normals lit through a table (:mod:`volpack.render.normals`),
        or the trilinear field's central differences (as perspective frames always do).
    refine : int
        Pre-integrated segments that carry more than :data:`REFINE_OPACITY` of their
        pixel's opacity (the entry into an opaque surface, a thin sheet crossed) are
        marched again as ``refine`` sub-segments (``refine - 1`` samples more; two
        where the scalar is nearly straight along the ray, :data:`REFINE_BEND`),
        through the table of their length (module docstring; default :data:`REFINE`);
        1 never refines.
    workers : int or None
        Threads (None or 0 = every core). The image does not depend on it.
    progress : callable(done, total)
        Called after each band of image rows.
    render_stats : bool
        Also return a :class:`RenderStats`.

    Returns
    -------
    ndarray (h, w, 4) float32, or (image, RenderStats)
    """
    t_start = time.perf_counter()
    from .preint import iso_table

    if classification not in MODES:
        raise VolpackError(f"expected classification in {sorted(MODES)}, found {classification!r}")
    if shading not in SHADINGS:
        raise VolpackError(f"expected shading in {list(SHADINGS)}, found {shading!r}")
    if shading in ("preintegrated", "centroid") and classification != "preintegrated":
        raise VolpackError(
            "expected classification='preintegrated' with shading='preintegrated' "
            f"(its lighting tables are pre-integrated), found {classification!r}"
        )
    if normals not in ("quantised", "exact"):
        raise VolpackError(f"expected normals 'quantised' or 'exact', found {normals!r}")
    if not (math.isfinite(step) and step > 0):
        raise VolpackError(f"expected a finite step > 0, found {step}")
    if isinstance(refine, bool) or not isinstance(refine, (int, np.integer)) or refine < 1:
        raise VolpackError(f"expected refine as a whole number >= 1, found {refine!r}")
    if int(table_size) < 2:
        raise VolpackError(f"expected table_size >= 2, found {table_size}")
    n = int(table_size)
    camera = Camera() if camera is None else camera
    if not isinstance(camera, Camera):
        raise VolpackError(f"expected a Camera, found {type(camera).__name__}")
    isos = list(isos or [])
    if tf is None and not isos:
        raise VolpackError(
            "expected a transfer function (tf=) or isosurfaces (isos=), found neither"
        )

    paged = hasattr(volume, "page")  # a volpack.render.lod.PagedVolume
    prep = None
    if paged:
        if classification == "pre":
            raise VolpackError("expected classification 'post' or 'preintegrated' for a "
                               "multiresolution selection, found 'pre'")  # fmt: skip
        sp = tuple(float(v) for v in (spacing or volume.spacing))
        vol = volume.atlas
        frange = volume.finite_range
    else:
        prep = prepare_volume(volume, spacing)
        sp = prep.spacing if spacing is None else unpack_volume(prep.data[:1, :1, :1], spacing)[2]
        vol = read_only(prep.data)  # one compiled signature for API and CLI callers
        frange = prep.finite_range
    if value_range is None:
        lo, hi = frange if frange is not None else (0.0, 1.0)
    else:
        lo, hi = (float(v) for v in value_range)
        if not (math.isfinite(lo) and math.isfinite(hi)):
            raise VolpackError(f"expected a finite value range, found {value_range}")
    lo, hi = nonempty_range(lo, hi)
    narrowed = False
    if not paged and not isos and frange is not None:  # the CLI passes the data range
        lo, hi, narrowed = tf_span(tf, lo, hi)
    scale = (n - 1) / (hi - lo)

    # tables
    mode = MODES[classification]
    has_vol = tf is not None
    base = transfer_table(tf, lo, hi, n) if has_vol else np.zeros((n, 4), np.float32)
    lit = shading in ("preintegrated", "centroid")
    tables = _frame_tables(base, float(step), has_vol and mode == 2, lit, preint_method)
    post_tab, pre2d = tables.post, tables.pre2d
    iso_vals = np.zeros(0, np.float64)
    iso2d = np.zeros((1, 1, 4), np.float32)
    if isos:
        isos = _check_isos(isos)
        iso_vals = np.array(sorted(v for v, _, _ in isos), np.float64)
        iso2d = np.ascontiguousarray(iso_table(n, lo, hi, isos), np.float32)

    if frange is None and not isos:  # nothing but non-finite voxels: nothing to see
        w, h = camera.size
        out = np.zeros((h, w, 4), np.float32)
        stats = RenderStats(0, time.perf_counter() - t_start, w * h, 0)
        return (out, stats) if render_stats else out
    dmin = None if frange is None else frange[0]
    nthreads = parse_workers(workers)
    fill = None
    if prep is not None and prep.bad is not None:
        fill = empty_value(base if has_vol else None, lo, hi, dmin)
        vol = prep.filled(fill)

    rgba = np.zeros((1, 1, 1, 4), np.float32)
    if has_vol and mode == 1:
        _check_preclassified(vol.size)
        rgba = np.empty((*vol.shape, 4), np.float32)
        _classify_kernel(vol, post_tab, lo, scale, rgba)
        if prep is not None and prep.bad is not None:
            rgba[prep.bad] = 0.0

    brick = BRICK
    ranges = None
    if paged:  # nodes are sampled through the page table
        fill_p = empty_value(base if has_vol else None, lo, hi, dmin, quiet=True)
        vol = page_tuple(volume, fill_p)
        shape = volume.shape
    else:
        shape = vol.shape
        brick = brick_size(shape)
        if skip_empty:
            ranges = prep.brick_ranges(fill, brick, lambda *a: brick_ranges(*a, nthreads))
    if paged and volume.cell % BRICK:  # bricks must not straddle page cells: skip by cell
        empty, brick = volume.page < 0, volume.cell
    else:
        def find_empty():
            return _empty_bricks(vol, shape, rgba, mode, has_vol, post_tab, pre2d, iso2d,
                                 bool(isos), lo, scale, skip_empty, ranges, brick)  # fmt: skip

        if prep is not None and skip_empty and mode != 1:  # kept while the tables show
            # the same entries (the frames of an orbit): 10-20 ms a frame on 4^3 bricks
            key = (fill, brick, mode, has_vol, bool(isos), lo, scale,
                   tables.shown(mode == 0), _shown(iso2d))  # fmt: skip

            def refresh(empty, boxes):  # bricks a walk's resident volume rewrote
                test = _invisibility(mode, has_vol, post_tab, pre2d, iso2d, bool(isos), lo,
                                     scale)  # once for all boxes: 2 ms each  # fmt: skip
                for bb in boxes:
                    empty[bb] = test(ranges[0][bb], ranges[1][bb])

            empty = prep.memo("empty", key, find_empty, refresh)
        else:
            empty = find_empty()
    if not skip_empty:
        leap = np.zeros(empty.shape, np.int32)
    elif prep is not None:  # kept across frames while the same bricks are empty
        leap = prep.leap_map(empty, _leap_kernel)
    else:
        leap = np.zeros(empty.shape, np.int32)
        _leap_kernel(np.ascontiguousarray(empty), leap)
    fast = FAST_PATH and has_vol and not isos and mode != 1 and shading in ("none", "phong")
    # the fast march makes each pixel's ray as it traces it (pixel_ray): 12 MB of rays
    # made and read again took 4-6 ms of a frame before the threads started
    ray_grid = camera.ray_grid(shape, sp) if fast else None
    origins, dirs = (None, None) if fast else camera.rays(shape, sp)
    # orthographic shaded frames light quantised normals through one table per frame
    codes, has_codes = np.zeros((1, 1, 1, 1), np.uint16), False  # a stack of code volumes
    parallel = camera.projection == "orthographic" or camera.size == (1, 1)  # one direction
    if fast and shading == "phong" and normals == "quantised" and parallel:
        if paged:
            if volume.codes is not None and sp == tuple(volume.spacing):  # codes of it
                codes, has_codes = volume.codes, True  # the nodes' code bricks
        elif (nc := prep.normal_codes(fill, sp)) is not None:
            codes = nc.ensure(~empty if skip_empty else None, brick, 0.5 * step, nthreads)[None]
            has_codes = True
    light = np.zeros((1, 2), np.float32)
    if has_codes:
        d = -np.array(pixel_ray(*ray_grid, 0, 0)[3:]) * (np.array(sp) / min(sp))
        light = light_table(d / np.linalg.norm(d), KA, KD, KS, SHININESS)
    grad = np.zeros((1, 1, 1, 1, 3), np.float32)  # a stack of gradient volumes (one here)
    has_grad = False
    if prep is not None and shading != "none" and not has_codes:
        g = prep.gradients(fill, nthreads)
        if g is not None:
            grad, has_grad = g[None], True
    w, h = camera.size
    out = np.zeros((h, w, 4), np.float32)
    ref = float(min(sp))
    gscale = np.array([0.5 / s for s in sp], np.float64)
    vscale = np.array([s / ref for s in sp], np.float64)
    gmin = 1e-6 * (hi - lo) / max(sp)
    shading_k = np.array([KA, KD, KS, SHININESS], np.float64)

    nsub = int(refine) if has_vol and mode == 2 else 1
    subs = tables.subs(nsub) if nsub > 1 else pre2d[None]
    near = has_vol and mode == 2 and NEAREST and tables.nearest()
    refine_k = np.array([nsub, REFINE_OPACITY, float(near), REFINE_BEND, float(LEAN_REFINE),
                         float(narrowed), CLIP_MIN], np.float64)  # fmt: skip
    if fast and paged and shading == "phong" and volume.grad is not None:
        grad, has_grad = volume.grad, True  # the nodes' gradient bricks
    if fast:
        march = _MARCH[mode == 2, 2 if has_codes else int(shading == "phong")]
        if mode == 2 and shading == "none" and near and NEAR_RUN and not narrowed:
            march = _NEAR_MARCH  # (its runs hold no clipped segment)
        clear = tables.clear(mode == 0)

        tiles = np.append(np.arange(0, w, TILE_COLS, dtype=np.int64), np.int64(w))
        row_cols = np.zeros((h, 3), np.int64)  # columns to trace, segments traced
        row_cols[:, :2] = camera.box_columns(shape, sp) if BOX_SPANS else (0, w)

        def run(rows: np.ndarray) -> None:  # the fast path (see _march)
            march(
                vol, grad, has_grad, codes, light, *ray_grid, rows, post_tab,
                pre2d, subs, lo, scale,
                float(step), leap, brick, bool(skip_empty), float(ert), shading_k, gscale,
                vscale, gmin, clear, refine_k, tiles, out, row_cols,
            )  # fmt: skip

        run_row_sets(run, h, nthreads, progress)
        return finish_render(out, row_cols[:, 2], t_start, render_stats)

    row_samples = np.zeros(h, np.int64)  # the general kernel's segments per row

    def run(rows: np.ndarray) -> None:
        _render_kernel(
            vol, grad, has_grad, rgba, origins, dirs, rows, mode, has_vol,
            post_tab, pre2d, subs, refine_k, iso2d, iso_vals, bool(isos), lo, scale, float(step),
            leap, brick, bool(skip_empty), float(ert), SHADINGS.index(shading), shading_k,
            gscale, vscale, gmin, out, row_samples,
        )  # fmt: skip

    run_row_sets(run, h, nthreads, progress)
    return finish_render(out, row_samples, t_start, render_stats)


class _Tables:
    """A frame's classification tables and what is derived from them, kept while the
    transfer function and step stay (the frames of an orbit, ``play``, ``walk``): the
    pre-integrated table, its visible entries and clear bounds took 10 ms a frame, a
    tenth of a small volume's frame on two threads."""

    def __init__(self, base, step, pre, lit, method):
        from .preint import preintegrate

        n = base.shape[0]
        self.base, self.step, self.method, self.lit = base, step, method, lit
        self.post = _corrected_table(base, step)
        self.pre2d = np.zeros((1, 1, 4), np.float32)
        if pre:
            self.pre2d = np.ascontiguousarray(
                preintegrate(base, step, method=method, lighting=lit), np.float32
            )
            if self.pre2d.shape[:2] != (n, n):
                raise VolpackError(f"expected an ({n}, {n}, 4) table, found {self.pre2d.shape}")
        for t in (self.post, self.pre2d):
            t.flags.writeable = False  # shared by later frames
        self._derived = {}

    def sub(self, m: int) -> np.ndarray:
        """The pre-integrated table of a segment ``1 / m`` as long (refinement)."""
        from .preint import preintegrate

        key = ("sub", m)
        if key not in self._derived:
            t = np.ascontiguousarray(
                preintegrate(self.base, self.step / m, method=self.method, lighting=self.lit),
                np.float32,
            )
            t.flags.writeable = False
            self._derived[key] = t
        return self._derived[key]

    def subs(self, m: int) -> np.ndarray:
        """The tables of segments ``1 / 2 .. 1 / m`` as long, stacked (refinement picks
        one per segment, :func:`sub_count`)."""
        key = ("subs", m)
        if key not in self._derived:
            t = np.ascontiguousarray(np.stack([self.sub(k) for k in range(2, m + 1)]))
            t.flags.writeable = False
            self._derived[key] = t
        return self._derived[key]

    def nearest(self) -> bool:
        """Whether the pre-integrated table is smooth enough to read at the nearest
        entry (:data:`NEAREST_STEP`)."""
        key = ("nearest", False)
        if key not in self._derived:
            t = self.pre2d
            step = max(float(np.abs(np.diff(t, axis=a)).max(initial=0.0)) for a in (0, 1))
            self._derived[key] = step <= NEAREST_STEP
        return self._derived[key]

    def _get(self, name, post, fn):
        key = (name, post)
        if key not in self._derived:
            self._derived[key] = fn(self.post if post else self.pre2d)
        return self._derived[key]

    def shown(self, post: bool) -> bytes:
        """:func:`_shown` of the post (else the pre-integrated) table."""
        return self._get("shown", post, _shown)

    def clear(self, post: bool) -> np.ndarray:
        """:func:`clear_bounds` of the post (else the pre-integrated) table."""
        return self._get("clear", post, clear_bounds)


_TABLES: dict = {}  # (table bytes, step, pre, lit, method) -> _Tables, the last few
_TABLES_LOCK = threading.Lock()


def _frame_tables(base, step, pre, lit, method) -> _Tables:
    """The :class:`_Tables` of the TF table ``base`` at ``step`` (kept for the last 4)."""
    key = (base.tobytes(), base.shape, step, pre, lit and pre, method if pre else None)
    with _TABLES_LOCK:
        tabs = _TABLES.pop(key, None)
    if tabs is None:
        tabs = _Tables(base, step, pre, lit, method)
    with _TABLES_LOCK:
        _TABLES[key] = tabs  # most recent last
        while len(_TABLES) > 4:
            del _TABLES[next(iter(_TABLES))]
    return tabs


def clear_bounds(tab: np.ndarray) -> np.ndarray:
    """Table positions ``(below, above)`` outside which a look-up reads only zeros.

    A linear look-up at ``x`` reads entries ``floor(x)`` and ``floor(x) + 1`` (clamped
    to the table): with ``x < below`` both come before the first non-zero entry, with
    ``x > above`` both after the last. Of a 2-D table, a segment with both ends below
    (above) reads entries whose row and column both lie there, so the first non-zero
    entry is the smallest ``max(i, j)`` (the last, the largest ``min(i, j)``) of a
    non-zero one. (inf, -inf) when the table is all zero."""
    n = tab.shape[0]
    if tab.ndim == 3:
        ii, jj = np.nonzero(np.any(tab != 0, axis=2))
        first, last = (np.maximum(ii, jj), np.minimum(ii, jj)) if ii.size else ((), ())
    else:
        first = last = np.flatnonzero(np.any(tab != 0, axis=1))
    if len(first) == 0:
        return np.array([np.inf, -np.inf])
    k, m = int(np.min(first)), int(np.max(last))
    # x < k - 1: floor(x) + 1 <= k - 1 (at x < 0 the clamped look-up reads entries 0 and
    # 1 with weight 0 on entry 1); x > m + 1: floor(x) >= m + 1, unless clamped to m
    return np.array([k - 1.0 if k >= 1 else -np.inf, m + 1.0 if m + 1 <= n - 1 else np.inf])


def finish_render(out, row_samples, t_start, render_stats):
    """The image, or ``(image, RenderStats)`` when ``render_stats`` is asked for."""
    if not render_stats:
        return out
    h, w = out.shape[:2]
    stats = RenderStats(
        samples=int(row_samples.sum()),
        seconds=time.perf_counter() - t_start,
        rays=w * h,
        hits=int(np.count_nonzero(out[..., 3] > 0)),
    )
    return out, stats


# --------------------------------------------------------------------------- helpers


#: Rows a thread traces in a row before its set skips ahead (see :func:`run_row_sets`).
ROW_BAND = 16
#: Most row sets a thread is handed (:func:`run_row_sets`): 16 rather than 4 took
#: two-thread 512^2 frames to 0.59-0.87x the wall time with other jobs on the machine
#: (best of 12-15 interleaved, head CT and 8-bit MRI; the same images), level when it
#: was free.
SETS_PER_THREAD = 16


def run_row_sets(run, h: int, nthreads: int, progress=None) -> None:
    """Call ``run(rows)`` on interleaved sets of bands of :data:`ROW_BAND` image rows
    (set ``j`` holds bands ``j, j + m, j + 2m, ...``) over ``nthreads`` threads, reporting
    ``progress(rows done, h)``. Interleaving balances the threads whatever the image
    holds; neighbouring rows traced one after the other by one thread read the same
    voxels from its cache (with single rows interleaved, two threads cost 15 % more CPU
    than one on the benchmark's CT, where VTK's cost the same). Up to
    :data:`SETS_PER_THREAD` sets a thread (one band each on a 512-row image and two
    threads): the last set to finish leaves the other threads idle, and a core taken by
    another process stalls its thread's sets, so small sets keep the threads level.
    Each ray is computed alone, so the image does not depend on the thread count."""
    band = max(1, min(ROW_BAND, h // (4 * nthreads))) if nthreads > 1 else 1
    nb = -(-h // band)
    m = min(nb, SETS_PER_THREAD * nthreads if nthreads > 1 else (8 if progress is not None else 1))
    band_of = np.arange(h, dtype=np.int64) // band

    def one(j: int) -> int:
        rows = np.flatnonzero(band_of % m == j).astype(np.int64)
        run(rows)
        return len(rows)

    done = 0  # sets as they finish (the calling thread traces sets too: no pool to start)
    for rows_done in completed_map(one, range(m), workers=nthreads):
        done += rows_done
        if progress is not None:
            progress(done, h)


#: Columns of a tile of the fast path (see :func:`_march_specialised`).
TILE_COLS = 32


@kernel(inline=True)
def band_end(rows, k0, band):
    """End of the band of ``rows`` (ascending image rows) that starts at ``rows[k0]``:
    ``k1`` such that ``rows[k0:k1]`` are consecutive rows, at most ``band`` of them."""
    k1 = k0 + 1
    while k1 < rows.shape[0] and k1 - k0 < band and rows[k1] == rows[k1 - 1] + 1:
        k1 += 1
    return k1


def tf_span(tf, lo: float, hi: float) -> tuple[float, float, bool]:
    """The range the tables span for data range ``[lo, hi]``: ``(lo, hi, False)``, or
    the TF's points clipped to it, ``(a, b, True)``, when those cover less than
    :data:`NARROW_SHARE` of it (a fill value or an outlier far from what the TF
    shows). Only a :class:`TransferFunction` has points; a table spans the range."""
    pts = getattr(tf, "points", None)
    if not pts:
        return lo, hi, False
    a, b = max(lo, float(pts[0][0])), min(hi, float(pts[-1][0]))
    if not (b > a and (b - a) < NARROW_SHARE * (hi - lo)):
        return lo, hi, False
    return a, b, True


def transfer_table(tf, lo, hi, n) -> np.ndarray:
    if hasattr(tf, "table"):
        tab = tf.table(lo, hi, n)
    else:
        tab = np.asarray(tf, np.float64)
        if tab.ndim != 2 or tab.shape[1] != 4 or tab.shape[0] < 2:
            raise VolpackError(
                f"expected a TransferFunction or an (n, 4) RGBA table, found shape {tab.shape}"
            )
        if tab.shape[0] != n:  # resample linearly to n entries
            xs = np.linspace(0, 1, tab.shape[0])
            xn = np.linspace(0, 1, n)
            tab = np.stack([np.interp(xn, xs, tab[:, k]) for k in range(4)], axis=1)
    tab = np.asarray(tab, np.float32)
    if tab.shape != (n, 4) or not np.all(np.isfinite(tab)):
        raise VolpackError(f"expected a finite ({n}, 4) table, found {tab.shape}")
    return np.clip(tab, 0.0, 1.0)


def _corrected_table(base: np.ndarray, step: float) -> np.ndarray:
    """Opacity corrected for ``step`` reference lengths; colour pre-multiplied by it."""
    a = np.clip(base[:, 3].astype(np.float64), 0.0, 1.0)
    a_step = -np.expm1(step * np.log1p(-np.minimum(a, 1.0 - 1e-7)))
    a_step[a >= 1.0] = 1.0
    out = np.empty(base.shape, np.float32)
    out[:, :3] = base[:, :3] * a_step[:, None]
    out[:, 3] = a_step
    return out


def _check_isos(isos) -> list:
    clean = []
    for item in isos:
        try:
            value, colour, opacity = item
            value = float(value)
            colour = tuple(float(c) for c in colour)
            opacity = float(opacity)
        except (TypeError, ValueError):
            raise VolpackError(
                f"expected an isosurface as (value, (r, g, b), opacity), found {item!r}"
            ) from None
        if len(colour) != 3 or not math.isfinite(value) or not 0 <= opacity <= 1:
            raise VolpackError(
                f"expected an isosurface as (value, (r, g, b), opacity in [0, 1]), found {item!r}"
            )
        clean.append((value, colour, opacity))
    return clean


def empty_value(base, lo, hi, dmin, quiet: bool = False) -> float:
    """A value for non-finite voxels (or absent nodes) whose table entry is transparent
    (``dmin``: the smallest finite value, None when there is none)."""
    dmin = lo if dmin is None else float(dmin)
    if base is None:
        return dmin
    n = base.shape[0]
    clear = np.flatnonzero(np.all(base == 0, axis=1) | (base[:, 3] == 0))
    if clear.size == 0:
        if not quiet:
            log.warning(
                "no transparent value in the transfer function: NaN voxels take the minimum"
            )
        return dmin
    i_min = (dmin - lo) * (n - 1) / (hi - lo)
    if base[min(max(int(round(i_min)), 0), n - 1), 3] == 0 and (
        i_min <= 0 or int(i_min) + 1 >= n or base[int(i_min) + 1, 3] == 0
    ):
        return dmin
    # a run of two transparent entries so that a linear lookup there is exactly zero
    runs = clear[np.flatnonzero(np.diff(clear) == 1)] if clear.size > 1 else clear[:0]
    pick = runs if runs.size else clear
    i = int(pick[np.argmin(np.abs(pick - i_min))])
    return lo + i * (hi - lo) / (n - 1)


def brick_size(shape) -> int:
    """Edge of the empty-space bricks of a plain volume (see :data:`FINE_BRICKS`)."""
    if math.prod(max(1, -(-int(s) // FINE_BRICK)) for s in shape) <= FINE_BRICKS:
        return FINE_BRICK
    return BRICK


def _empty_bricks(
    vol, shape, rgba, mode, has_vol, post_tab, pre2d, iso2d, has_iso, lo, scale, skip,
    ranges=None, brick=BRICK,
):  # fmt: skip
    """Which ``brick``^3 bricks of level-0 space no sample can see: their value range
    (with the voxels trilinear samples inside them reach; ``ranges`` when given) maps to
    zero in every table in use; for a paged volume, also the bricks no node covers."""
    nb = tuple(max(1, -(-s // brick)) for s in shape)
    if not skip:
        return np.zeros(nb, np.bool_)
    if has_vol and mode == 1:
        alpha = np.ascontiguousarray(rgba[..., 3])
        mins = np.empty(nb, np.float32)
        maxs = np.empty(nb, np.float32)
        brick_ranges(alpha, brick, mins, maxs)
        empty = maxs <= 0.0
        if not has_iso:
            return empty
    mins = np.empty(nb, np.float32)
    maxs = np.empty(nb, np.float32)
    uncovered = np.zeros(nb, np.bool_)
    if isinstance(vol, tuple):
        _paged_range_kernel(vol[0][..., 0], *vol[1:5], brick, mins, maxs)
        uncovered = np.isnan(mins)
        mins[uncovered] = maxs[uncovered] = lo
    elif ranges is not None:
        mins, maxs = ranges
    else:
        brick_ranges(vol, brick, mins, maxs)
    invisible = uncovered | _invisible_range(
        mins, maxs, mode, has_vol, post_tab, pre2d, iso2d, has_iso, lo, scale
    )
    if has_vol and mode == 1:
        return invisible & empty
    return invisible


@kernel
def _invisible_kernel(mins, maxs, lo, scale, n, cum, has_cum, sat, has_sat, out):
    """:func:`_invisibility`'s test, brick by brick (numpy's passes over half a million
    bricks made a dozen temporaries: 55 ms against 10 on the MRI walk's frame 0). The
    table entries a range can touch (bilinear neighbours, with a little slack) are found
    with numpy's operations in its order; a brick is invisible if, with ``has_cum``, no
    entry of the 1-D table between them is visible (``cum``, their running count) and,
    with ``has_sat``, none in their square of the 2-D tables (``sat``, a summed-area
    table). ``mins`` and ``maxs`` hold no NaN (brick ranges skip NaN voxels)."""
    for i in range(mins.size):
        f0 = np.floor((np.float64(mins[i]) - lo) * scale - 1e-3)
        f1 = np.floor((np.float64(maxs[i]) - lo) * scale + 1e-3) + 1
        i0 = int(min(max(f0, 0.0), n - 1.0))
        i1 = int(min(max(f1, 0.0), n - 1.0))
        hidden = True
        if has_cum:
            hidden = cum[i1 + 1] - cum[i0] == 0
        if has_sat and hidden:
            hidden = sat[i1 + 1, i1 + 1] - sat[i0, i1 + 1] - sat[i1 + 1, i0] + sat[i0, i0] == 0
        out[i] = hidden


def _shown(tab: np.ndarray) -> bytes:
    """Which entries of a table are not all zero, packed (what empty space depends on)."""
    return np.packbits(np.any(tab != 0, axis=-1)).tobytes()


def _invisible_range(mins, maxs, mode, has_vol, post_tab, pre2d, iso2d, has_iso, lo, scale):
    """True where the value range ``[mins, maxs]`` touches no visible table entry."""
    return _invisibility(mode, has_vol, post_tab, pre2d, iso2d, has_iso, lo, scale)(mins, maxs)


def _invisibility(mode, has_vol, post_tab, pre2d, iso2d, has_iso, lo, scale):
    """The test of :func:`_invisible_range` for these tables, as a function of
    ``(mins, maxs)``: the tables' visible entries are counted once (a summed-area
    table), then each call only indexes it."""
    n = post_tab.shape[0]
    nonzero2 = np.zeros((n, n), bool)
    cum = None
    if has_vol and mode == 0:
        cum = np.concatenate([[0], np.cumsum(np.any(post_tab != 0, axis=1))])
    elif has_vol and mode == 2:
        nonzero2 |= np.any(pre2d != 0, axis=2)
    if has_iso:
        nonzero2 |= np.any(iso2d != 0, axis=2)
    sat = None
    if nonzero2.any():
        sat = np.zeros((n + 1, n + 1), np.int64)
        sat[1:, 1:] = np.cumsum(np.cumsum(nonzero2, axis=0), axis=1)

    cum_a = np.zeros(1, np.int64) if cum is None else cum.astype(np.int64)
    sat_a = np.zeros((1, 1), np.int64) if sat is None else sat

    def test(mins, maxs):
        out = np.empty(mins.shape, np.bool_)
        _invisible_kernel(np.ascontiguousarray(mins, np.float32).ravel(),
                          np.ascontiguousarray(maxs, np.float32).ravel(), float(lo), float(scale),
                          n, cum_a, cum is not None, sat_a, sat is not None, out.reshape(-1))  # fmt: skip
        return out

    return test
