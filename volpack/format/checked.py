"""The base of the stream kinds' readers: a container :class:`~volpack.format.container.Reader`
whose header the kind has checked, closed when the reader is."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from ..errors import reading
from .container import Reader


class CheckedReader:
    """Open ``source`` (a path, bytes, a binary file, or a Reader to take over) and keep
    ``check(header, *args)`` as :attr:`header`; the container is closed if the check fails."""

    def __init__(self, source: Any, check: Callable[..., dict], *args: Any) -> None:
        self._r = source if isinstance(source, Reader) else Reader(source)
        try:
            with reading(self._r.path):
                self.header = check(self._r.header, *args)
        except BaseException:
            self._r.close()
            raise

    def close(self) -> None:
        self._r.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.close()
