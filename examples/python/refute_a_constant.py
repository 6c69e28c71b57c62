"""Checking a hand-derived Lipschitz constant with lgc from Python.

A common slip when bounding |grad f| by hand: bound each partial derivative
over the box and take the largest, forgetting that |grad f| adds all three.
For f = x^4 + y^4 + z^4 - 1 on [-1, 1]^3 each |df/dx_i| = 4|x_i|^3 is at most
4, but at a corner all three are 4 at once. lgc either proves a claim, with
the number of pieces it checked, or refutes it with a witness point where a
certified lower bound of |grad f| already exceeds the claim.

Run: python examples/python/refute_a_constant.py
"""

import numpy as np

import lgc

f = lgc.Formula("x^4+y^4+z^4-1")
box = [-1, -1, -1, 1, 1, 1]

for claim in ["4", 6.93]:
    result = f.verify(box, lipschitz=claim)
    print(f"claim L = {claim}: {result['status']} after {result['pieces']} pieces")
    if result["status"] == "refuted":
        x, y, z = result["witness"]
        print(f"  at ({x:.6g}, {y:.6g}, {z:.6g}), |grad f| >= {result['value']:.17g}")
        print(f"  grad f there: {f.grad(np.array([result['witness']]))[0]}")

# The exact maximum, "4*sqrt(3)", would be left undecided after max_boxes
# pieces (a million by default, a minute or two): a claim equal to an
# irrational maximum cannot be shown to hold, and is never falsely proved.
