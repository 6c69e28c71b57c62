#!/usr/bin/env python3
"""Cross-checks `lgc eval --json` against sympy, an independent computer-algebra system.

Random formulas are generated as trees and printed twice: in lgc syntax and as
sympy expressions. sympy differentiates them symbolically and evaluates f, the
gradient, g = d.grad f and g' = d^T H d at 30 digits; lgc must agree to 1e-9
relative. Formulas only use functions on arguments inside their domains, so
every value is finite.

Step functions (floor, ceil, round, mod) are checked on formulas of their own:
their derivatives are 0 between jumps, so sympy differentiates each formula with
every step replaced by its value at the point, and points within 1e-6 of a jump
are skipped.

Usage: check_eval.py PATH_TO_LGC [COUNT] [SEED]
"""
import json
import random
import subprocess
import sys

import sympy as sp

X, Y, Z = sp.symbols("x y z", real=True)
DX, DY, DZ = sp.symbols("dx dy dz", real=True)


def leaf(rng):
    r = rng.random()
    if r < 0.7:
        name = rng.choice("xyz")
        return name, {"x": X, "y": Y, "z": Z}[name]
    if r < 0.8:
        return "pi", sp.pi
    c = rng.choice([0.5, 1.5, 2, 3, 0.25, 1.25, 7])
    return repr(c), sp.Rational(str(c))


def tree(rng, depth):
    """Returns (lgc text, sympy expression) of a random formula."""
    if depth == 0:
        return leaf(rng)
    kind = rng.choice(["add", "sub", "mul", "div", "pow", "neg", "fun", "fun", "fun2"])
    a, ea = tree(rng, depth - 1)
    if kind == "neg":
        return f"-({a})", -ea
    if kind == "fun":
        name = rng.choice(["sin", "cos", "atan", "tanh", "sqrt1", "ln1", "exp", "sinh", "cosh", "log1", "abs", "asin", "acos", "sech"])
        if name == "sqrt1":
            return f"sqrt(({a})^2 + 1)", sp.sqrt(ea**2 + 1)
        if name == "ln1":
            return f"ln(({a})^2 + 1)", sp.log(ea**2 + 1)
        if name == "log1":
            return f"log(({a})^2 + 2)", sp.log(ea**2 + 2, 10)
        if name == "exp":
            return f"exp(sin({a}))", sp.exp(sp.sin(ea))
        if name in ("sinh", "cosh"):
            return f"{name}(tanh({a}))", getattr(sp, name)(sp.tanh(ea))
        if name in ("asin", "acos"):
            return f"{name}(0.9*tanh({a}))", getattr(sp, name)(sp.Rational(9, 10) * sp.tanh(ea))
        if name == "abs":
            return f"abs({a})", sp.Abs(ea)
        if name == "sech":
            return f"sech({a})", sp.sech(ea)
        return f"{name}({a})", getattr(sp, name)(ea)
    b, eb = tree(rng, depth - 1)
    if kind == "add":
        return f"({a}) + ({b})", ea + eb
    if kind == "sub":
        return f"({a}) - ({b})", ea - eb
    if kind == "mul":
        return f"({a})*({b})", ea * eb
    if kind == "div":
        return f"({a})/(({b})^2 + 0.5)", ea / (eb**2 + sp.Rational(1, 2))
    if kind == "pow":
        n = rng.choice([2, 3, -1, 4])
        if n == -1:
            return f"(({a})^2 + 1)^-1", (ea**2 + 1) ** -1
        if rng.random() < 0.3:
            return f"pow(({a})^2 + 1, 1.5)", (ea**2 + 1) ** sp.Rational(3, 2)
        return f"({a})^{n}", ea**n
    if kind == "fun2":
        name = rng.choice(["atan2", "hypot", "min", "max", "lse"])
        if name == "atan2":
            return f"atan2({a}, ({b})^2 + 1)", sp.atan2(ea, eb**2 + 1)
        if name == "hypot":
            return f"hypot({a}, {b})", sp.sqrt(ea**2 + eb**2)
        if name == "min":
            return f"min({a}, {b})", sp.Min(ea, eb)
        if name == "lse":
            return f"ln(exp({a}) + exp({b}))", sp.log(sp.exp(ea) + sp.exp(eb))
    return f"max({a}, {b})", sp.Max(ea, eb)


def step_tree(rng, depth):
    """A random formula with floor, ceil, round or mod over smooth parts."""
    a, ea = tree(rng, depth)
    b, eb = tree(rng, max(depth - 1, 0))
    name = rng.choice(["floor", "ceil", "round", "mod"])
    scale = rng.choice([1, 2, 3.5])
    if name == "floor":
        step = f"floor({scale}*({a}))", sp.floor(sp.Float(scale) * ea)
    elif name == "ceil":
        step = f"ceil({scale}*({a}))", sp.ceiling(sp.Float(scale) * ea)
    elif name == "round":
        u = sp.Float(scale) * ea
        step = f"round({scale}*({a}))", sp.sign(u) * sp.floor(sp.Abs(u) + sp.Rational(1, 2))
    else:
        m = sp.Float(scale) * (eb**2 + 1)
        step = f"mod({a}, {scale}*(({b})^2 + 1))", ea - m * sp.floor(ea / m)
    text, expr = step
    return f"{text}*({b}) + ({a})", expr * eb + ea


