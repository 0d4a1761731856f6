"""scripts/profile_walk_first.py with its "faults" column replaced by the process's
system CPU in microseconds (the first writes to fresh pages are system time).

    python stages_sys.py SCRIPTS_DIR T.vpk --repeat 1 --csv C --label L
"""
import resource
import sys

sys.path.insert(0, sys.argv.pop(1))  # the scripts folder holding profile_walk_first.py
import profile_walk_first as p  # noqa: E402

p.faults = lambda: int(1e6 * resource.getrusage(resource.RUSAGE_SELF).ru_stime)
raise SystemExit(p.main())
