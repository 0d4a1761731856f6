"""What the session-39 probes share (rend39): a volume prepared as the peers benchmark
prepares it, its TF and the benchmark's first view (azimuth 30, 512^2)."""

import contextlib
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "scripts"))
sys.path.insert(0, str(ROOT / "results" / "render" / "rend37"))
import bench_render_peers as peers  # noqa: E402
from probe import load  # noqa: E402

from volpack.render.camera import Camera  # noqa: E402
from volpack.render.prepared import prepare_volume  # noqa: E402
from volpack.render.transfer import TransferFunction  # noqa: E402


def first_view(name, tfk):
    """``(short name, prepared volume, TF, camera)`` of volume file ``name``, TF ``tfk``."""
    vol, sp = load(name)
    prep = prepare_volume(vol, sp)
    tf = TransferFunction(points=peers.tf_points(tfk, *peers.tf_base(vol)))
    cam = Camera(azimuth=30.0, elevation=peers.ELEVATION, size=(512, 512))
    return Path(name).name.split(".")[0], prep, tf, cam


def interleaved_cpu(runs, rounds):
    """``{key: [CPU seconds, ...]}`` of calling each of ``runs`` (``{key: callable}``)
    ``rounds`` times, one round of all after another (so load drifts hit all alike)."""
    times = {k: [] for k in runs}
    for _ in range(rounds):
        for k, fn in runs.items():
            c = time.process_time()
            fn()
            times[k].append(time.process_time() - c)
    return times


@contextlib.contextmanager
def knobs(module, values):
    """Module constants ``values`` (``{name: value}``) set for the block, then restored."""
    old = {a: getattr(module, a) for a in values}
    for a, v in values.items():
        setattr(module, a, v)
    try:
        yield
    finally:
        for a, v in old.items():
            setattr(module, a, v)
