# The fast codec on held-out set 5 against JPEG-LS (CharLS per z slice) in one process:
# ratio, and decode MB/s per core (process CPU time, best of 5). Run from the repository root:
#   PYTHONPATH=. python results/lossless/heldout23/fast_check.py
import sys, csv, time
sys.path.insert(0, 'scripts')
import datasets, numpy as np
from volpack import api
rows = list(csv.DictReader(open('results/lossless/heldout23/lossless.csv')))
jls = {r['dataset']: float(r['ratio']) for r in rows if r['method'] == 'jpegls'}
best = {}
for r in rows:
    if not r['method'].startswith('volpack'):
        best[r['dataset']] = max(best.get(r['dataset'], 0), float(r['ratio']))
import imagecodecs
for name in ['mni152_wm', 'atlas_jhu_wm_2mm', 'mri_emri_dicom', 'mri_parrec_phantom', 'mri_afni_epi']:
    a = datasets.load(name)[0]
    blob = api.compress_array(a, codec='fast', workers=1)
    # decode speed against JPEG-LS per slice, best of 5, same process
    def t(f):
        b = 1e9
        for _ in range(5):
            t0 = time.process_time(); f(); b = min(b, time.process_time() - t0)
        return b
    api.decompress_array(blob)
    u = (a.astype(np.int64) - a.min()).astype(np.uint16) if a.dtype.kind == "i" else a
    enc = [imagecodecs.jpegls_encode(np.ascontiguousarray(s)) for s in u]
    tv = t(lambda: api.decompress_array(blob, workers=1))
    tj = t(lambda: [imagecodecs.jpegls_decode(e) for e in enc])
    jr = a.nbytes / sum(map(len, enc))
    print(f"{name:20s} {a.shape} {a.dtype} fast {a.nbytes/len(blob):7.3f} jpegls {jls.get(name, jr):7.3f} (own {jr:.3f}) best peer {best.get(name):7.3f}  decode MB/s fast {a.nbytes/1e6/tv:6.1f} jpegls {a.nbytes/1e6/tj:6.1f}")
