set -x
cd /work/wt/lossless19
R=results/lossless/lossless19
export PYTHONPATH=/work/wt/lossless19 VOLPACK_JIT_CACHE=0 VP_LPMODE=0
P=/work/venv/bin/python
V=mri_nibabel_t1,mri_dipy_s0,mri_dipy_aniso,mri_epi_nibabel,brainsmall
$P /tmp/l19/tune.py "" "[{}, {2:0,0:2,7:0}, {2:0,0:2}, {2:0,0:1}, {2:0,0:0}, {2:0,0:1,1:1}, {2:0,0:1,1:2}, {2:4,0:2,7:0}, {2:4,3:6,0:2,7:0}, {2:2,3:6,0:2,7:0}, {2:2,4:2,0:2,7:0}, {2:2,4:3,0:2,7:0}, {2:2,4:3}, {2:0,0:2,7:0,9:15}, {2:0,0:2,7:0,9:17}, {2:0,0:2,7:0,5:4}, {2:0,0:2,7:0,5:16}, {2:0,0:2,7:0,6:7}, {2:0,0:2,7:0,6:6}, {2:0,0:2,7:0,8:1}]" check > $R/mix_variants.log 2>&1
$P /tmp/l19/nlow.py $V > $R/nlow.log 2>&1
$P /tmp/l19/prime.py mri_nibabel_t1,mri_dipy_s0,brainsmall > $R/learning_cost.log 2>&1
$P /tmp/l19/bg.py > $R/dipy_background.log 2>&1
$P /tmp/l19/classls.py $V > $R/fit_classes.log 2>&1
$P /tmp/l19/nlms.py $V > $R/nlms.log 2>&1
$P /tmp/l19/combo.py $V "[({},16,0), ({2:2,4:3},16,0), ({2:2,4:3,0:2,7:0},16,0), ({2:2,4:3,0:2,7:0},48,0), ({2:2,4:3,0:2,7:0},48,1), ({2:2,4:3},48,1), ({2:2,4:3,3:6},48,1)]" > $R/combined.log 2>&1
VP_LPMODE=1 $P /tmp/l19/lpwin.py $V "[(4,3,1e-3)]" > $R/local_ls_averaged.log 2>&1
$P /tmp/l19/lsstudy.py mri_nibabel_t1 mri_dipy_s0 > $R/ls_neighbourhoods.log 2>&1
$P /tmp/l19/locls.py > $R/local_ls_mae.log 2>&1
echo done
