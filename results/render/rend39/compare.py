"""The held-out trial's two runs side by side (session 39, rend39): the base code's run
and the final code's, volpack pre-integrated against VTK matched (frame wall / CPU), with
the final run's first image and PSNR; a summary line for each run.

    python results/render/rend39/compare.py results/render/rend39/heldout/peers.csv \\
        results/render/rend39/heldout_final/peers.csv
"""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "rend37"))
from compare import ratios  # noqa: E402  (rend37's: the same ratios of a run)


def b(x, bad):
    return f"**{x:.2f}**" if bad else f"{x:.2f}"


def main(base, final):
    a, f = ratios(base), ratios(final)
    print(
        "| volume | TF | shading | base: frame x VTK matched (wall / CPU) | final: frame x VTK "
        "matched (wall / CPU) | final: first image x VTK | PSNR volpack / VTK matched (dB) |"
    )
    print("|---|---|---|---:|---:|---:|---|")
    for key, (fw, fc, fi, pv, pk) in f.items():
        aw, ac = a[key][0], a[key][1]
        pks = f"**{pk:.1f}**" if pk > pv else f"{pk:.1f}"
        print(
            f"| {key[0]} | {key[1]} | {key[2]} | {b(aw, aw > 1)} / {b(ac, ac > 1)} | "
            f"{b(fw, fw > 1)} / {b(fc, fc > 1)} | {b(fi, fi > 1)} | {pv:.1f} / {pks} |"
        )
    print()
    for name, d in (("base", a), ("final", f)):
        w = sorted(x[0] for x in d.values())
        print(
            f"{name}: {len(d)} cases; frame <= 1x VTK matched by wall in "
            f"{sum(x[0] <= 1 for x in d.values())}, by CPU in "
            f"{sum(x[1] <= 1 for x in d.values())} (wall {w[0]:.2f}-{w[-1]:.2f}x); first image "
            f"<= 1x in {sum(x[2] <= 1 for x in d.values())}; PSNR at or above VTK matched's in "
            f"{sum(x[3] >= x[4] for x in d.values())}"
        )


if __name__ == "__main__":
    main(*sys.argv[1:3])
