import atexit, os, sys, time
def spent():
    time.sleep(0.15)
    main, cpu = str(os.getpid()), 0
    for tid in os.listdir("/proc/self/task"):
        if tid != main:
            with open(f"/proc/self/task/{tid}/schedstat") as f:
                cpu += int(f.read().split()[0])
    print(f"{os.environ.get('OPENBLAS_THREAD_TIMEOUT')} BLAS {cpu / 1e9:.4f}", file=sys.stderr)
atexit.register(spent)
from volpack.launch import run
run()
