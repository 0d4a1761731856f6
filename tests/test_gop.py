"""GOP strings, storage order, references and the one-decode-per-step playback."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from volpack.animation import gop
from volpack.errors import FormatError


def test_thesis_example():
    types = gop.frame_types("IBBPBBPBB", 13)
    assert types == "IBBPBBPBBIBBP"
    assert gop.storage_order(types)[:10] == [0, 3, 1, 2, 6, 4, 5, 9, 7, 8]
    refs = gop.references(types)
    assert refs[0] == (None, None) and refs[3] == (0, None) and refs[1] == (0, 3)
    assert refs[7] == (6, 9)  # open GOP: B-frames lean on the next group's I-frame
    assert refs[9] == (None, None)
    sched = dict(gop.schedule(types))
    assert sched[0] == [0, 3] and sched[1] == [1] and sched[3] == [6] and sched[6] == [9]
    assert sched[9] == [12]
    assert gop.needed(types, 8) == [0, 3, 6, 9, 8]


def test_trailing_b_frames_get_a_following_anchor():
    assert gop.frame_types("IBB", 3) == "IBP"
    assert gop.frame_types("IBBPBB", 5) == "IBBPP"
    assert gop.frame_types("IBB", 1) == "I"
    assert gop.frame_types("IBB", 2) == "IP"
    types = gop.frame_types("IBBPBB", 6)
    assert types == "IBBPBP" and gop.references(types)[4] == (3, 5)


@pytest.mark.parametrize("bad", ["", "PBB", "IXB", "BI", None, 3])
def test_invalid_gop_strings(bad):
    with pytest.raises(FormatError, match="GOP"):
        gop.parse_gop(bad)


def test_lowercase_gop_is_accepted():
    assert gop.parse_gop("ibbp") == "IBBP"


@given(st.from_regex(r"\AI[IPB]{0,10}\Z"), st.integers(1, 40))
def test_schedule_one_decode_per_step(g, n):
    types = gop.frame_types(g, n)
    order = gop.storage_order(types)
    assert sorted(order) == list(range(n))
    pos = {t: i for i, t in enumerate(order)}
    for t, (p, q) in enumerate(gop.references(types)):
        for r in (p, q):  # references come first in storage and are anchors
            assert r is None or (pos[r] < pos[t] and types[r] in "IP")
    decoded: list[int] = []

    def decode(t, prev, nxt):
        p, q = gop.references(types)[t]
        assert (prev is None) == (p is None) and (nxt is None) == (q is None)
        assert prev is None or int(prev) == p
        assert nxt is None or int(nxt) == q
        decoded.append(t)
        return np.array(t)

    shown = []
    for step, (t, frame) in enumerate(gop.play(types, decode)):
        assert t == step and int(frame) == t
        # two decodes before step 0 is shown, then exactly one per step
        assert len(decoded) == min(2 + step, n)
        shown.append(t)
    assert shown == list(range(n)) and decoded == order


def test_play_keeps_few_frames():
    types = gop.frame_types("IBBPBBPBB", 60)
    alive: set[int] = set()
    peak = 0

    class Frame:
        def __init__(self, t):
            self.t = t
            alive.add(t)

        def __del__(self):
            alive.discard(self.t)

    for _t, f in gop.play(types, lambda t, p, n: Frame(t)):
        peak = max(peak, len(alive))
        del f
    assert peak <= 4  # two anchors, the next anchor being prepared, the frame shown
