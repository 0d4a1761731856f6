"""Cycle collections (count, ms) of a fresh `walk --orbit 2` process by phase: "cli" before the walk command, "walk" from its start to frame 0, then each frame. Run: PYTHONPATH=<tree> VOLPACK_SERVE=0 python gc_collections.py"""
import gc, time, sys, io, contextlib, tempfile, importlib.abc
sys.argv = ["volpack", "-q", "walk", "/work/lead/walk/o.vpk", tempfile.mkdtemp() + "/", "--orbit", "2", "--json"]
st = {"frame": -1, "t": 0.0, "log": [], "where": "cli"}
def cb(phase, info):
    if phase == "start":
        st["t"] = time.perf_counter()
    else:
        st["log"].append((st["where"] if st["frame"] < 0 else st["frame"], info["generation"], time.perf_counter() - st["t"]))
gc.callbacks.append(cb)
class F(importlib.abc.MetaPathFinder):
    busy = False
    def find_spec(self, name, path, target=None):
        if F.busy or name not in ("volpack.render.lod", "volpack.cli.play"): return None
        F.busy = True
        try:
            for f in sys.meta_path:
                if f is self: continue
                spec = f.find_spec(name, path, target)
                if spec: break
        finally: F.busy = False
        inner = spec.loader.exec_module
        def ex(mod):
            inner(mod)
            if name == "volpack.render.lod":
                orig = mod.render_lod
                def rl(*a, **k):
                    st["frame"] += 1
                    return orig(*a, **k)
                mod.render_lod = rl
            else:
                w = mod.walk.callback
                def walk(*a, **k):
                    st["where"] = "walk"
                    return w(*a, **k)
                mod.walk.callback = walk
        spec.loader.exec_module = ex
        return spec
sys.meta_path.insert(0, F())
from volpack.cli import options, main
options.WHOLE_PROCESS = True
with contextlib.redirect_stdout(io.StringIO()):
    try: main(standalone_mode=False)
    except SystemExit: pass
import collections
agg = collections.defaultdict(lambda: [0, 0.0])
for f, g, d in st["log"]:
    agg[(str(f), g)][0] += 1; agg[(str(f), g)][1] += d
for k in sorted(agg): print("phase", k[0], "gen", k[1], "count", agg[k][0], "ms %.1f" % (1000 * agg[k][1]))
