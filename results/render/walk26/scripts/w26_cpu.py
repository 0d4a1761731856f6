import os, subprocess, sys, time, tempfile, shutil
vpk = "/work/lead/walk/o.vpk"
tree = sys.argv[1]; n = int(sys.argv[2]); settings = sys.argv[3:]
res = {s: [] for s in settings}
for r in range(n):
    for s in settings:
        env = dict(os.environ, PYTHONPATH=tree, VOLPACK_SERVE="0")
        if s != "none":
            k, v = s.split("=")
            env[k] = v
        d = tempfile.mkdtemp()
        t = time.perf_counter()
        p = subprocess.Popen([sys.executable, "-m", "volpack", "-q", "walk", vpk, d + "/o/", "--orbit", "1", "--json"], env=env, cwd=d, stdout=subprocess.DEVNULL)
        _, st, ru = os.wait4(p.pid, 0)
        res[s].append((ru.ru_utime + ru.ru_stime, time.perf_counter() - t))
        shutil.rmtree(d)
for s, v in res.items():
    print(s, "cpu", " ".join(f"{c:.3f}" for c, _ in v), "wall", " ".join(f"{w:.3f}" for _, w in v))
