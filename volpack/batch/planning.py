"""Planning a batch: globs, folders and manifests -> :class:`Task` objects (one input, one
output, the options for it), and the option names and types a task takes."""

import csv
import dataclasses
import glob
import hashlib
import json
import os
from collections.abc import Sequence
from typing import Any

from ..errors import OptionError, VolpackError

JOURNAL_NAME = ".volpack-batch.jsonl"
COMPRESS_KEYS = (
    "codec",
    "wavelet",
    "coder",
    "order",
    "max_levels",
    "brick",
    "max_error",
    "rel_error",
    "psnr",
    "ratio",
    "quality",
    "threshold",
    "fill_value",
    "effort",
    "workers",
)
LOSSY_KEYS = ("max_error", "rel_error", "psnr", "ratio", "quality", "threshold")
READ_KEYS = ("shape", "dtype", "byteorder", "offset")
OPTION_KEYS = COMPRESS_KEYS + READ_KEYS
_FLOAT_KEYS = {"max_error", "rel_error", "psnr", "ratio", "threshold", "fill_value"}
_INT_KEYS = {"max_levels", "quality", "workers", "offset"}
_UNHASHED = {"workers"}  # the output does not depend on them
MANIFEST_EXTS = (".csv", ".json")


class BatchError(VolpackError, ValueError):
    """A batch cannot start: nothing matches, two inputs share an output, no access..."""


@dataclasses.dataclass(frozen=True)
class Task:
    """One conversion: ``input`` (a volume spec, or a ``.vpk`` for ``kind="decompress"``),
    ``output`` (a path), ``options`` (compress and raw-read options), how to check it."""

    input: str
    output: str
    options: dict = dataclasses.field(default_factory=dict)
    kind: str = "compress"
    verify: str = "decode"
    force: bool = False

    @property
    def options_hash(self) -> str:
        opts = {k: v for k, v in self.options.items() if k not in _UNHASHED}
        blob = json.dumps({"kind": self.kind, "options": opts}, sort_keys=True, default=str)
        return hashlib.sha256(blob.encode()).hexdigest()[:16]


# -- planning --------------------------------------------------------------------------


