"""Who wants to know when numba compiles: a subscriber list that imports no numba.

The CLI subscribes before any kernel module is loaded (so ``volpack --help`` still
imports no numba); :mod:`volpack._jit` forwards numba's compile events here once numba
is loaded. A subscriber is called as ``fn(event, name, seconds)`` with ``event`` one of
``"start"`` (``seconds`` None) and ``"end"`` (``seconds`` the compiling thread's CPU
time, callees included), from the thread that compiles.
"""

from __future__ import annotations

from collections.abc import Callable

Subscriber = Callable[[str, str, "float | None"], None]

_subscribers: list[Subscriber] = []
# Set by volpack._jit at import: whether this source tree's kernel cache was empty, i.e.
# every kernel used from now on compiles (a first run). None until numba is loaded.
fresh_cache: bool | None = None
cache_dir: str | None = None


def subscribe(fn: Subscriber) -> None:
    _subscribers.append(fn)


def unsubscribe(fn: Subscriber) -> None:
    if fn in _subscribers:
        _subscribers.remove(fn)


def notify(event: str, name: str, seconds: float | None = None) -> None:
    for fn in list(_subscribers):
        fn(event, name, seconds)
