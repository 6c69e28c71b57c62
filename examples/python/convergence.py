"""How fast lgc's bound L of |grad f| converges to the true maximum as the
box is subdivided, by method, plotted with matplotlib.

For each method and each split n (8^n sub-boxes), L over the box is divided
by a certified lower bound of the true maximum (from `bracket`), so 1 is a
perfect bound. Run: python examples/python/convergence.py [out.png]
"""

import sys

import matplotlib

matplotlib.use("Agg")  # no display needed
import matplotlib.pyplot as plt

import lgc

formula = "x^4-5*x^2+y^4-5*y^2+z^4-5*z^2+11.8"  # the tangle cube
box = [-1, -1, -1, 1, 1, 1]
f = lgc.Formula(formula)

truth = f.bracket(box, tolerance=1e-3)
print(f"max |grad f| in [{truth['L_lower']:.6f}, {truth['L']:.6f}] ({truth['pieces']} pieces)")

splits = range(0, 4)
fig, ax = plt.subplots(figsize=(6, 4))
for method in ("natural", "centred", "bernstein", "best"):
    ratios = [f.bounds(box, split=n, method=method)["L"] / truth["L_lower"] for n in splits]
    print(f"{method:<10}" + "".join(f"{r:9.4f}" for r in ratios))
    ax.plot(list(splits), ratios, marker="o", label=method)
ax.set_xlabel("split n (8^n sub-boxes)")
ax.set_ylabel("L / max |grad f|")
ax.set_title(f"tangle cube on {box}")
ax.legend()
out = sys.argv[1] if len(sys.argv) > 1 else "convergence.png"
fig.savefig(out, dpi=100, bbox_inches="tight")
print(f"wrote {out}")