def plan(
    inputs: str | Sequence[str],
    out_dir: str,
    *,
    suffix: str = ".vpk",
    options: dict | None = None,
    kind: str = "compress",
    verify: str = "decode",
    skipped: list[tuple[str, str]] | None = None,
) -> list[Task]:
    """Expand ``inputs`` into tasks writing under ``out_dir``.

    Each input is a glob (``**`` recurses; ``'run/*.h5:/T'`` keeps the dataset), a
    folder (every readable volume under it; hidden files, raw files without a
    ``shape`` option and, for compression, ``.vpk`` files are left out; folders of
    slices are not volumes here: name them, or list them in a manifest), a file, or a
    ``.csv``/``.json`` manifest (column ``input``, optional ``output`` relative to
    ``out_dir`` (a relative one may not climb out of it; an absolute one is taken as
    it is), optional per-file options overriding ``options``; inputs relative to
    the manifest's folder). Outputs mirror the inputs' tree below their common root,
    the volume extension replaced by ``suffix``. An input named twice is planned once;
    two inputs mapping to one output raise :class:`BatchError`. Files a glob or a folder
    finds but leaves out (meshes, files of no known format, ``.vpk`` or raw files that
    cannot be taken) are appended to ``skipped`` as ``(path, reason)`` when it is given.
    """
    from .. import io as vio

    if kind not in ("compress", "decompress"):
        raise OptionError(f"expected kind 'compress' or 'decompress', found {kind!r}")
    if verify not in ("decode", "checksum"):
        raise OptionError(f"expected verify 'decode' or 'checksum', found {verify!r}")
    if isinstance(inputs, (str, os.PathLike)):
        inputs = [os.fspath(inputs)]
    base_opts = normalize_options(options or {})
    out_abs = os.path.abspath(out_dir)
    # (spec, root folder, per-file options, explicit output)
    entries: list[tuple[str, str, dict, str | None]] = []
    for inp in inputs:
        inp = os.fspath(inp)
        path, inner = vio.parse_spec(inp)
        tail = f":{inner}" if inner else ""
        if path.lower().endswith(MANIFEST_EXTS) and os.path.isfile(path):
            entries += _read_manifest(path)
        elif glob.has_magic(path):
            found = [
                m + tail
                for m in sorted(glob.glob(path, recursive=True))
                if _selectable(m, kind, base_opts, out_abs, tree=False, skipped=skipped)
            ]
            if not found:
                raise BatchError(f"expected volumes matching {inp!r}, found none")
            entries += [(m, _glob_root(path), {}, None) for m in found]
        elif os.path.isdir(path):
            found = _walk(path, kind, base_opts, out_abs, skipped)
            if not found:
                raise BatchError(f"expected readable volumes under the folder {path!r}, found none")
            entries += [(m, path, {}, None) for m in found]
        elif os.path.exists(path):
            entries.append((inp, os.path.dirname(path) or ".", {}, None))
        else:
            raise BatchError(f"expected a file, folder, glob or manifest, found nothing at {inp!r}")
    if not entries:
        raise BatchError("expected at least one input, found none")

    root = os.path.commonpath([os.path.abspath(r) for _, r, _, _ in entries])
    tasks: list[Task] = []
    seen_inputs: set[tuple[str, str | None]] = set()
    owner: dict[str, str] = {}
    for spec, _, per_file, explicit in entries:
        path, inner = vio.parse_spec(spec)
        key = (os.path.realpath(path), inner)
        if key in seen_inputs:
            continue
        seen_inputs.add(key)
        if explicit:
            if kind == "compress":  # a .vpk named ct.nii.gz misleads every other program
                from ..api import check_vpk_name

                check_vpk_name(explicit, "a manifest's output", "batch compresses to .vpk")
            out = explicit if os.path.isabs(explicit) else os.path.join(out_dir, explicit)
        else:
            rel = os.path.relpath(os.path.abspath(path), root)
            out = os.path.join(out_dir, strip_volume_ext(rel) + suffix)
        out = os.path.normpath(out)
        other = owner.get(os.path.abspath(out))
        if other is not None:
            raise BatchError(f"inputs {other!r} and {spec!r} would both be written to {out!r}")
        owner[os.path.abspath(out)] = spec
        opts = dict(base_opts)
        if any(k in per_file for k in LOSSY_KEYS):
            opts = {k: v for k, v in opts.items() if k not in LOSSY_KEYS}
        opts.update(per_file)
        tasks.append(Task(spec, out, opts, kind, verify))
    inputs_abs = {os.path.realpath(vio.parse_spec(t.input)[0]) for t in tasks}
    for t in tasks:
        if os.path.realpath(t.output) in inputs_abs:
            raise BatchError(f"output {t.output!r} would overwrite an input; choose another folder")
    return tasks


def normalize_options(options: dict) -> dict:
    """Drop unset options and convert strings (a CSV cell) to the types the API takes."""
    out: dict[str, Any] = {}
    for k, v in options.items():
        if k not in OPTION_KEYS:
            # quoted: they are a manifest's columns and the API's names, not flags
            known = ", ".join(repr(k) for k in OPTION_KEYS)
            raise BatchError(f"expected options among {known}, found {k!r}")
        if v is None or (isinstance(v, str) and not v.strip()):
            continue
        try:
            if k in _FLOAT_KEYS:
                v = float(v)
            elif k in _INT_KEYS:
                v = int(v)
            elif k in ("brick", "shape") and isinstance(v, str):
                nums = tuple(int(p) for p in v.replace("x", ",").split(","))
                v = nums[0] if len(nums) == 1 and k == "brick" else nums
            elif isinstance(v, list):
                v = tuple(v)
        except ValueError:
            raise BatchError(f"expected a number for option {k!r}, found {v!r}") from None
        out[k] = v
    return out


def strip_volume_ext(path: str) -> str:
    """``a/b.nii.gz`` -> ``a/b`` (the longest known volume extension, if any)."""
    from ..io.registry import extensions

    low = path.lower()
    for ext in sorted(extensions(), key=len, reverse=True):
        if low.endswith(ext):
            return path[: -len(ext)]
    return path


def _glob_root(pattern: str) -> str:
    parts = []
    for part in pattern.split(os.sep):
        if glob.has_magic(part):
            break
        parts.append(part)
    root = os.sep.join(parts)
    if root == pattern:  # pragma: no cover - has_magic said otherwise
        root = os.path.dirname(pattern)
    return root or ("/" if pattern.startswith(os.sep) else ".")


def _selectable(path: str, kind: str, opts: dict, out_abs: str, tree: bool, skipped=None) -> bool:
    """Whether a path found by a glob (``tree=False``) or a walk is an input to take;
    a file left out that a user may have meant is noted in ``skipped``."""
    why = _left_out(path, kind, opts, out_abs, tree)
    if why and skipped is not None and os.path.isfile(path):
        skipped.append((path, why))
    return why is None