def freeze_steps(expr, subs):
    """The expression with every floor and ceiling replaced by its value at
    the point (their derivatives are 0 there), or None when the point lies
    within 1e-6 of a jump."""
    for node in sorted(expr.atoms(sp.floor, sp.ceiling), key=lambda n: -sp.count_ops(n)):
        arg = complex(sp.N(node.args[0].subs(subs), 40)).real
        if abs(arg - round(arg)) < 1e-6:
            return None
        value = sp.floor(sp.Float(arg, 40)) if isinstance(node, sp.floor) else sp.ceiling(sp.Float(arg, 40))
        expr = expr.subs(node, value)
    return expr


def program(rng, depth):
    """A formula, sometimes with a `let` binding used twice."""
    if rng.random() < 0.3:
        a, ea = tree(rng, depth - 1)
        b, eb = tree(rng, depth - 1)
        return f"let t = {a};\n# reused below\n(t)*({b}) + t", ea * eb + ea
    return tree(rng, depth)


def ill_conditioned(expr, subs):
    """True when f64 cannot resolve the formula at this point: a periodic
    function of an argument so large that one rounding of it moves the result
    by more than the tolerance, or an exponential beyond the f64 range."""
    for node in sp.preorder_traversal(expr):
        if isinstance(node, (sp.sin, sp.cos, sp.tan)):
            if abs(complex(sp.N(node.args[0].subs(subs), 20))) > 1e4:
                return True
        if isinstance(node, (sp.exp, sp.sinh, sp.cosh)):
            if abs(complex(sp.N(node.args[0].subs(subs), 20))) > 700:
                return True
    return False


def lgc_eval(lgc, text, p, d):
    out = subprocess.run(
        [lgc, "eval", text, f"--at={p[0]!r},{p[1]!r},{p[2]!r}", f"--dir={d[0]!r},{d[1]!r},{d[2]!r}", "--json"],
        capture_output=True, text=True, check=False)
    if out.returncode != 0:
        raise RuntimeError(f"lgc failed on {text!r}: {out.stderr}")
    return json.loads(out.stdout)


def main():
    lgc = sys.argv[1]
    count = int(sys.argv[2]) if len(sys.argv) > 2 else 150
    seed = int(sys.argv[3]) if len(sys.argv) > 3 else 2026
    rng = random.Random(seed)
    steps = random.Random(seed + 1)
    passed = failed = skipped = 0
    for i in range(count + count // 5):
        stepped = i >= count
        if stepped:
            text, expr = step_tree(steps, steps.choice([1, 2]))
            source = steps
        else:
            text, expr = program(rng, rng.choice([2, 3, 4]))
            source = rng
        p = [source.uniform(-2, 2) for _ in range(3)]
        d = [source.uniform(-1, 1) for _ in range(3)]
        if stepped:
            frozen_subs = {X: sp.Float(repr(p[0]), 40), Y: sp.Float(repr(p[1]), 40), Z: sp.Float(repr(p[2]), 40)}
            frozen = freeze_steps(expr, frozen_subs)
            if frozen is None:
                skipped += 1
                continue
            expr = frozen
        grad = [sp.diff(expr, v) for v in (X, Y, Z)]
        g = DX * grad[0] + DY * grad[1] + DZ * grad[2]
        dg = sum(dv * sp.diff(g, v) for dv, v in zip((DX, DY, DZ), (X, Y, Z)))
        subs = {X: sp.Float(repr(p[0]), 40), Y: sp.Float(repr(p[1]), 40), Z: sp.Float(repr(p[2]), 40),
                DX: sp.Float(repr(d[0]), 40), DY: sp.Float(repr(d[1]), 40), DZ: sp.Float(repr(d[2]), 40)}
        if ill_conditioned(expr, subs):
            skipped += 1
            continue
        try:
            want = [complex(sp.N(e.subs(subs), 30)) for e in [expr, *grad, g, dg]]
        except (TypeError, ValueError):
            skipped += 1  # sympy could not reduce a derivative of abs/min/max to a number
            continue
        if any(abs(w.imag) > 0 or w != w for w in want):
            skipped += 1
            continue
        want = [w.real for w in want]
        got = lgc_eval(lgc, text, p, d)
        got = [got["f"], *got["grad"], got["g"], got["dg"]]
        # Error is measured against the size of the terms that were summed: the
        # value itself, or for a derivative the magnitude of f's own scale.
        scale = max(1.0, abs(want[0]))
        bad = [(n, w, v) for n, w, v in zip(["f", "fx", "fy", "fz", "g", "dg"], want, got)
               if v is None or abs(v - w) > 1e-9 * max(abs(w), scale)]
        if bad:
            failed += 1
            print(f"MISMATCH #{i}: {text}\n  at {p} dir {d}\n  " +
                  "\n  ".join(f"{n}: lgc {v!r} sympy {w!r}" for n, w, v in bad))
        else:
            passed += 1
    print(f"cas: {passed} passed, {failed} failed, {skipped} skipped")
    sys.exit(1 if failed or passed < (count + count // 5) // 2 else 0)


if __name__ == "__main__":
    main()
