import os, statistics, subprocess, sys, tempfile, time
rounds = int(sys.argv[1]); tree = sys.argv[2]; args = sys.argv[3:]
res = {"28": [], "4": []}
d = tempfile.mkdtemp()
for r in range(rounds):
    for v in res:
        env = dict(os.environ, PYTHONPATH=tree, VOLPACK_SERVE="0", OPENBLAS_THREAD_TIMEOUT=v)
        t = time.perf_counter()
        p = subprocess.Popen([sys.executable, "-m", "volpack", *[a.replace("OUT", d) for a in args]], env=env, cwd=d, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        _, st, ru = os.wait4(p.pid, 0)
        res[v].append((ru.ru_utime + ru.ru_stime, time.perf_counter() - t))
for v, x in res.items():
    print(f"OPENBLAS_THREAD_TIMEOUT={v}: CPU median {statistics.median(c for c, _ in x):.3f} ({min(c for c, _ in x):.3f}-{max(c for c, _ in x):.3f}) wall median {statistics.median(w for _, w in x):.3f}")
dd = [b[0] - a[0] for a, b in zip(res["28"], res["4"])]
print(f"paired CPU (4) - (28) median {statistics.median(dd):+.3f}, less in {sum(x < 0 for x in dd)} of {len(dd)}")
