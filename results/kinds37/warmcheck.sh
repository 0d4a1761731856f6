cd /work/wt/kinds37
export VOLPACK_CACHE_DIR=/work/tmp_kinds37/cold3 PYTHONPATH=/work/wt/kinds37
/usr/bin/time -f "warmup %e s" /work/venv/bin/python -m volpack warmup
/work/venv/bin/python -c "
import time
from volpack import api
for f in ('/work/tmp_kinds37/nyx_vel_1e-2.vpk',):
    for i in range(3):
        t=time.perf_counter(); api.decompress(f); print(f, i, round(time.perf_counter()-t,3))
"
