"""docs/figures/rate_ladder.png: each quantity against the rate (x the paper's), per seed, with the pooled law."""
import json, os, sys
import numpy as np
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
import analyse as a

law = json.load(open(os.path.join(a.HERE, "ladder_fit.json")))
seeds = law["seeds"]
fig, axes = plt.subplots(1, 3, figsize=(12, 3.6))
for ax, q, label in zip(axes, ("peak_robust.ratio13", "end_span.ev", "end_span.Z"),
                        ("robust peak σ1/σ3", "εv over the last 2 % of ε1", "Z over the last 2 % of ε1")):
    r = law["quantities"][q]["rate"]
    x = np.geomspace(0.01, 10, 200)
    for k, s in enumerate(seeds):
        fs = [f for f in a.FACTORS if os.path.exists(os.path.join(a.folder(s, f), "summary.json"))]
        v = [a.values(s, f)[q] for f in fs]
        line, = ax.plot(fs, v, "o", label=f"seed {s}")
        ax.plot(x, r["Q0"][k] + r["C"] * x ** r["order"], "-", color=line.get_color(), lw=0.8)
        ax.axhline(r["Q0"][k], color=line.get_color(), ls=":", lw=0.8)
    ax.set_xscale("log")
    ax.set_xlabel("rate / the paper's (I ≈ 1e-4 × it, imposed scale)")
    ax.set_title(f"{label}: p = {r['order']:.2f} [{r['order_ci95'][0]:.2f}, {r['order_ci95'][1]:.2f}]", fontsize=9)
axes[0].legend(fontsize=8)
fig.suptitle("Rate ladder, 1000 spheres, TTC to ε1 = 5 %: Q = Q0(seed) + C r^p (dotted: Q0, the I → 0 answer)", fontsize=10)
fig.tight_layout()
fig.savefig(sys.argv[1], dpi=110)
