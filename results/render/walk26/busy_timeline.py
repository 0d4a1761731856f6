"""Cores busy (all of the process's threads, from /proc schedstat polled every ~2 ms)
beside the main thread's stage, in 10 ms bins, for one fresh instrumented walk
(scripts/timeline_walk.py's driver), so that the idle-core windows before frame 0 show.

    python results/render/walk26/busy_timeline.py VPK TREE
"""
import json, os, subprocess, sys, tempfile, time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "scripts"))
import timeline_walk as tw

vpk, tree = sys.argv[1], str(Path(sys.argv[2]).resolve())
B = 0.01
# also the frame's chunk prefetch (the rest of the resident update is the node writes)
DRIVER = tw.DRIVER.replace('def instrument(loader, name):', 'WRAPS["volpack.octree.reader"] = [("Octree", "prefetch", "stage", "prefetch")]\ndef instrument(loader, name):')
with tempfile.TemporaryDirectory() as d:
    out = Path(d) / "out"; out.mkdir()
    evfile = Path(d) / "ev.json"
    env = dict(os.environ, PYTHONPATH=tree, VOLPACK_SERVE="0", TIMELINE_OUT=str(evfile),
               TIMELINE_ARGS=json.dumps(["-q", "walk", vpk, f"{out}/", "--orbit", "1", "--json"]))
    p = subprocess.Popen([sys.executable, "-c", DRIVER], env=env, cwd=d, stdout=subprocess.DEVNULL)
    with open(f"/proc/{p.pid}/stat") as f:
        start_ticks = int(f.read().rsplit(")", 1)[1].split()[19])
    t_start = start_ticks / os.sysconf("SC_CLK_TCK")
    samples = []
    while p.poll() is None:
        tot = {}
        try:
            for tid in os.listdir(f"/proc/{p.pid}/task"):
                try:
                    with open(f"/proc/{p.pid}/task/{tid}/schedstat") as f:
                        tot[tid] = int(f.read().split()[0])
                except OSError:
                    pass
        except OSError:
            break
        samples.append((time.clock_gettime(time.CLOCK_BOOTTIME) - t_start, tot))
        time.sleep(0.002)
    p.wait()
    evs = json.loads(evfile.read_text())
f0 = tw.frame0_end(evs)
stages = sorted((e for e in evs if e[2] == "MainThread" and e[0] in ("stage", "wait") and e[4]), key=lambda e: e[3])
bins = {}
for (t0, c0), (t1, c1) in zip(samples, samples[1:]):
    b = int(t0 / B)
    bins[b] = bins.get(b, 0) + sum(n - c0.get(t, 0) for t, n in c1.items()) / 1e9
print(f"frame 0 PNG written at {f0:.3f} s (process start offset +-10 ms)")
idle = 0.0
for b in sorted(bins):
    t = b * B
    if t > f0:
        break
    here = [e[1] for e in stages if e[3] <= t + B and e[4] >= t]
    cores = bins[b] / B
    idle += max(0.0, 2 - cores) * B
    print(f"{t:5.2f} {cores:4.2f} {'#' * int(round(cores * 10)):20s} {', '.join(dict.fromkeys(here))[:90]}")
print(f"idle core-seconds up to frame 0: {idle:.3f}")
