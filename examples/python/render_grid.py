"""A grid of well-known surfaces, each rendered by lgc's certified ray
tracer into a numpy array and shown in one matplotlib figure.

Every pixel's ray is answered with a proof (a sign change for a hit, an
exclusion for a miss), so no surface has holes, whatever its shape.
Run: python examples/python/render_grid.py [out.png]
"""

import json
import pathlib
import sys

import matplotlib

matplotlib.use("Agg")  # no display needed
import matplotlib.pyplot as plt

import lgc

SURFACES = json.loads((pathlib.Path(__file__).resolve().parents[1] / "surfaces.json").read_text())
names = ["torus", "tangle_cube", "heart", "decocube", "goursat", "klein_bottle", "gyroid", "blend"]
colors = [(0.85, 0.45, 0.25), (0.3, 0.55, 0.85), (0.8, 0.2, 0.3), (0.55, 0.7, 0.35)]

fig, axes = plt.subplots(2, 4, figsize=(12, 6.4))
for k, (name, ax) in enumerate(zip(names, axes.flat)):
    s = SURFACES[name]
    image = lgc.render(s["expr"], size=(240, 200), box=s["box"], color=colors[k % len(colors)])
    ax.imshow(image)
    ax.set_title(name.replace("_", " "))
    ax.axis("off")
    print(f"{name:<14} {image.shape[1]}x{image.shape[0]}")
fig.tight_layout()
out = sys.argv[1] if len(sys.argv) > 1 else "render_grid.png"
fig.savefig(out, dpi=100)
print(f"wrote {out}")