def _left_out(path: str, kind: str, opts: dict, out_abs: str, tree: bool) -> str | None:
    """Why a found path is not an input ('' for ones not worth saying: hidden files, the
    output folder, the .img of an Analyze pair), or None to take it."""
    from .. import io as vio
    from ..tetra import is_mesh_path

    if os.path.basename(path).startswith("."):
        return ""
    try:
        fmt = vio.detect_format(path)
    except (VolpackError, OSError):
        if is_mesh_path(path):
            return "a mesh (compress it on its own: volpack compress)"
        return "not a volume format volpack reads"
    if kind == "decompress":
        return None if fmt == "vpk" and os.path.isfile(path) else "not a .vpk"
    if os.path.isdir(path):
        return None if not tree else ""
    if tree and fmt == "vpk":
        return "already a .vpk"
    if fmt == "raw" and "shape" not in opts:
        return "raw voxels without --shape and --dtype"
    if path.lower().endswith(".img") and os.path.exists(path[:-4] + ".hdr"):
        return ""  # the Analyze pair is read through its .hdr
    return "" if os.path.abspath(path).startswith(out_abs + os.sep) else None


def _walk(folder: str, kind: str, opts: dict, out_abs: str, skipped=None) -> list[str]:
    from ..io.registry import is_zarr_store

    found = []
    for here, dirs, files in os.walk(folder):
        dirs[:] = sorted(
            d
            for d in dirs
            if not d.startswith(".") and os.path.abspath(os.path.join(here, d)) != out_abs
        )
        if kind != "decompress":  # a zarr store is one input, not a tree of chunk files
            stores = {d for d in dirs if is_zarr_store(os.path.join(here, d))}
            found += [os.path.join(here, d) for d in sorted(stores)]
            dirs[:] = [d for d in dirs if d not in stores]
        for name in sorted(files):
            p = os.path.join(here, name)
            if _selectable(p, kind, opts, out_abs, tree=True, skipped=skipped):
                found.append(p)
    return found


def _leaves_out_dir(output: str) -> bool:
    """Whether a manifest's relative output climbs out of OUT_DIR (``../x.vpk``): a
    shared manifest must not write beside the folder it was given. Absolute outputs
    are asked for by name and stay allowed."""
    if os.path.isabs(output):
        return False
    first = os.path.normpath(output).split(os.sep)[0]
    return first == os.pardir


def _read_manifest(path: str) -> list[tuple[str, str, dict, str | None]]:
    base = os.path.dirname(path)
    try:
        if path.lower().endswith(".json"):
            with open(path, encoding="utf-8-sig") as f:  # (a BOM, as some editors write)
                rows = json.load(f)
            if isinstance(rows, dict):
                rows = rows.get("files")
            if not isinstance(rows, list) or not all(isinstance(r, dict) for r in rows):
                raise BatchError(
                    f"expected a JSON list of objects (or {{'files': [...]}}) in {path!r}"
                )
        else:
            with open(path, newline="", encoding="utf-8-sig") as f:  # Excel's "CSV UTF-8"
                rows = list(csv.DictReader(f))
    except (json.JSONDecodeError, csv.Error, UnicodeDecodeError) as e:
        raise BatchError(f"cannot read the manifest {path!r}: {e}") from None
    out = []
    for n, row in enumerate(rows, 1):
        row = {str(k).strip(): v for k, v in row.items() if k is not None}
        spec = str(row.pop("input", "") or "").strip()
        if not spec:
            raise BatchError(f"expected an 'input' in every row of {path!r}, row {n} has none")
        explicit = str(row.pop("output", "") or "").strip() or None
        if explicit and _leaves_out_dir(explicit):
            raise BatchError(
                f"{path!r} row {n}: expected an output inside OUT_DIR (or an absolute path), "
                f"found {explicit!r}"
            )
        try:
            per_file = normalize_options(row)
        except BatchError as e:
            raise BatchError(f"{path!r} row {n}: {e}") from None
        if not os.path.isabs(spec):
            spec = os.path.join(base, spec)
        from ..io import parse_spec

        if not os.path.exists(parse_spec(spec)[0]):
            raise BatchError(f"{path!r} row {n}: expected an input, found nothing at {spec!r}")
        out.append((spec, os.path.dirname(parse_spec(spec)[0]) or ".", per_file, explicit))
    return out
