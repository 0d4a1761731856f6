"""`volpack info` in its text view (the fuzzer runs `info --json`) on header and summary
field mutants of every golden stream: one field replaced by another type, as
`scripts/fuzz.py` mutates them; counts the runs that end in an internal error.

    python results/fuzz/info_text_mutants.py        # from the repository's root
"""
import glob
import random
import sys

sys.path.insert(0, 'scripts')
import fuzz
from click.testing import CliRunner

from volpack.cli import main

rng = random.Random(39)
bad = {}
n = 0
for f in sorted(glob.glob('formats/examples/*.vpk')):
    blob = open(f, 'rb').read()
    try:
        header, summary, chunks, entries = fuzz.parse(blob)
    except Exception:
        continue
    errors = [e.error for e in entries]
    for i in range(40):
        h, s = header, summary
        if i % 2:
            s = fuzz.mutate_field(rng, dict(summary or {}))
        else:
            h = fuzz.mutate_field(rng, dict(header))
        try:
            b = fuzz.rebuild(h, s, chunks, errors)
        except Exception:
            continue
        p = '/tmp/itf.vpk'
        open(p, 'wb').write(b)
        r = CliRunner().invoke(main, ['info', p])
        n += 1
        if 'internal error' in r.output or (r.exception and not isinstance(r.exception, SystemExit)):
            key = (f.split('/')[-1], 'summary' if i % 2 else 'header')
            bad.setdefault(key, (r.output.strip().splitlines() or [repr(r.exception)])[-1][:160])
print(n, 'mutants;', len(bad), 'kinds of failure')
for k, v in bad.items():
    print(k, v)
