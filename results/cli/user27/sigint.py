"""Ctrl-C as a terminal sends it: start COMMAND with SIGINT at its default action (a job
started with '&' in a script ignores SIGINT), send SIGINT to its process group after
DELAY seconds, report its exit status and how long it took to stop.

    python sigint.py DELAY COMMAND...
"""

import os
import signal
import subprocess
import sys
import time


def main() -> None:
    delay, cmd = float(sys.argv[1]), sys.argv[2:]
    p = subprocess.Popen(
        cmd,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
        start_new_session=True,
    )
    time.sleep(delay)
    os.killpg(p.pid, signal.SIGINT)
    t = time.time()
    rc = p.wait()
    print(f"rc={rc} exited {time.time() - t:.1f} s after SIGINT", file=sys.stderr)


if __name__ == "__main__":
    main()
