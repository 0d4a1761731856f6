import sys, os, time, importlib._bootstrap_external as be, threading
T=[]
orig=be.SourceLoader.source_to_code
def stc(self, data, path, *, _optimize=-1):
    t=time.perf_counter(); c=orig(self, data, path, _optimize=_optimize); T.append((time.perf_counter()-t, len(data), path, threading.current_thread().name)); return c
be.SourceLoader.source_to_code=stc
def rep():
    tot=sum(t for t,*_ in T); print(f'{len(T)} modules compiled, {1e3*tot:.1f} ms, {sum(n for _,n,*_ in T)/1e3:.0f} kB', file=sys.stderr)
    for t,n,p,th in sorted(T, reverse=True)[:int(os.environ.get('TOP','40'))]: print(f'{1e3*t:6.1f} ms {n/1e3:6.1f} kB {th[:12]:12s} {p}', file=sys.stderr)
_exit=os._exit
def ex(c): rep(); _exit(c)
os._exit=ex
sys.argv=['volpack']+sys.argv[1:]
from volpack.launch import run
run()
rep()
