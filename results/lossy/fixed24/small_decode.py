"""Best-of-N decode time (process time) of small volumes, main's tree against this one:
each tree decodes in its own process (volpack imports lazily, so two trees cannot share
one), the two alternating ``--turns`` times so that a change of load hits both; the
streams and the decoded bytes of the two trees are compared too.

    python results/lossy/fixed24/small_decode.py /work/main /work/wt/fixed24
"""
import hashlib
import json
import os
import subprocess
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
SCRIPTS = os.path.join(HERE, "..", "..", "..", "scripts")


def cases():
    sys.path.insert(0, SCRIPTS)
    import datasets

    rng = np.random.default_rng(0)
    z, y, x = np.mgrid[:64, :64, :64]
    smooth = (1000 * np.sin(x / 9.0) * np.cos(y / 7.0) + 30 * z).astype(np.int16)
    noisy = (smooth + rng.integers(-20, 21, smooth.shape)).astype(np.int16)
    out = [("int16 64^3 smooth lossless", smooth, {}), ("int16 64^3 noisy lossless", noisy, {})]
    for name in ("eta_u", "cam_t", "storm_p", "contour_t", "mecca_t"):
        a = datasets.load(name)[0]
        span = float(a.max() - a.min())
        for rel in (1e-2, 1e-4):
            opts = dict(max_error=rel * span, effort="fast")
            out.append((f"{name} {'x'.join(map(str, a.shape))} fast {rel:g}", a, opts))
    return out


def worker(reps: int) -> None:
    from volpack import api

    res = {}
    for name, a, opts in cases():
        blob = api.compress_array(a, **opts)
        dec = api.decompress_array(blob)
        best = np.inf
        for _ in range(reps):
            t0 = time.process_time()
            api.decompress_array(blob)
            best = min(best, time.process_time() - t0)
        digest = hashlib.sha256(blob + dec.tobytes()).hexdigest()
        res[name] = (len(blob), best, digest)
    print(json.dumps(res))


def main(main_tree: str, branch: str, turns: int = 5, reps: int = 60) -> None:
    best: dict = {}
    for _ in range(turns):
        for label, root in (("main", main_tree), ("branch", branch)):
            env = dict(os.environ, PYTHONPATH=root)
            out = subprocess.run(
                [sys.executable, __file__, "--worker", str(reps)],
                env=env, capture_output=True, text=True, check=True,
            )  # fmt: skip
            for name, (size, t, digest) in json.loads(out.stdout.splitlines()[-1]).items():
                old = best.setdefault(name, {}).get(label)
                best[name][label] = (size, min(t, old[1]) if old else t, digest)
    print("| case | bytes | main us | branch us | branch/main | same bytes |")
    print("|---|---:|---:|---:|---:|---|")
    for name, r in best.items():
        m, b = r["main"], r["branch"]
        same = "yes" if m[2] == b[2] else "NO"
        print(f"| {name} | {m[0]} | {m[1] * 1e6:.0f} | {b[1] * 1e6:.0f} | {b[1] / m[1]:.2f} | {same} |")


if __name__ == "__main__":
    if sys.argv[1] == "--worker":
        worker(int(sys.argv[2]))
    else:
        main(*sys.argv[1:3])
