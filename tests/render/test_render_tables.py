"""Transfer functions and pre-integration tables (volpack.render.transfer, .preint)."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from naive import render_iso_reference, render_preint_reference

from volpack.errors import FormatError
from volpack.render import preint
from volpack.render.preint import (
    TableUpdater,
    iso_hits,
    iso_table,
    opacity_correct,
    preintegrate,
)
from volpack.render.transfer import (
    PRESETS,
    TransferFunction,
    auto_tf,
    load_tf,
    preset,
)

METHODS = ("fast", "exact")


def random_table(rng, n, amax=1.0):
    tab = rng.uniform(0, 1, (n, 4))
    tab[:, 3] *= amax
    return tab


# -- transfer functions ----------------------------------------------------------------


def test_tf_sampling_is_piecewise_linear_and_clamped():
    tf = TransferFunction(((10.0, 0, 0, 0, 0), (20.0, 1, 0.5, 0, 0.2), (40.0, 0, 1, 1, 1)))
    tab = tf.table(0.0, 50.0, 11)  # values 0, 5, ..., 50
    assert tab.shape == (11, 4) and tab.dtype == np.float32
    np.testing.assert_allclose(tab[0], [0, 0, 0, 0])  # clamped below
    np.testing.assert_allclose(tab[3], [0.5, 0.25, 0, 0.1])  # 15: halfway to 20
    np.testing.assert_allclose(tab[4], [1, 0.5, 0, 0.2])
    np.testing.assert_allclose(tab[6], [0.5, 0.75, 0.5, 0.6])  # 30
    np.testing.assert_allclose(tab[10], [0, 1, 1, 1])  # clamped above
    assert tf.table(3.0, 3.0, 1).shape == (1, 4)


def test_tf_step_takes_the_later_point_at_the_step():
    tf = TransferFunction(
        ((0.0, 0, 0, 0, 0), (0.5, 0, 0, 0, 0), (0.5, 1, 1, 1, 1), (1.0, 1, 1, 1, 1))
    )
    np.testing.assert_allclose(tf([0.25, 0.4999, 0.5, 0.75])[:, 3], [0, 0, 1, 1])
    single = TransferFunction(((3.0, 0.1, 0.2, 0.3, 0.4),))
    np.testing.assert_allclose(single([-1, 3, 9]), [[0.1, 0.2, 0.3, 0.4]] * 3)


def test_tf_json_round_trip_and_normalized_space(tmp_path):
    tf = preset("ct-soft", -1024, 3071)
    again = TransferFunction.from_json(tf.to_json())
    assert again == tf
    doc = {"name": "n", "space": "normalized", "points": [[0, 0, 0, 0, 0], [1, 1, 1, 1, 0.5]]}
    path = tmp_path / "n.json"
    path.write_text(json.dumps(doc))
    loaded = load_tf(str(path), 100.0, 300.0)
    assert loaded.name == "n"
    assert [p[0] for p in loaded.points] == [100.0, 300.0]
    np.testing.assert_allclose(loaded.table(100, 300, 3)[1], [0.5, 0.5, 0.5, 0.25])


@pytest.mark.parametrize(
    "text, words",
    [
        ("{not json", "JSON"),
        ("[1, 2]", "object"),
        ('{"name": "x"}', "points"),
        ('{"points": []}', "non-empty"),
        ('{"points": [[0, 1, 1, 1]]}', "[value, r, g, b, a]"),
        ('{"points": [[0, 1, 1, 1, 1.5]]}', "[0, 1]"),
        ('{"points": [[1, 0, 0, 0, 0], [0, 0, 0, 0, 0]]}', "ascending"),
        ('{"points": [[0, 0, 0, 0, "a"]]}', "five numbers"),
        ('{"points": [[0, 0, 0, 0, 0]], "space": "hu"}', "space"),
        ('{"points": [[2, 0, 0, 0, 0]], "space": "normalized"}', "normalized"),
        ('{"points": [[0, 0, 0, 0, 0]], "colour": 1}', "keys"),
    ],
)
def test_bad_tf_files_raise_format_error(tmp_path, text, words):
    path = tmp_path / "bad.json"
    path.write_text(text)
    with pytest.raises(FormatError) as e:
        load_tf(str(path), 0, 1)
    assert words in str(e.value) and "bad.json" in str(e.value)


def test_unknown_spec_and_bad_range():
    with pytest.raises(FormatError, match="preset"):
        load_tf("no-such-preset-or-file", 0, 1)
    with pytest.raises(FormatError, match="lo <= hi"):
        preset("mri", 5, 1)
    with pytest.raises(FormatError, match="table size"):
        preset("mri", 0, 1).table(0, 1, 0)


@pytest.mark.parametrize("name", PRESETS)
@pytest.mark.parametrize("lo, hi", [(-1024, 3071), (0, 255), (-1.5, 2.5), (7, 7)])
def test_presets_are_valid(name, lo, hi):
    tf = load_tf(name, lo, hi)
    assert tf.name == name
    tab = tf.table(lo, hi)
    assert tab.shape == (256, 4) and np.all((tab >= 0) & (tab <= 1))
    if hi > lo:
        assert tab[0, 3] == 0 and tab[-1, 3] > 0  # background clear, top visible


def test_ct_presets_use_hounsfield_units_only_for_ct_like_ranges():
    ct = preset("ct-bone", -1024, 3071)
    assert ct.points[0][0] == -1000.0 and ct.points[-1][0] == 1500.0
    other = preset("ct-bone", 0, 4095)
    assert other.points[0][0] == 0.0 and other.points[-1][0] == 4095.0


def test_auto_choice():
    assert auto_tf(-1024, 3071, np.int16).name == "ct-bone"
    assert auto_tf(-1000.0, 2000.0, np.float32).name == "ct-bone"
    assert auto_tf(0, 255, np.uint8).name == "mri"
    assert auto_tf(0, 4095, np.uint16).name == "mri"
    assert auto_tf(-3.0, 4.0, np.float32).name == "generic"
    assert auto_tf(-20, 400, np.int16).name == "generic"
    assert load_tf("auto", 0, 255, dtype=np.uint8).name == "mri"


def test_render_package_import_is_light():
    code = (
        "import sys, volpack.render, volpack.render.transfer as t\n"
        "t.load_tf('ct-bone', -1024, 3071).table(-1024, 3071)\n"
        "assert 'numba' not in sys.modules, 'numba imported'\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True, capture_output=True)


# -- pre-integration --------------------------------------------------------------------


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("length", [0.25, 1.0, 3.7])
def test_diagonal_matches_closed_form(rng, method, length):
    tab = random_table(rng, 17)
    out = preintegrate(tab, length, method)
    diag = out[np.arange(17), np.arange(17)]
    a = 1 - (1 - tab[:, 3]) ** length
    np.testing.assert_allclose(diag[:, 3], a, rtol=1e-6, atol=1e-7)
    np.testing.assert_allclose(diag[:, :3], tab[:, :3] * a[:, None], rtol=1e-6, atol=1e-7)


@pytest.mark.parametrize("amax", [0.05, 0.5, 0.95, 1.0])
@pytest.mark.parametrize("length", [0.5, 2.0])
def test_exact_matches_brute_force_reference(rng, amax, length):
    tab = random_table(rng, 9, amax)
    if amax == 1.0:
        tab[3, 3] = 1.0  # a fully opaque entry
    ref = render_preint_reference(tab, length, steps=3000)
    out = preintegrate(tab, length, "exact")
    np.testing.assert_allclose(out, ref, atol=1e-3, rtol=0)


@pytest.mark.parametrize("length", [0.5, 1.0])
def test_fast_matches_reference_for_low_opacity(rng, length):
    tab = random_table(rng, 9, 0.05)
    ref = render_preint_reference(tab, length, steps=1000)
    out = preintegrate(tab, length, "fast")
    np.testing.assert_allclose(out, ref, atol=1e-3, rtol=0)
    # opacity is exact in both methods: the extinction integral has a closed form
    np.testing.assert_allclose(out[..., 3], ref[..., 3], atol=1e-6, rtol=0)


def test_fast_is_exact_for_constant_colour(rng):
    tab = random_table(rng, 12)
    tab[:, :3] = [0.2, 0.6, 0.9]
    fast = preintegrate(tab, 1.5, "fast")
    exact = preintegrate(tab, 1.5, "exact")
    np.testing.assert_allclose(fast, exact, atol=2e-6)


def test_engel_is_the_first_order_of_fast(rng):
    tab = random_table(rng, 12, 0.002)
    engel = preintegrate(tab, 1.0, "engel")
    fast = preintegrate(tab, 1.0, "fast")
    np.testing.assert_allclose(engel, fast, atol=1e-5)
    opaque = preintegrate(random_table(rng, 12, 1.0), 4.0, "engel")
    assert np.any(opaque[..., :3] > opaque[..., 3:])  # why it is not the default


@pytest.mark.parametrize("method", METHODS)
@given(
    tab=arrays(np.float64, st.tuples(st.integers(1, 12), st.just(4)), elements=st.floats(0, 1)),
    length=st.floats(0, 20),
)
def test_table_invariants(method, tab, length):
    out = preintegrate(tab, length, method)
    assert out.dtype == np.float32 and out.shape == (len(tab), len(tab), 4)
    assert np.all(np.isfinite(out))
    a = out[..., 3]
    np.testing.assert_array_equal(a, a.T)  # opacity does not depend on the direction
    assert np.all((a >= 0) & (a <= 1))
    assert np.all(out[..., :3] >= 0) and np.all(out[..., :3] <= a[..., None])


def test_fast_and_exact_share_the_opacity(rng):
    tab = random_table(rng, 40, 0.7)
    np.testing.assert_allclose(
        preintegrate(tab, 0.8, "fast")[..., 3], preintegrate(tab, 0.8, "exact")[..., 3], atol=1e-7
    )


def test_exact_colour_depends_on_direction():
    # red and blue, both nearly opaque: what you see is what is in front
    tab = np.array([[1, 0, 0, 0.999], [0, 0, 1, 0.999]])
    out = preintegrate(tab, 4.0, "exact")
    assert out[0, 1, 0] > 0.9 and out[0, 1, 2] < 0.1
    assert out[1, 0, 2] > 0.9 and out[1, 0, 0] < 0.1
    fast = preintegrate(tab, 4.0, "fast")
    np.testing.assert_allclose(fast[0, 1], fast[1, 0])  # fast ignores the order


@pytest.mark.parametrize("method", METHODS)
def test_length_scaling_agrees_with_opacity_correction(rng, method):
    tab = random_table(rng, 10)
    one = preintegrate(tab, 1.0, method)
    for length in (0.1, 0.5, 2.5):
        other = preintegrate(tab, length, method)
        i = np.arange(10)
        np.testing.assert_allclose(
            other[i, i, 3], opacity_correct(one[i, i, 3].astype(np.float64), length), atol=2e-6
        )


@pytest.mark.parametrize("method", METHODS)
def test_extreme_extinction_is_finite(method):
    tab = np.array(
        [[1, 1, 1, 1.0], [0.5, 0.2, 0.1, 1 - 1e-12], [0, 1, 0, 0.0], [1, 0, 1, 1.0], [0, 0, 1, 0.5]]
    )
    for length in (1e-3, 1.0, 1000.0):
        out = preintegrate(tab, length, method)
        assert np.all(np.isfinite(out))
        assert np.all(out[..., :3] <= out[..., 3:]) and np.all(out <= 1)
    out = preintegrate(tab, 1.0, method)
    assert out[0, 0, 3] == 1.0 and out[0, 3, 3] == 1.0


@pytest.mark.parametrize("method", METHODS + ("engel",))
def test_zero_length_gives_zeros(rng, method):
    out = preintegrate(random_table(rng, 7), 0.0, method)
    assert not np.any(out)


def test_interpreted_exact_kernel_agrees(rng):
    tab = random_table(rng, 6, 0.9)
    tau = preint.extinction(tab[:, 3])
    col = np.ascontiguousarray(tab[:, :3])
    want = np.empty((6, 6, 4), np.float32)
    preint._preint_exact_kernel(tau, col, 1.3, want)
    got = np.empty_like(want)
    interpreted = getattr(preint._preint_exact_kernel, "py_func", preint._preint_exact_kernel)
    interpreted(tau, col, 1.3, got)
    np.testing.assert_allclose(got, want, atol=1e-7)


def test_single_entry_and_errors():
    out = preintegrate([[0.5, 0.5, 0.5, 0.5]], 1.0, "exact")
    np.testing.assert_allclose(out[0, 0], [0.25, 0.25, 0.25, 0.5])
    with pytest.raises(FormatError, match="shape"):
        preintegrate(np.zeros((4, 3)), 1.0)
    with pytest.raises(FormatError, match=">= 0"):
        preintegrate(np.zeros((4, 4)), -1.0)
    with pytest.raises(FormatError, match="method"):
        preintegrate(np.zeros((4, 4)), 1.0, "slow")
    with pytest.raises(FormatError, match=r"\[0, 1\]"):
        preintegrate(np.full((4, 4), 2.0), 1.0)


# -- pre-integrated lighting and table updates ---------------------------------------------


@pytest.mark.parametrize("amax", [0.1, 0.9, 1.0])
@pytest.mark.parametrize("length", [0.5, 2.0])
def test_exact_lighting_table_matches_brute_force(rng, amax, length):
    tab = random_table(rng, 8, amax)
    ref = render_preint_reference(tab, length, steps=3000, lighting=True)
    out = preintegrate(tab, length, "exact", lighting=True)
    np.testing.assert_allclose(out, ref, atol=1.5e-3, rtol=0)
    # the lighting channels ride along: the first four are the plain table, bit for bit
    assert np.array_equal(out[..., :4], preintegrate(tab, length, "exact"))


@pytest.mark.parametrize("method", METHODS)
def test_lighting_table_invariants(rng, method):
    out = preintegrate(random_table(rng, 33), 1.7, method, lighting=True)
    c, b = out[..., :3], out[..., 4:]
    assert np.all(b >= 0) and np.all(b <= c)
    # rising and falling segments over the same constant-emission stretch put their
    # emission centroid on opposite sides of the middle
    flat = np.tile([[0.4, 0.6, 0.2, 0.05]], (9, 1))
    t = preintegrate(flat, 1.0, method, lighting=True)
    np.testing.assert_allclose(t[..., 4:], t[..., :3] / 2, rtol=2e-2 if method == "exact" else 1e-6)
    # an emitting back end: the centroid sits near the back of the segment
    ramp = np.zeros((5, 4))
    ramp[:, :3] = 1.0
    ramp[4, 3] = 0.5
    t = preintegrate(ramp, 1.0, method, lighting=True)
    assert t[0, 4, 4] > 0.6 * t[0, 4, 0] and t[4, 0, 4] < 0.4 * t[4, 0, 0]


def test_fast_lighting_matches_reference_for_low_opacity(rng):
    tab = random_table(rng, 9, 0.03)
    ref = render_preint_reference(tab, 1.0, steps=1000, lighting=True)
    out = preintegrate(tab, 1.0, "fast", lighting=True)
    np.testing.assert_allclose(out[..., 4:], ref[..., 4:], atol=2e-3)


@pytest.mark.parametrize("method", METHODS)
@pytest.mark.parametrize("lighting", [False, True])
def test_local_table_update_equals_a_fresh_build(rng, method, lighting):
    n = 40
    tab = random_table(rng, n, 0.9)
    up = TableUpdater(tab, 1.3, method, lighting=lighting)
    assert np.array_equal(up.table, preintegrate(tab, 1.3, method, lighting=lighting))
    for k0, k1 in [(0, 1), (17, 19), (39, 40), (5, 33)]:
        tab = tab.copy()
        tab[k0:k1] = rng.uniform(0, 0.9, (k1 - k0, 4))
        count = up.update(tab)
        assert count == n * n - k0 * k0 - (n - k1) ** 2
        assert np.array_equal(up.table, preintegrate(tab, 1.3, method, lighting=lighting))
    assert up.update(tab) == 0
    with pytest.raises(FormatError, match="shape"):
        up.update(tab[:-1])
    with pytest.raises(FormatError, match="method"):
        TableUpdater(tab, 1.0, "engel")


def test_opacity_correct():
    assert opacity_correct(0.5, 2) == pytest.approx(0.75)
    assert opacity_correct(1.0, 0.01) == 1.0 and opacity_correct(1.0, 0) == 0.0
    assert opacity_correct(1e-12, 3) == pytest.approx(3e-12, rel=1e-9)
    a = np.array([0, 0.3, 1], np.float32)
    out = opacity_correct(a, 0.5)
    assert out.dtype == np.float32
    np.testing.assert_allclose(out, 1 - (1 - a.astype(np.float64)) ** 0.5, rtol=1e-6)
    with pytest.raises(FormatError):
        opacity_correct(1.5, 1)


# -- isosurfaces ------------------------------------------------------------------------


def test_iso_table_picks_the_first_crossed_iso(rng):
    isos = [(0.7, (0, 0, 1), 0.5), (0.2, (1, 0, 0), 1.0), (0.45, (0, 1, 0), 0.25)]
    n = 21  # values 0, 0.05, ..., 1: isos 0.2, 0.45, 0.7 sit exactly on entries 4, 9, 14
    values = list(np.linspace(0, 1, n))
    table = iso_table(n, 0.0, 1.0, isos)
    order = sorted(range(3), key=lambda q: isos[q][0])
    want = render_iso_reference(values, [isos[q] for q in order])
    prem = np.array([[*(np.array(isos[q][1]) * isos[q][2]), isos[q][2]] for q in order])
    for f in range(n):
        for b in range(n):
            k = want[f][b]
            np.testing.assert_allclose(table[f, b], prem[k] if k >= 0 else 0, atol=1e-7)
    # rising from 0.1 to 0.9 meets 0.2 first; falling from 0.9 to 0.1 meets 0.7 first
    assert table[2, 18, 3] == 1.0 and table[18, 2, 3] == 0.5
    # half-open: a segment ending on an iso hits it, one starting on it does not
    assert table[3, 4, 3] == 1.0 and table[4, 5, 3] == 0.0
    assert table[5, 4, 3] == 1.0 and table[4, 3, 3] == 0.0
    assert not np.any(table[np.arange(n), np.arange(n)])


def test_iso_hits_index_and_weight():
    hit, w = iso_hits(11, 0.0, 10.0, [(2.5, (1, 1, 1), 1.0)])
    assert hit[0, 10] == 0 and w[0, 10] == pytest.approx(0.25)
    assert hit[10, 0] == 0 and w[10, 0] == pytest.approx(0.75)
    assert hit[3, 10] == -1 and w[3, 10] == 0
    assert iso_table(5, 0, 1, []).shape == (5, 5, 4)
    with pytest.raises(FormatError, match="isosurface 0"):
        iso_table(5, 0, 1, [(0.5, (1, 1), 2.0)])


def _linear_reads(x, n):
    """Entries a clamped linear look-up at ``x`` reads with a non-zero weight, plus the
    lower one (what the kernel loads)."""
    q = min(max(x, 0.0), n - 1.0)
    i = int(q)
    return {i, min(i + 1, n - 1)} if q - i > 0 else {i}


@pytest.mark.parametrize("seed", range(6))
def test_clear_bounds_skip_only_zero_look_ups(seed):
    from volpack.render.raycast import clear_bounds

    rng = np.random.default_rng(seed)
    n = 12
    tab = np.zeros((n, 4), np.float32)
    a, b = sorted(rng.integers(0, n, 2))
    tab[a : b + 1] = rng.uniform(0.1, 1, (b + 1 - a, 4))
    tab2 = preintegrate(tab, 0.5)
    xs = np.concatenate([rng.uniform(-2, n + 1, 300), np.arange(-1, n + 1, 0.5)])
    for t in (tab, tab2):
        below, above = clear_bounds(t)
        hit = 0
        for x in xs:
            for y in xs[:40] if t.ndim == 3 else [None]:
                skip = (x < below and (y is None or y < below)) or (
                    x > above and (y is None or y > above))  # fmt: skip
                if not skip:
                    continue
                hit += 1
                if y is None:
                    assert not t[sorted(_linear_reads(x, n))].any(), (x, below, above)
                else:
                    rows, cols = _linear_reads(x, n), _linear_reads(y, n)
                    assert not t[np.ix_(sorted(rows), sorted(cols))].any(), (x, y, below, above)
        assert hit > 0 or (a == 0 and b == n - 1)
    assert list(clear_bounds(np.zeros((4, 4)))) == [np.inf, -np.inf]
    assert list(clear_bounds(np.ones((4, 4, 4)))) == [-np.inf, np.inf]
