"""Groups of pictures: frame types, storage order, references and the playback schedule.

A GOP string such as ``IBBPBBPBB`` repeats over the sequence: frame ``t`` (display order)
has type ``gop[t % len(gop)]``.

``I``  coded alone; an anchor.
``P``  predicted from the previous anchor (I or P) plus a coded residual; an anchor.
``B``  predicted from the previous and the next anchor; never a reference.

GOPs are open: the last B-frames of one group lean on the next group's I-frame. B-frames
at the end of a sequence have no next anchor, so the last of them becomes a P-frame
(the others become B-frames between the previous anchor and it).

Frames are stored in the order of their first use: each anchor, then the B-frames that
precede it in display order, e.g. ``I0 P3 B1 B2 P6 B4 B5 I9 B7 B8``. Decoding in that
order, two volumes before the first display and then exactly one per displayed frame
keeps every frame ready in time (:func:`schedule`, :func:`play`).
"""

from __future__ import annotations

from collections.abc import Callable, Iterator

import numpy as np

from ..errors import FormatError

TYPES = "IPB"
ANCHORS = "IP"


def parse_gop(gop: str) -> str:
    """Check a GOP string: letters I, P and B, starting with I."""
    if not isinstance(gop, str) or not gop:
        raise FormatError(f"expected a GOP string of I, P and B such as 'IBBPBB', found {gop!r}")
    g = gop.upper()
    bad = sorted(set(g) - set(TYPES))
    if bad:
        raise FormatError(f"expected a GOP of the letters I, P and B, found {bad} in {gop!r}")
    if g[0] != "I":
        raise FormatError(f"expected a GOP starting with an I-frame, found {gop!r}")
    return g


def frame_types(gop: str, n: int) -> str:
    """Type of each of ``n`` frames in display order (trailing B-frames fixed up)."""
    g = parse_gop(gop)
    if n < 1:
        raise FormatError(f"expected at least one frame, found {n}")
    types = [g[t % len(g)] for t in range(n)]
    if types[-1] == "B":
        types[-1] = "P"
    return "".join(types)


def check_types(types: str) -> str:
    """Check a per-frame type string read from a file."""
    if not isinstance(types, str) or not types or types[0] != "I" or types[-1] == "B":
        raise FormatError(
            f"expected frame types starting with I and not ending with B, found {types!r:.40}"
        )
    if set(types) - set(TYPES):
        raise FormatError(f"expected frame types of I, P and B, found {types!r:.40}")
    return types


def references(types: str) -> list[tuple[int | None, int | None]]:
    """``(previous anchor, next anchor)`` each frame is predicted from (display indices)."""
    out: list[tuple[int | None, int | None]] = []
    prev = None
    nxt_of = [None] * len(types)
    nxt = None
    for t in range(len(types) - 1, -1, -1):
        nxt_of[t] = nxt
        if types[t] in ANCHORS:
            nxt = t
    for t, c in enumerate(types):
        if c == "I":
            out.append((None, None))
        elif c == "P":
            out.append((prev, None))
        else:
            out.append((prev, nxt_of[t]))
        if c in ANCHORS:
            prev = t
    return out


def storage_order(types: str) -> list[int]:
    """Display indices in storage (= decoding) order: each anchor, then the B-frames
    that precede it."""
    order: list[int] = []
    pending: list[int] = []
    for t, c in enumerate(types):
        if c == "B":
            pending.append(t)
        else:
            order.append(t)
            order.extend(pending)
            pending = []
    return order


def needed(types: str, t: int) -> list[int]:
    """The frames that must be decoded to show frame ``t``, in decoding order: its
    anchors' chains back to an I-frame, then ``t`` itself."""
    refs = references(types)
    want: set[int] = set()
    stack = [t]
    while stack:
        f = stack.pop()
        if f in want:
            continue
        want.add(f)
        stack.extend(r for r in refs[f] if r is not None)
    pos = {f: i for i, f in enumerate(storage_order(types))}
    return sorted(want, key=pos.__getitem__)


def last_use(types: str) -> dict[int, int]:
    """For each anchor, the storage position of the last frame that references it: the
    moment an encoder or decoder may let go of it."""
    order = storage_order(types)
    refs = references(types)
    out = {t: i for i, t in enumerate(order) if types[t] in ANCHORS}
    for i, t in enumerate(order):
        for r in refs[t]:
            if r is not None:
                out[r] = max(out[r], i)
    return out


def schedule(types: str) -> list[tuple[int, list[int]]]:
    """``(display step, frames decoded during it)``: the first two frames in storage
    order before step 0, then one per step (step 0 decodes nothing more)."""
    order = storage_order(types)
    steps = [(0, order[:2])]
    steps += [(k, [order[k + 1]] if k + 1 < len(order) else []) for k in range(1, len(types))]
    return steps


def play(
    types: str, decode: Callable[[int, np.ndarray | None, np.ndarray | None], np.ndarray]
) -> Iterator[tuple[int, np.ndarray]]:
    """Yield ``(t, frame)`` in display order following :func:`schedule`.

    ``decode(t, prev, next)`` decodes frame ``t`` from its decoded anchors. Only the
    anchors still referenced and the frames not yet shown are kept.
    """
    refs = references(types)
    done: dict[int, np.ndarray] = {}
    release = last_use(types)
    upto = -1  # storage position of the last frame decoded
    for step, todo in schedule(types):
        for t in todo:
            p, n = refs[t]
            done[t] = decode(t, None if p is None else done[p], None if n is None else done[n])
            upto += 1
        if step not in done:  # cannot happen for a valid type string: the order guarantees it
            raise FormatError(f"playback schedule broken: frame {step} not decoded in time")
        frame = done[step]
        if types[step] == "B":
            del done[step]
        yield step, frame
        # anchors already shown whose last user has been decoded
        for a in [a for a in done if a <= step and release[a] <= upto]:
            del done[a]
