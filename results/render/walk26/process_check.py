"""CPU and wall of whole `volpack` processes (os.wait4), trees alternating, for commands
other than walk: python process_check.py ROUNDS MAIN BRANCH -- ARGS... (OUT in ARGS is a
fresh folder per run; outputs compared byte for byte)."""
import filecmp, os, shutil, statistics, subprocess, sys, tempfile, time
from pathlib import Path

rounds, trees = int(sys.argv[1]), {"main": sys.argv[2], "branch": sys.argv[3]}
args = sys.argv[sys.argv.index("--") + 1:]
res = {k: [] for k in trees}
work = Path(tempfile.mkdtemp(prefix="w26proc"))
for r in range(rounds + 1):
    for name, tree in trees.items():
        out = work / name
        shutil.rmtree(out, ignore_errors=True)
        out.mkdir()
        a = [x.replace("OUT", str(out)) for x in args]
        env = dict(os.environ, PYTHONPATH=tree, VOLPACK_SERVE="0")
        t = time.perf_counter()
        p = subprocess.Popen([sys.executable, "-m", "volpack", *a], env=env, cwd=work,
                             stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        _, st, ru = os.wait4(p.pid, 0)
        assert st == 0, (name, st)
        if r:  # the first round warms the kernel caches
            res[name].append((ru.ru_utime + ru.ru_stime, time.perf_counter() - t))
files = sorted(p.name for p in (work / "main").iterdir())
same = all(filecmp.cmp(work / "main" / f, work / "branch" / f, shallow=False) for f in files)
print(" ".join(args), f"; outputs byte-identical: {same} ({len(files)} files)")
for name, v in res.items():
    print(f"  {name:7s} CPU median {statistics.median(c for c, _ in v):.3f} s ({min(c for c, _ in v):.3f}-{max(c for c, _ in v):.3f}), "
          f"wall median {statistics.median(w for _, w in v):.3f} s ({min(w for _, w in v):.3f}-{max(w for _, w in v):.3f})")
d = [b[0] - a[0] for a, b in zip(res["main"], res["branch"])]
print(f"  paired CPU branch - main median {statistics.median(d):+.3f} s, less in {sum(x < 0 for x in d)} of {len(d)}")
