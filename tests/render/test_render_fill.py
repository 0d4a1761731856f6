"""A fill value or an outlier far from what the transfer function shows (-9999 on a
climate grid, 1e20): the tables span the TF's points, not the data range, and a
pre-integrated segment reaching beyond them is cut where its scalar crosses their ends
(volpack.render.raycast: NARROW_SHARE, tf_span, _clip_chord; session 37)."""

from __future__ import annotations

import numpy as np
import pytest

import volpack.render.raycast as rc
from volpack.render.camera import Camera
from volpack.render.raycast import render, tf_span
from volpack.render.transfer import TransferFunction

CAM = Camera(azimuth=30.0, elevation=20.0, size=(48, 48))


def wind(shape=(12, 20, 24), fill=-9999.0) -> np.ndarray:
    """A smooth field over [0, 30] with ``fill`` in a slab of columns (land)."""
    z, y, x = np.meshgrid(*(np.linspace(-1, 1, n) for n in shape), indexing="ij")
    f = 15.0 + 15.0 * np.sin(2.0 * z + 1.5 * y) * np.cos(1.7 * x - 0.5 * y)
    f[:, :, : shape[2] // 3] = fill
    return f.astype(np.float32)


def semi(lo=3.0, hi=30.0) -> TransferFunction:
    """Clear below ``lo`` and above ``hi`` (so a fill on either side is clear)."""
    r = hi - lo
    return TransferFunction(points=((lo, 0, 0, 0, 0.0), (lo + 0.3 * r, 0.9, 0.6, 0.5, 0.05),
                                    (hi, 1.0, 1.0, 1.0, 0.3), (hi + 1, 0, 0, 0, 0.0)))  # fmt: skip


def truth(vol, tf) -> np.ndarray:
    """Post-classified point samples at step 1/16 through a fine table over the TF's
    points (exact beyond them: the TF is constant there): the image the pre-integrated
    one converges to."""
    lo, hi = tf.points[0][0], tf.points[-1][0]
    return render(vol, tf=tf, camera=CAM, step=1 / 16, classification="post",
                  value_range=(lo, hi), table_size=1024)  # fmt: skip


@pytest.mark.parametrize("fill", [-9999.0, 1e20])
@pytest.mark.parametrize("given", [False, True])
def test_a_fill_value_leaves_the_tf_its_table(fill, given):
    vol = wind(fill=fill)
    tf = semi()
    # given: the data range passed as value_range, as `volpack render` does
    vr = (float(vol.min()), float(vol.max())) if given else None
    img = render(vol, tf=tf, camera=CAM, value_range=vr)
    err = np.abs(img - truth(vol, tf))
    # the tables over [-9999, 31] (or [0, 1e20]) held the TF in one or two entries: the
    # clear values below 3 drawn, 0.86-1.0 off the truth, 0.07-0.13 on average (before
    # session 37); now 0.08-0.10 at most (at the fill's edges), 9e-4 on average
    assert err.max() < 0.15
    assert err.mean() < 3e-3


# a guard (it passes on the code before the cut segments too) that compiles the general
# kernel's lit path for its own case: about 12 s on an empty cache, in the slow set
@pytest.mark.slow
def test_clipped_segments_agree_between_the_kernels():
    """The fast march and the general kernel (perspective frames, isosurfaces) cut the
    same segments the same way."""
    vol = wind()
    tf = semi()
    fast = render(vol, tf=tf, camera=CAM, shading="phong", normals="exact")
    rc.FAST_PATH = False
    try:
        slow = render(vol, tf=tf, camera=CAM, shading="phong")
    finally:
        rc.FAST_PATH = True
    assert np.abs(fast - slow).max() < 1e-4


def test_clip_chord_is_the_segment_cut_at_the_tables_ends():
    """A segment from far below the table to inside it: only the share of its length
    inside counts (its optical depth scaled), and the pieces beyond take the end
    entries in ray order."""
    n = 8
    tab = np.zeros((n, n, 4), np.float32)
    tab[..., 3] = 0.5  # every chord inside: opacity 0.5 over a whole segment
    tab[..., 0] = 0.25
    tab[0, 0] = 0.0  # clear below the table
    top = n - 1.0
    # from -93 to 7 (the top): 7 % of the length inside
    r, g, b, a = rc._clip_chord(tab, -93.0, 7.0, top)
    assert a == pytest.approx(1 - 0.5**0.07, rel=1e-5)
    assert r == pytest.approx(0.25 * a / 0.5, rel=1e-5)
    # inside, then above the table, where the end entry is opaque: the piece above is
    # behind the inside one
    tab[n - 1, n - 1] = (1.0, 0.0, 0.0, 1.0)
    r, g, b, a = rc._clip_chord(tab, 3.0, 11.0, top)  # half inside, half above
    ai = 1 - 0.5**0.5
    assert a == pytest.approx(1.0)
    assert r == pytest.approx(0.25 * ai / 0.5 + (1 - ai) * 1.0, rel=1e-5)


def test_tf_span_narrows_only_past_the_share():
    tf = semi(3.0, 30.0)
    assert tf_span(tf, -9999.0, 30.0) == (3.0, 30.0, True)
    assert tf_span(tf, 0.0, 30.0) == (0.0, 30.0, False)  # the TF covers most of the data
    assert tf_span(np.zeros((4, 4)), -9999.0, 30.0) == (-9999.0, 30.0, False)  # a table
    assert tf_span(tf, 100.0, 1e6) == (100.0, 1e6, False)  # no point inside the data


def test_a_faint_cut_segment_keeps_its_chord(monkeypatch):
    """A segment cut at the tables' ends is sampled again only where it can move its
    pixel by half an 8-bit level or more (rc.CLIP_MIN, session 37, rend37b): the faint
    ones keep their chord; fewer segments, the image as near the truth."""
    vol = wind()
    tf = semi()
    want = truth(vol, tf)
    monkeypatch.setattr(rc, "CLIP_MIN", 0.0)  # every cut segment sampled again
    img0, st0 = render(vol, tf=tf, camera=CAM, render_stats=True)
    monkeypatch.setattr(rc, "CLIP_MIN", 1.0 / 512.0)
    img, st = render(vol, tf=tf, camera=CAM, render_stats=True)
    assert st.samples < st0.samples
    err, err0 = np.abs(img - want), np.abs(img0 - want)
    assert err.max() < 0.15 and err.mean() < 1.05 * err0.mean()


def test_faint_cut_reads_the_diagonal_at_the_end_inside():
    n = 8
    tab = np.zeros((n, n, 4), np.float32)
    tab[5, 5, 3] = 0.01
    top = n - 1.0
    assert rc._faint_cut(tab, -1e4, 2.0, top, 1.0, 1 / 512)  # clear at its end inside
    assert not rc._faint_cut(tab, -1e4, 5.2, top, 1.0, 1 / 512)  # 0.01 there
    assert rc._faint_cut(tab, 4.9, 1e4, top, 0.1, 1 / 512)  # behind 90 % opacity
    assert not rc._faint_cut(tab, 5.0, 1e4, top, 1.0, 0.0)  # CLIP_MIN 0: never
    assert not rc._faint_cut(tab, -1e4, 1e4, top, 1.0, 1 / 512)  # no end inside
