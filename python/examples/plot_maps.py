"""Plan the paper's LM-S and LM-M at A = 2..6 mm and plot their time-averaged
radiation pressure and LM-frequency power maps (`lmhost simulate --compare`
in Python). Needs matplotlib (`pip install matplotlib`).

    python python/examples/plot_maps.py [scenes/paper.toml] [out.png]
"""

import sys

import matplotlib.pyplot as plt

import lmhost

scene = lmhost.Scene.load(sys.argv[1]) if len(sys.argv) > 1 else lmhost.Scene.flat()
out = sys.argv[2] if len(sys.argv) > 2 else "lm_maps.png"
radii = [2, 3, 4, 5, 6]
fig, axes = plt.subplots(4, len(radii), figsize=(3 * len(radii), 11), constrained_layout=True)
for col, a in enumerate(radii):
    for row, (name, foci) in enumerate([("LM-S", 1), ("LM-M", 4)]):
        f = lmhost.simulate(lmhost.plan(radius=a, foci=foci, scene=scene))
        ext = [f.u_mm[0], f.u_mm[-1], f.v_mm[0], f.v_mm[-1]]
        for k, (m, unit) in enumerate([(f.mean_pressure, "Pa"), (f.lm_power, "Pa²")]):
            ax = axes[2 * row + k, col]
            im = ax.imshow(m, origin="lower", extent=ext, cmap="inferno")
            ax.set_title(f"{name} A={a} mm, {'mean' if k == 0 else 'LM power'}", fontsize=8)
            fig.colorbar(im, ax=ax, shrink=0.7, label=unit)
        print(f"{name} A={a} mm: force {f.force_n * 1e3:.2f} mN")
fig.savefig(out, dpi=120)
print(f"wrote {out}")
