"""Brick shapes for a 1800x3600 field (synthetic random fields of ab.py): (1, 2048, 2048)
against (1, 1024, 4096) and the whole field, bytes at 1e-2 and 1e-4 of the range.

Run: PYTHONPATH=. python results/lossy/flat34/shape.py
"""
import sys; sys.path.insert(0,'results/lossy/flat34')
from trial import grf
from volpack import api
for lab,a in (('s4',grf((1800,3600),-4.0,3)[None]),('s3',grf((1800,3600),-3.0,2)[None])):
    for rel in (1e-2,1e-4):
        print(lab, rel, [(br, len(api.compress_array(a, rel_error=rel, workers=2, brick=br))) for br in ((1,2048,2048),(1,1024,4096),(1,1800,3600))], flush=True)
