#!/usr/bin/env python3
"""Checks the certified brackets of `lgc bounds --tolerance` independently.

For every corpus surface (examples/surfaces.json) lgc brackets the true
Lipschitz constant, L_lower <= max |grad f| <= L, to a relative tolerance.
This script shares no code with lgc: check_rays.py's parser and mpmath
forward-mode derivatives at 150 bits. It checks

* the bracket: L <= (1 + R) L_lower, reached;
* the lower end: |grad f| at L_point, evaluated at 150 bits, is at least
  L_lower (the true constant is then at least L_lower too);
* the upper end: no sampled point (a grid and random points of the box, and
  L_point) has |grad f| above L;

and the same for G = max |g'(t)| on a ray segment of each smooth surface,
g'(t) being the derivative of g(t) = d . grad f(o + t d) taken by mpmath
at 150 bits.

Usage: check_bracket.py PATH_TO_LGC [TOLERANCE] [SEED]
"""
import json
import os
import random
import subprocess
import sys

from mpmath import mp

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from check_rays import REAL, Parser, evaluate, has_crease  # noqa: E402

mp.prec = 150

# The oracle's own rounding at 150 bits, relative.
SLACK = mp.mpf(2) ** -120


def grad_norm(tree, p):
    """|grad f(p)| at 150 bits: one forward-mode pass per axis."""
    total = mp.mpf(0)
    for i in range(3):
        x = [(mp.mpf(p[k]), mp.mpf(1 if k == i else 0)) for k in range(3)]
        total += evaluate(tree, x, REAL)[1] ** 2
    return mp.sqrt(total)


def g_of_t(tree, o, d, t):
    """g(t) = d . grad f(o + t d): forward mode along d."""
    x = [(mp.mpf(o[k]) + t * mp.mpf(d[k]), mp.mpf(d[k])) for k in range(3)]
    return evaluate(tree, x, REAL)[1]


def dg(tree, o, d, t):
    """|g'(t)| at 150 bits (mpmath's differentiation at raised precision)."""
    return abs(mp.diff(lambda s: g_of_t(tree, o, d, s), mp.mpf(t)))


def lgc_bounds(lgc, expr, box, tolerance, ray=None):
    cmd = [lgc, "bounds", expr, "--box=" + ",".join(repr(float(v)) for v in box),
           "--tolerance", str(tolerance), "--json"]
    if ray:
        cmd += ["--ray=" + ",".join(repr(float(v)) for v in ray[0]), "--t=" + ",".join(repr(float(v)) for v in ray[1])]
    out = subprocess.run(cmd, capture_output=True, text=True, check=True)
    return json.loads(out.stdout)


def samples(rng, box, n_grid=9, n_random=400):
    lo, hi = box[:3], box[3:]
    pts = []
    for i in range(n_grid):
        for j in range(n_grid):
            for k in range(n_grid):
                pts.append([lo[a] + (hi[a] - lo[a]) * (i, j, k)[a] / (n_grid - 1) for a in range(3)])
    for _ in range(n_random):
        pts.append([rng.uniform(lo[a], hi[a]) for a in range(3)])
    return pts


def check_l(lgc, name, expr, box, tolerance, rng):
    tree = Parser(expr).parse()
    o = lgc_bounds(lgc, expr, box, tolerance)
    upper, lower, point = o["L"], o["L_lower"], o["L_point"]
    fails = []
    if upper is None:
        return [f"{name}: L is infinite ({o.get('L_note')})"]
    if not o["L_reached"] or upper > (1 + tolerance) * lower:
        fails.append(f"{name}: bracket [{lower}, {upper}] not within {tolerance}")
    at = grad_norm(tree, point)
    if at * (1 + SLACK) < lower:
        fails.append(f"{name}: |grad f| at L_point is {mp.nstr(at, 20)} < L_lower {lower}")
    if at > upper * (1 + SLACK):
        fails.append(f"{name}: |grad f| at L_point is {mp.nstr(at, 20)} > L {upper}")
    best = max(grad_norm(tree, p) for p in samples(rng, box))
    if best > upper * (1 + SLACK):
        fails.append(f"{name}: a sampled |grad f| {mp.nstr(best, 20)} exceeds L {upper}")
    print(f"{name:<14} L in [{lower:.10g}, {upper:.10g}] ({o['pieces']} pieces), "
          f"|grad f| at L_point {mp.nstr(at, 12)}, best sample {mp.nstr(best, 12)}")
    return fails


def check_g(lgc, name, expr, box, tolerance, rng):
    tree = Parser(expr).parse()
    lo, hi = box[:3], box[3:]
    origin = [rng.uniform(lo[a], hi[a]) for a in range(3)]
    direction = [rng.uniform(-1, 1) for _ in range(3)]
    ray = (origin + direction, (0.0, 0.5))
    o = lgc_bounds(lgc, expr, box, tolerance, ray)
    upper, lower, t = o["G"], o["G_lower"], o["G_t"]
    if upper is None:
        return [f"{name}: G is infinite ({o.get('G_note')})"]
    fails = []
    if not o["G_reached"] or upper > (1 + tolerance) * lower:
        fails.append(f"{name}: G bracket [{lower}, {upper}] not within {tolerance}")
    at = dg(tree, origin, direction, t)
    # mp.diff's own error is far below 2^-100 relative for these analytic g.
    if at * (1 + mp.mpf(2) ** -100) < lower:
        fails.append(f"{name}: |g'| at G_t is {mp.nstr(at, 20)} < G_lower {lower}")
    best = max(dg(tree, origin, direction, 0.5 * k / 64) for k in range(65))
    if best > upper * (1 + mp.mpf(2) ** -100):
        fails.append(f"{name}: a sampled |g'| {mp.nstr(best, 20)} exceeds G {upper}")
    print(f"{name:<14} G in [{lower:.10g}, {upper:.10g}] ({o['G_pieces']} pieces), |g'| at G_t {mp.nstr(at, 12)}")
    return fails


NARROW = {
    "ridge": "x + exp(-((y-0.2)^2+z^2)*900)",
    "ridge 0.02": "x + exp(-((y-0.2)^2+z^2)/0.0004)",
    "gaussian 0.02": "exp(-((x-0.1)/0.02)^2) + 0.1*y",
}


def main():
    lgc = sys.argv[1]
    tolerance = float(sys.argv[2]) if len(sys.argv) > 2 else 0.01
    rng = random.Random(int(sys.argv[3]) if len(sys.argv) > 3 else 2026)
    here = os.path.dirname(os.path.abspath(__file__))
    with open(os.path.join(here, "..", "..", "examples", "surfaces.json")) as fh:
        corpus = json.load(fh)
    fails = []
    for name, s in corpus.items():
        fails += check_l(lgc, name, s["expr"], s["box"], tolerance, rng)
        if not has_crease(Parser(s["expr"]).parse()):
            fails += check_g(lgc, name, s["expr"], s["box"], tolerance, rng)
    # Narrow features, whose maximum a few boxes in a million hold: they
    # bracket within the default piece budget only when the split follows
    # the coordinates |grad f| depends on (the smear rule).
    for name, expr in NARROW.items():
        fails += check_l(lgc, name, expr, [-1, -1, -1, 1, 1, 1], tolerance, rng)
    for f in fails:
        print("FAIL", f)
    print(f"brackets: {len(corpus) + len(NARROW)} surfaces, {len(fails)} failures")
    sys.exit(1 if fails else 0)


if __name__ == "__main__":
    main()
