"""Plain, strict JSON values: what headers, journals and reports store.

JSON has no spelling for NaN and the infinities, and the json module knows neither numpy
scalars nor arrays; :func:`jsonable` turns any nested value into dicts, lists, strings,
numbers, booleans and None.
"""

from __future__ import annotations

import math
from typing import Any


def jsonable(value: Any) -> Any:
    """``value`` as plain JSON types, recursively: numpy scalars and arrays become Python
    numbers and lists, tuples lists, keys strings, non-finite floats None, and any other
    object its ``str``."""
    if isinstance(value, dict):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [jsonable(v) for v in value]
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, (str, int, float, bool)) or value is None:
        return value
    if hasattr(value, "tolist"):  # numpy arrays and scalars (numpy is not imported here)
        return jsonable(value.tolist())
    return str(value)
