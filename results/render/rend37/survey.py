"""Which volumes of the renderer's earlier trials narrow their tables (session 37): the
peers benchmark's semi and opaque TFs on each, through raycast.tf_span.

    PYTHONPATH=. python results/render/rend37/survey.py > results/render/rend37/survey.txt
"""

import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "scripts"))
import bench_render_peers as peers  # noqa: E402
import datasets  # noqa: E402

from volpack.render.raycast import tf_span  # noqa: E402
from volpack.render.transfer import TransferFunction  # noqa: E402

NAMES = ("ct_head mri_mni152 zmap_neurovault mri_ch2 mri_ch2better ct_skull_float "
         "mri_inia19_float cryoem_emd3001 xray_1jzv frog_labels nuclei_stardist storm_u "
         "sst_monthly mri_dipy_aniso heart_mayavi_float atlas_aicha mri_parrec_phantom md_water "
         "mecca_t mri_emri_dicom liver_labels").split()

for name in NAMES:
    try:
        vol, _, _ = datasets.load(name)
    except Exception as e:  # noqa: BLE001
        print(f"{name:20s} not loaded: {e}")
        continue
    lo, hi = float(np.nanmin(vol)), float(np.nanmax(vol))
    out = []
    for tfk in ("semi", "opaque"):
        tf = TransferFunction(points=peers.tf_points(tfk, *peers.tf_base(vol)))
        _, _, nar = tf_span(tf, lo, hi)
        share = (min(hi, tf.points[-1][0]) - max(lo, tf.points[0][0])) / (hi - lo)
        out.append(f"{tfk} {'NARROWED' if nar else 'data range'} (points {share:.3f} of it)")
    print(f"{name:20s} [{lo:.4g}, {hi:.4g}]  " + "; ".join(out), flush=True)
