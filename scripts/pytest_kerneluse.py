"""pytest plugin: which compiled kernel signatures each test runs, to find the fast tests
that alone need a costly signature (they belong in the slow set).

After each test it lists every volpack numba dispatcher's loaded signatures, appends one
row per signature to ``$VOLPACK_TEST_KERNEL_USE`` (default
``results/test_kernel_use.csv``: test, kernel, argument types), then forgets them, so
the next test that runs one loads it again from the (warm) cache and is listed too.
Dispatchers held in module globals and in dicts of module globals are seen (the ray
caster's marches live in one); helpers called only from other kernels are not.

    PYTHONPATH=scripts pytest -p pytest_kerneluse -n 0 -p no:cacheprovider   # warm cache
    python scripts/pytest_kerneluse.py results/test_kernel_use.csv KERNELS.csv

The second command joins the rows with a ``$VOLPACK_TEST_KERNELS`` file of
``pytest_cputime`` (compile CPU per signature, from a run on an empty cache) and prints
the costliest signatures with their users (those with at most 8 listed by name).
"""

from __future__ import annotations

import csv
import os
import sys
from collections import defaultdict

import pytest

_PATH = os.environ.get("VOLPACK_TEST_KERNEL_USE", "results/test_kernel_use.csv")


def _dispatchers() -> list:
    from numba.core.registry import CPUDispatcher

    found = {}
    for name, mod in list(sys.modules.items()):
        if not name.startswith("volpack") or mod is None:
            continue
        for v in list(vars(mod).values()):
            for x in list(v.values()) if isinstance(v, dict) else [v]:
                if isinstance(x, CPUDispatcher):
                    found[id(x)] = x
    return list(found.values())


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item, nextitem):
    yield
    rows = []
    for d in _dispatchers():
        if not d.overloads:
            continue
        fn = d.py_func
        for sig in list(d.overloads):
            args = " ".join(str(sig).split()).replace('"', "'")
            rows.append((item.nodeid, f"{fn.__module__}.{fn.__qualname__}", args))
        d._clear()  # numba's own reset (as recompile() does): the next call loads again
        d.overloads.clear()
    with open(_PATH, "a", newline="") as f:
        csv.writer(f, quoting=csv.QUOTE_ALL).writerows(rows)


def summary(use_csv: str, kernels_csv: str, top: int = 40) -> None:
    cost: dict[tuple[str, str], float] = {}
    for k, a, _test, cpu in csv.reader(open(kernels_csv)):
        cost[k, a] = max(cost.get((k, a), 0.0), float(cpu))
    users: dict[tuple[str, str], set] = defaultdict(set)
    for test, k, a in csv.reader(open(use_csv)):
        users[k, a].add(test)
    for key in sorted(users, key=lambda k: -cost.get(k, 0.0))[:top]:
        ts = users[key]
        print(f"{cost.get(key, 0.0):6.1f} CPU s  {len(ts):4d} tests  {key[0]} {key[1][:60]}")
        if len(ts) <= 8:
            for t in sorted(ts):
                print(f"{'':26}{t}")


if __name__ == "__main__":
    summary(*sys.argv[1:3])
