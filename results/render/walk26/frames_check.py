"""Every frame of `volpack walk VPK out/ --orbit 12 --json` from main and the branch, with
the default workers (2) and -j 1, compared byte for byte; per-frame decode / render
medians of the later frames (1-11) over ROUNDS alternating runs.

    python results/render/walk26/frames_check.py VPK MAIN_TREE BRANCH_TREE ROUNDS [more walk options]
"""
import filecmp, json, os, statistics, subprocess, sys, tempfile
from pathlib import Path

vpk, trees, rounds, extra = sys.argv[1], {"main": sys.argv[2], "branch": sys.argv[3]}, int(sys.argv[4]), sys.argv[5:]
work = Path(tempfile.mkdtemp(prefix="w26frames"))
later = {(t, j): {"decode_s": [], "render_s": [], "select_s": []} for t in trees for j in ("2", "1")}
for r in range(rounds):
    for j in ("2", "1"):
        for name, tree in trees.items():
            out = work / f"{name}_j{j}"
            env = dict(os.environ, PYTHONPATH=tree, VOLPACK_SERVE="0")
            p = subprocess.run([sys.executable, "-m", "volpack", "-q", "walk", vpk, f"{out}/", "--orbit", "12",
                                "--json", "--force", "-j", j, *extra], env=env, cwd=work, capture_output=True, text=True, check=True)
            rows = json.loads(p.stdout)["per_frame"]
            for row in rows[1:]:
                for k in later[(name, j)]:
                    later[(name, j)][k].append(row[k])
pngs = sorted(p.name for p in (work / "main_j2").glob("*.png"))
same = {f"{a} vs {b}": all(filecmp.cmp(work / a / f, work / b / f, shallow=False) for f in pngs)
        for a, b in [("main_j2", "branch_j2"), ("main_j1", "branch_j1"), ("branch_j1", "branch_j2"), ("main_j1", "main_j2")]}
print(f"{len(pngs)} frames; byte-identical: {same}")
for key, v in later.items():
    print(key, "later frames median ms: " + ", ".join(f"{k} {1000 * statistics.median(x):.1f}" for k, x in v.items()))
