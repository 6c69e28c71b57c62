#!/usr/bin/env python3
"""Writes balls.vm: the union (min) of 300 balls at seeded random places, in
fidget's .vm format, a CSG model whose every region sees one or two balls.

Usage: make_balls.py [COUNT] [SEED] > balls.vm
"""
import random
import sys

count = int(sys.argv[1]) if len(sys.argv) > 1 else 300
rng = random.Random(int(sys.argv[2]) if len(sys.argv) > 2 else 3)
print(f"# The union of {count} balls, written by make_balls.py (seed as given).")
print("_x var-x\n_y var-y\n_z var-z")
last = None
for k in range(count):
    cx, cy, cz = (round(rng.uniform(-1.0, 1.0), 4) for _ in range(3))
    r = round(rng.uniform(0.04, 0.1), 4)
    for axis, c in zip("xyz", (cx, cy, cz)):
        print(f"_c{axis}{k} const {c}")
        print(f"_d{axis}{k} sub _{axis} _c{axis}{k}")
        print(f"_s{axis}{k} square _d{axis}{k}")
    print(f"_a{k} add _sx{k} _sy{k}")
    print(f"_b{k} add _a{k} _sz{k}")
    print(f"_n{k} sqrt _b{k}")
    print(f"_r{k} const {r}")
    print(f"_f{k} sub _n{k} _r{k}")
    if last is None:
        last = f"_f{k}"
    else:
        print(f"_u{k} min {last} _f{k}")
        last = f"_u{k}"
