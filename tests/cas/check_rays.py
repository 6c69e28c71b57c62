#!/usr/bin/env python3
"""Checks every answer of `lgc trace` against an independent oracle.

The oracle shares no code with lgc: its own parser for the formula language
(the subset the cases use), and mpmath's interval arithmetic at 150 bits with
forward-mode derivatives. For each ray it isolates the first root of
F(t) = f(o + t d) on the part of the ray inside the box by branch and bound
with the mean-value form F([a,b]) ⊆ F(m) + F'([a,b])·([a,b] - m) (a Clarke
hull across creases of min/max/abs), and classifies it:

* none: every piece excluded;
* a crossing at t*: a piece of width ≤ 1e-13·scale whose ends have opposite
  signs, certified by intervals at the ends; t* is refined by bisection;
* a double root at t*: a piece that small whose enclosure holds 0 without a
  sign change (a tangency, or |F| below what 150 bits resolve).

lgc must then answer, ray by ray:

* `none` only where the oracle finds no root, nor a double root whose
  |F| there exceeds f64's rounding noise;
* a hit t only where the oracle's first root is within 1e-9 (relative, or
  absolute below 1) of t, or where a double root lies there;
* `touch t` only where F comes within f64's rounding noise of 0 within the
  tolerance of t (a double root as f64 sees it), with no crossing before.

f64 rounding noise at a point is 64 ulps of the formula evaluated with every
term in absolute value (the classic bound of a sum's rounding), plus the
noise of the point itself times |grad f|.

Usage: check_rays.py PATH_TO_LGC [RAYS_PER_SURFACE] [SEED]
"""
import math
import os
import random
import re
import subprocess
import sys

import mpmath
from mpmath import iv, mp

HERE = os.path.dirname(os.path.abspath(__file__))

mp.prec = 150
iv.prec = 150

TOL_REL = 1e-9

# --------------------------------------------------------------- formulas ---

TOKEN = re.compile(r"\s*(?:(\d+\.?\d*(?:[eE][-+]?\d+)?|\.\d+(?:[eE][-+]?\d+)?)|([A-Za-z_]\w*)|(.))")


def tokens(text):
    out = []
    for num, name, op in TOKEN.findall(text):
        if num:
            out.append(("num", float(num)))
        elif name:
            out.append(("name", name))
        elif op.strip():
            out.append(("op", op))
    out.append(("end", None))
    return out


class Parser:
    """expr := term (('+'|'-') term)*; term := unary (('*'|'/') unary)*;
    unary := '-' unary | power; power := atom ('^' unary)?"""

    def __init__(self, text):
        self.t = tokens(text)
        self.i = 0

    def peek(self):
        return self.t[self.i]

    def take(self, kind=None, value=None):
        tok = self.t[self.i]
        if kind and tok[0] != kind or value is not None and tok[1] != value:
            raise SyntaxError(f"expected {value or kind}, found {tok}")
        self.i += 1
        return tok

    def parse(self):
        e = self.expr()
        self.take("end")
        return e

    def expr(self):
        e = self.term()
        while self.peek() in (("op", "+"), ("op", "-")):
            op = self.take()[1]
            e = (op, e, self.term())
        return e

    def term(self):
        e = self.unary()
        while self.peek() in (("op", "*"), ("op", "/")):
            op = self.take()[1]
            e = (op, e, self.unary())
        return e

    def unary(self):
        if self.peek() == ("op", "-"):
            self.take()
            return ("neg", self.unary())
        if self.peek() == ("op", "+"):
            self.take()
            return self.unary()
        return self.power()

    def power(self):
        a = self.atom()
        if self.peek() == ("op", "^"):
            self.take()
            b = self.unary()
            if b[0] == "num" and float(b[1]).is_integer():
                return ("powi", a, int(b[1]))
            raise SyntaxError("only integer constant powers are supported")
        return a

    def atom(self):
        kind, v = self.take()
        if kind == "num":
            return ("num", v)
        if kind == "name":
            if self.peek() == ("op", "("):
                self.take()
                args = [self.expr()]
                while self.peek() == ("op", ","):
                    self.take()
                    args.append(self.expr())
                self.take("op", ")")
                return ("call", v, args)
            if v in ("x", "y", "z"):
                return ("var", "xyz".index(v))
            if v == "pi":
                return ("num", math.pi)
            raise SyntaxError(f"unknown name {v}")
        if (kind, v) == ("op", "("):
            e = self.expr()
            self.take("op", ")")
            return e
        raise SyntaxError(f"unexpected {v}")


# Dual numbers (value, derivative in t) over intervals or mp reals.


class Ops:
    def __init__(self, ctx, interval):
        self.ctx = ctx
        self.interval = interval

    def const(self, v):
        return (self.ctx.mpf(mpmath.mpf(v)), self.ctx.mpf(0))

    def hull(self, a, b):
        lo = min(a.a, b.a) if self.interval else None
        return iv.mpf([lo, max(a.b, b.b)])

    def sign_of(self, v):
        """-1, 1, or 0 when the interval holds 0."""
        if self.interval:
            if v.a > 0:
                return 1
            if v.b < 0:
                return -1
            return 0
        return 1 if v > 0 else -1 if v < 0 else 0

    def minmax(self, a, b, is_max):
        s = self.sign_of(a[0] - b[0])
        pick_a = s > 0 if is_max else s < 0
        if s != 0:
            return a if pick_a else b
        if not self.interval:
            return a if is_max else b
        v = self.hull(a[0], b[0])
        # The exact min/max lies between the two values' hull ends.
        lo = (max if is_max else min)(a[0].a, b[0].a)
        hi = (max if is_max else min)(a[0].b, b[0].b)
        return (iv.mpf([lo, hi]), self.hull(a[1], b[1]))

    def abs(self, a):
        s = self.sign_of(a[0])
        if s > 0:
            return a
        if s < 0:
            return (-a[0], -a[1])
        if not self.interval:
            return (abs(a[0]), a[1])
        m = max(abs(a[0].a), abs(a[0].b))
        return (iv.mpf([0, m]), self.hull(a[1], -a[1]))


def evaluate(node, x, ops, memo=None):
    """f and dF/dt at inputs x = [(value, derivative)]*3. A model read from a
    .vm file shares its subexpressions: each node is evaluated once (memo)."""
    if memo is None:
        memo = {}
    key = id(node)
    if key not in memo:
        memo[key] = evaluate_node(node, x, ops, memo)
    return memo[key]


def evaluate_node(node, x, ops, memo):
    evaluate = lambda n, x, ops: globals()["evaluate"](n, x, ops, memo)  # noqa: E731
    kind = node[0]
    if kind == "num":
        return ops.const(node[1])
    if kind == "var":
        return x[node[1]]
    if kind == "neg":
        a = evaluate(node[1], x, ops)
        return (-a[0], -a[1])
    if kind in "+-*/":
        a = evaluate(node[1], x, ops)
        b = evaluate(node[2], x, ops)
        if kind == "+":
            return (a[0] + b[0], a[1] + b[1])
        if kind == "-":
            return (a[0] - b[0], a[1] - b[1])
        if kind == "*":
            return (a[0] * b[0], a[1] * b[0] + a[0] * b[1])
        q = a[0] / b[0]
        return (q, (a[1] - q * b[1]) / b[0])
    if kind == "powi":
        a = evaluate(node[1], x, ops)
        n = node[2]
        if n == 0:
            return ops.const(1)
        return (a[0] ** n, n * a[0] ** (n - 1) * a[1])
    if kind == "call":
        name, args = node[1], [evaluate(a, x, ops) for a in node[2]]
        c = ops.ctx
        if name in ("min", "max"):
            acc = args[0]
            for b in args[1:]:
                acc = ops.minmax(acc, b, name == "max")
            return acc
        if name == "abs":
            return ops.abs(args[0])
        a = args[0]
        if name == "sqrt":
            r = c.sqrt(a[0])
            return (r, a[1] / (2 * r))
        if name == "exp":
            e = c.exp(a[0])
            return (e, e * a[1])
        if name == "ln":
            return (c.log(a[0]), a[1] / a[0])
        if name == "sin":
            return (c.sin(a[0]), c.cos(a[0]) * a[1])
        if name == "cos":
            return (c.cos(a[0]), -c.sin(a[0]) * a[1])
        raise SyntaxError(f"function {name} is not in the oracle")
    raise SyntaxError(f"node {kind}")


def abs_scale(node, x, memo=None):
    """The formula with every term in absolute value, at a point (floats)."""
    if memo is None:
        memo = {}
    key = id(node)
    if key not in memo:
        memo[key] = abs_scale_node(node, x, memo)
    return memo[key]


def abs_scale_node(node, x, memo):
    abs_scale = lambda n, x: globals()["abs_scale"](n, x, memo)  # noqa: E731
    kind = node[0]
    if kind == "num":
        return abs(node[1])
    if kind == "var":
        return abs(x[node[1]])
    if kind == "neg":
        return abs_scale(node[1], x)
    if kind in "+-":
        return abs_scale(node[1], x) + abs_scale(node[2], x)
    if kind == "*":
        return abs_scale(node[1], x) * abs_scale(node[2], x)
    if kind == "/":
        return abs_scale(node[1], x) / max(1e-300, abs(float(evaluate(node[2], [(mp.mpf(v), 0) for v in x], REAL)[0])))
    if kind == "powi":
        v = abs_scale(node[1], x)
        return v ** node[2] if v < 1e100 else math.inf
    if kind == "call":
        vals = [abs_scale(a, x) for a in node[2]]
        if node[1] in ("exp", "ln"):
            # exp(a) carries a's noise times exp(a) (its slope), ln(a) a's
            # over |a|: with the argument's value, not its absolute-value
            # form (exp of that overflows on soft blends).
            v = float(evaluate(node[2][0], [(mp.mpf(v), 0) for v in x], REAL)[0])
            if node[1] == "exp":
                return math.exp(min(700.0, v)) * (1.0 + vals[0])
            return abs(math.log(max(1e-300, abs(v)))) + vals[0] / max(1e-300, abs(v))
        if node[1] in ("sin", "cos"):
            return 1.0 + vals[0]
        return max(vals)
    return 0.0


REAL = Ops(mp, False)
INTERVAL = Ops(iv, True)

# ------------------------------------------------------------------ roots ---


def point_x(o, d, t, ops):
    """Inputs of F at t (a number or an interval), with dx/dt = d."""
    ctx = ops.ctx
    return [(ctx.mpf(o[i]) + ctx.mpf(t) * ctx.mpf(d[i]), ctx.mpf(d[i])) for i in range(3)]


def enclose(tree, o, d, a, b):
    """Enclosure of F over [a, b] (mp numbers): the mean-value form, met with
    the natural one (forward-mode slopes are unbounded where the ray crosses
    the axis of a sqrt(u² + v²), though F is not)."""
    m = (a + b) / 2
    fm = evaluate(tree, point_x(o, d, iv.mpf([m, m]), INTERVAL), INTERVAL)[0]
    natural, slope = evaluate(tree, point_x(o, d, iv.mpf([a, b]), INTERVAL), INTERVAL)
    half = iv.mpf([a, b]) - iv.mpf([m, m])
    mean_value = fm + slope * half
    lo, hi = max(mean_value.a, natural.a), min(mean_value.b, natural.b)
    if lo > hi:
        # Both enclose F: they meet unless one is wrong.
        raise ArithmeticError(f"enclosures {mean_value} and {natural} of F are disjoint")
    return iv.mpf([lo, hi]), fm, slope


def sign_at(tree, o, d, t):
    v = evaluate(tree, point_x(o, d, iv.mpf([t, t]), INTERVAL), INTERVAL)[0]
    return INTERVAL.sign_of(v)


def slab(o, d, lo, hi):
    near, far = mp.mpf(0), mp.inf
    for i in range(3):
        if d[i] == 0:
            if not (lo[i] <= o[i] <= hi[i]):
                return None
            continue
        t0 = (mp.mpf(lo[i]) - o[i]) / d[i]
        t1 = (mp.mpf(hi[i]) - o[i]) / d[i]
        near = max(near, min(t0, t1))
        far = min(far, max(t0, t1))
    return (near, far) if near <= far else None


def t_unit(o, d, lo, hi):
    """The ray's own unit of t: the time it takes to cross the box's diagonal.
    Widths and tolerances in t are relative to it, so that a ray scaled by
    any power of ten is judged as its unscaled self."""
    diag = mp.sqrt(sum((mp.mpf(hi[i]) - mp.mpf(lo[i])) ** 2 for i in range(3)))
    return diag / mp.sqrt(sum(mp.mpf(v) ** 2 for v in d))


def first_root(tree, o, d, lo, hi, budget=200000):
    """('none',) | ('cross', t) | ('double', t) | ('unknown', t)."""
    span = slab(o, d, lo, hi)
    if span is None:
        return ("none",)
    t0, t1 = span
    unit = t_unit(o, d, lo, hi)
    # The box is closed: a surface on its wall is in it. Its entry, rounded
    # to 150 bits, may lie just inside that wall.
    t0 = max(mp.mpf(0), t0 - mp.mpf(2) ** -100 * unit) if t0 > 0 else t0
    eps = mp.mpf(1e-13) * max(unit, abs(t1))
    stack = [(t0, t1)]
    while stack:
        budget -= 1
        if budget < 0:
            return ("unknown", stack[-1][0])
        a, b = stack.pop()
        e, _, slope = enclose(tree, o, d, a, b)
        if e.a > 0 or e.b < 0:
            continue
        sa, sb = sign_at(tree, o, d, a), sign_at(tree, o, d, b)
        monotone = slope.a > 0 or slope.b < 0
        if monotone and sa != 0 and sa == sb:
            continue
        if monotone and sa * sb < 0 or b - a <= eps:
            if sa * sb < 0:
                # A crossing in [a, b]; the first root is here (everything
                # before is excluded); bisect it to 150 bits.
                while b - a > mp.mpf(2) ** -120 * max(unit, abs(b)):
                    m = (a + b) / 2
                    sm = sign_at(tree, o, d, m)
                    if sm == 0:
                        return ("cross", m)
                    if sm == sa:
                        a = m
                    else:
                        b = m
                return ("cross", (a + b) / 2)
            if b - a <= eps:
                if sa == 0:
                    return ("cross", a)
                # No sign change within eps: a double root (or two roots
                # closer than eps, which lgc may report as a touch too).
                m = (a + b) / 2
                return ("double", m)
        m = (a + b) / 2
        stack.append((m, b))
        stack.append((a, m))
    return ("none",)


def has_crease(tree):
    """Whether the formula holds a min, max or abs."""
    stack, seen = [tree], set()
    while stack:
        node = stack.pop()
        if id(node) in seen:
            continue
        seen.add(id(node))
        if node[0] == "call":
            if node[1] in ("min", "max", "abs"):
                return True
            stack.extend(node[2])
        elif node[0] in ("+", "-", "*", "/"):
            stack.extend(node[1:])
        elif node[0] in ("neg", "powi"):
            stack.append(node[1])
    return False


def grad_norm(tree, p, h):
    """|grad f| at p, by central differences of step h (mp)."""
    return mp.sqrt(sum(v * v for v in gradient(tree, p, h)))


def grazes(tree, o, d, t, tol_t, h):
    """Whether the ray passes within the tolerance of the surface near t, to
    first order: |F| there below its noise plus |grad f| times the tolerance
    (a touch at a crease, where the interval of F over the last piece cannot
    exclude a surface that close)."""
    p = [float(o[i] + t * d[i]) for i in range(3)]
    speed = mp.sqrt(sum(v * v for v in d))
    slack = noise(tree, o, d, t, h) + grad_norm(tree, p, h) * tol_t * speed
    return min_abs_near(tree, o, d, t, tol_t) <= slack


def noise(tree, o, d, t, h):
    """f64 rounding noise of F near t: 64 ulps of the absolute-value formula,
    and the point's own rounding times a bound of |grad f| (by differences
    of step h), and 64 of the least subnormals, where f64 stops resolving."""
    p = [float(o[i] + t * d[i]) for i in range(3)]
    s = abs_scale(tree, p)
    size = max(abs(v) for v in p) + abs(t) * max(abs(v) for v in d)
    return 64 * mp.mpf(2) ** -53 * (s + grad_norm(tree, p, h) * size) + 64 * mp.mpf(2) ** -1074


def unresolved(tree, o, d, t):
    """Whether F over the box of points that rounding may put at o + t·d
    (four ulps of |o| + |t·d| each way) holds 0: f64 cannot tell F's sign
    there, whatever F's gradient (at 1e308 an ulp is wider than a unit
    sphere)."""
    r = 4 * mp.mpf(2) ** -53 * (max(abs(v) for v in o) + abs(t) * max(abs(v) for v in d))
    x = [(iv.mpf([o[i] + t * d[i] - r, o[i] + t * d[i] + r]), iv.mpf(0)) for i in range(3)]
    v = evaluate(tree, x, INTERVAL)[0]
    return v.a <= 0 <= v.b


def min_abs_near(tree, o, d, t, width, samples=41):
    """The smallest |F| sampled on [t - width, t + width], in mp."""
    best = mp.inf
    for k in range(samples):
        u = t - width + 2 * width * k / (samples - 1)
        v = abs(evaluate(tree, point_x(o, d, u, REAL), REAL)[0])
        best = min(best, v)
    return best


def judge(tree, o, d, lo, hi, answer):
    """None when lgc's answer agrees with the oracle, else why not."""
    truth = first_root(tree, o, d, lo, hi)
    diag = math.dist(lo, hi)
    unit = t_unit(o, d, lo, hi)
    tol_t = 1e-10 * unit  # lgc's tolerance along the ray
    h = 1e-7 * diag  # the step of finite differences
    if truth[0] == "unknown":
        return None  # the oracle could not settle it: no verdict
    if answer[0] == "none":
        if truth[0] == "none":
            return None
        t = truth[1]
        if truth[0] == "double" and min_abs_near(tree, o, d, t, 2 * tol_t) > noise(tree, o, d, t, h) / 1000:
            # A near-tangency that f64 can resolve: lgc may prove F != 0.
            return None
        return f"lgc: none, oracle: {truth[0]} at {mp.nstr(t, 17)}"
    kind, t = answer
    t = mp.mpf(t)
    if truth[0] == "none":
        # A touch must be within f64 noise of a root (F small there), or
        # graze the surface within the tolerance.
        if kind == "touch" and grazes(tree, o, d, t, tol_t, h):
            return None
        return f"lgc: {kind} {mp.nstr(t, 17)}, oracle: none"
    tt = truth[1]
    close = abs(t - tt) <= max(TOL_REL * max(unit, abs(tt)), 2 * tol_t)
    if kind == "hit":
        if close:
            return None
        return f"lgc: hit {mp.nstr(t, 17)}, oracle: {truth[0]} at {mp.nstr(tt, 17)}"
    # touch: F within f64 noise of 0 near t, and nothing crossing before.
    if t < tt - max(TOL_REL * max(unit, abs(tt)), 2 * tol_t):
        if min_abs_near(tree, o, d, t, tol_t) <= noise(tree, o, d, t, h) or unresolved(tree, o, d, t):
            return None
        return f"lgc: touch {mp.nstr(t, 17)} where |F| exceeds f64 noise, oracle: {truth[0]} at {mp.nstr(tt, 17)}"
    if not close:
        return f"lgc: touch {mp.nstr(t, 17)}, oracle: {truth[0]} at {mp.nstr(tt, 17)}"
    if truth[0] == "double" or min_abs_near(tree, o, d, t, tol_t) <= noise(tree, o, d, t, h):
        return None
    if unresolved(tree, o, d, t):
        return None
    # At a crease a crossing may be answered as a touch in the right place:
    # weaker than a hit, not wrong, when the ray meets the surface there.
    if has_crease(tree) and grazes(tree, o, d, t, tol_t, h):
        return None
    return f"lgc: touch {mp.nstr(t, 17)}, oracle: a simple crossing at {mp.nstr(tt, 17)}"


# ------------------------------------------------------------------ cases ---

SURFACES = [
    # name, formula, box, (centre, radius) of a sphere the surface touches for
    # tangent rays, or None
    ("sphere", "x^2+y^2+z^2-1", (-2, -2, -2, 2, 2, 2)),
    ("torus", "(x^2+y^2+z^2+0.75)^2-4*(x^2+y^2)", (-2, -2, -1, 2, 2, 1)),
    ("plane", "z+0.3", (-1, -1, -1, 1, 1, 1)),
    ("cube", "max(abs(x),abs(y),abs(z))-1", (-2, -2, -2, 2, 2, 2)),
    ("heart", "(x^2+2.25*y^2+z^2-1)^3-x^2*z^3-0.1125*y^2*z^3", (-1.5, -1.5, -1.5, 1.5, 1.5, 1.5)),
    ("gaussian_min", "min(exp(-1*(x^2+y^2+z^2)) + exp(-0.5*((x-1)^2+y^2)) - 0.2, x^4 - 5*x^2 + y^4 - 5*y^2 + z^4 - 5*z^2 + 8)", (-2, -2, -2, 2, 2, 2)),
    ("cancelling", "(z+1e5)^2-z^2-2e5*z-1e10+x^2+y^2+z^2-1", (-2, -2, -2, 2, 2, 2)),
    ("tangle", "x^4-5*x^2+y^4-5*y^2+z^4-5*z^2+11.8", (-3, -3, -3, 3, 3, 3)),
    # CSG: leaves away from the crease are specialised, rays along it are not.
    ("ball_cut", "max(x^2+y^2+z^2-1, z-0.3)", (-2, -2, -2, 2, 2, 2)),
    ("cube_minus_ball", "max(max(abs(x),abs(y),abs(z))-1, 1.69-(x^2+y^2+z^2))", (-2, -2, -2, 2, 2, 2)),
    ("gyroid_ball", "max(sin(4*x)*cos(4*y)+sin(4*y)*cos(4*z)+sin(4*z)*cos(4*x), x^2+y^2+z^2-1)", (-2, -2, -2, 2, 2, 2)),
    # Round strokes of lettering as a slab: leaves hold the circles' centres,
    # where grad f is undefined though f is 1-Lipschitz.
    ("strokes", "max(min(sqrt((x-0.31)^2+(y-0.12)^2)-0.03, sqrt((x+0.4)^2+y^2)-0.05), abs(z)-0.1)", (-1, -1, -1, 1, 1, 1)),
]

# Rays that once got wrong answers, as (surface formula, box, ray).
MODELS = [
    # name, .vm file, box
    ("bear", os.path.join(HERE, "..", "..", "examples", "models", "bear.vm"), (-1.2, -1.2, -1.2, 1.2, 1.2, 1.2)),
]

FIXED = [
    ("z+0.3", (-1, -1, -1, 1, 1, 1), "-3 0.5 -0.300001 1 0 0"),
    ("y", (-2, -2, -2, 2, 2, 2), "0 0.000001 -5 0 0 1"),
    ("max(abs(x),abs(y),abs(z))-1", (-2, -2, -2, 2, 2, 2), "-3 1.000001 0.2 1 0 0"),
    (SURFACES[5][1], (-2, -2, -2, 2, 2, 2),
     "-0.3895635886193114 -1.9626110683387603 -0.857731638034863 0.7387928642675752 0.6598363953923365 0.13711686629645706"),
    ("max(abs(x),abs(y),abs(z))-2", (-2, -2, -2, 2, 2, 2), "-5 0.3 0.2 1 0 0"),
    # At the extremes of f64: a direction of 1e-170 (root at t = 5e169), a
    # surface scaled by 1e200, subnormal direction components, a surface on
    # the box's wall, and a ray from 1e308 into a box of ±1e300.
    ("x^2+y^2+z^2-1", (-2, -2, -2, 2, 2, 2), "0 0 -1.5 0 0 1e-170"),
    ("1e200*(x^2+y^2+z^2)-1e200", (-2, -2, -2, 2, 2, 2), "0.5 0 -1.5 0 0 1e-200"),
    ("ln(x^2+y^2+z^2)", (-2, -2, -2, 2, 2, 2), "0 0 -3 1e-320 1e-320 1"),
    ("max(abs(x),abs(y),abs(z))-2", (-2, -2, -2, 2, 2, 2),
     "-3.954615319081471 0.47762324501249065 -1.0324676372729522 3726.1110286687654 -1265.051425676977 263.9244892315902"),
    ("x^2+y^2+z^2-1", (-1e300, -1e300, -1e300, 1e300, 1e300, 1e300), "1e308 1e308 1e308 -1 -1 -1"),
    # Through leaves holding a circle's centre, where L comes from slopes
    # carried through the formula: onto the dot's face, into its side
    # through the centre, along the slab, and past it.
    (SURFACES[-1][1], (-1, -1, -1, 1, 1, 1), "0.31 0.12 -3 0 0 1"),
    (SURFACES[-1][1], (-1, -1, -1, 1, 1, 1), "-0.59 -0.48 -3 0.3 0.2 1"),
    (SURFACES[-1][1], (-1, -1, -1, 1, 1, 1), "-3 0.12 0 1 0 0"),
    (SURFACES[-1][1], (-1, -1, -1, 1, 1, 1), "0.31 0.12 -3 0.02 0 1"),
]

# Surfaces at other scales of space and value: c*f(x/s, y/s, z/s) in the box
# scaled by s, along rays scaled by s whose directions are scaled again by u
# (so t scales by 1/u); s, c and u range over 1e-300 to 1e300.
SCALED = ["sphere", "torus", "cube", "heart", "tangle", "cube_minus_ball", "gyroid_ball"]


def scaled_case(rng, name, formula, box):
    """A surface of SURFACES at random scales, with rays: (formula, box, rays)."""
    while True:
        s, c, u = (10.0 ** rng.uniform(-300, 300) for _ in range(3))
        # Coordinates, directions and every t inside f64's range.
        if 1e-300 < s * u < 1e300 and 1e-290 < u and 100 * c < 1e300:
            break
    inv = repr(1.0 / s)
    scaled = re.sub(r"\b([xyz])\b", lambda m: f"({m.group(1)}*{inv})", formula)
    scaled_box = tuple(v * s for v in box)
    rays = []
    for _ in range(6):
        o, d = random_ray(rng, box)
        rays.append(([v * s for v in o], [v * s * u for v in d]))
    return f"{c!r}*({scaled})", scaled_box, rays


def grazing(rng, name):
    """A ray tangent to the surface at a known point, pushed off by ±delta."""
    delta = rng.choice([1e-6, 1e-9, 1e-12]) * rng.choice([-1, 1])
    if name == "sphere":
        n = [rng.gauss(0, 1) for _ in range(3)]
        ln = math.sqrt(sum(v * v for v in n))
        n = [v / ln for v in n]
        p = [v * (1 + delta) for v in n]
    elif name == "plane":
        n = [0.0, 0.0, 1.0]
        p = [rng.uniform(-0.5, 0.5), rng.uniform(-0.5, 0.5), -0.3 + delta]
    elif name == "torus":
        # The top circle z = 0.5 of the torus R = 1, r = 0.5.
        a = rng.uniform(0, 2 * math.pi)
        n = [0.0, 0.0, 1.0]
        p = [math.cos(a), math.sin(a), 0.5 + delta]
    elif name == "cube":
        n = [0.0, 1.0, 0.0]
        p = [rng.uniform(-0.9, 0.9), 1 + delta, rng.uniform(-0.9, 0.9)]
    elif name == "ball_cut":
        # Through the crease circle z = 0.3, pushed off along the sphere's
        # normal, in any direction: along the crease, across it, grazing it.
        a = rng.uniform(0, 2 * math.pi)
        r = math.sqrt(0.91)
        c = [r * math.cos(a), r * math.sin(a), 0.3]
        p = [v * (1 + delta) for v in c]
        t = [rng.gauss(0, 1) for _ in range(3)]
        s = rng.uniform(2.5, 4)
        return [p[i] - s * t[i] for i in range(3)], t
    else:
        return None
    t = [rng.gauss(0, 1) for _ in range(3)]
    dot = sum(t[i] * n[i] for i in range(3))
    t = [t[i] - dot * n[i] for i in range(3)]
    s = rng.uniform(2.5, 4)
    o = [p[i] - s * t[i] for i in range(3)]
    return o, t


def random_ray(rng, box):
    lo, hi = box[:3], box[3:]
    target = [rng.uniform(0.8 * lo[i], 0.8 * hi[i]) for i in range(3)]
    o = [rng.uniform(1.5 * lo[i], 1.5 * hi[i]) for i in range(3)]
    if all(lo[i] < o[i] < hi[i] for i in range(3)) and rng.random() < 0.5:
        o = [target[i] + 3 * (hi[i] - lo[i]) * rng.choice([-1, 1]) for i in range(3)]
    return o, [target[i] - o[i] for i in range(3)]


def bundle(rng, box):
    """16 rays from one eye outside the box through a narrow cone, as a tile of
    camera rays: `lgc trace --bundle` proves the space before the surface empty for
    all of them at once and starts each ray there."""
    lo, hi = box[:3], box[3:]
    centre = [(lo[i] + hi[i]) / 2 for i in range(3)]
    size = math.sqrt(sum((hi[i] - lo[i]) ** 2 for i in range(3)))
    away = [rng.gauss(0, 1) for _ in range(3)]
    n = math.sqrt(sum(a * a for a in away)) or 1.0
    eye = [centre[i] + away[i] / n * size * rng.uniform(0.8, 2.0) for i in range(3)]
    target = [rng.uniform(0.8 * lo[i], 0.8 * hi[i]) for i in range(3)]
    forward = [target[i] - eye[i] for i in range(3)]
    width = 10 ** rng.uniform(-3, -1) * math.sqrt(sum(f * f for f in forward))
    return [(eye, [forward[i] + width * rng.uniform(-1, 1) for i in range(3)]) for _ in range(16)]


def gradient(tree, p, h):
    """grad f at p (floats), by central differences of step h, in mp."""
    g = []
    for i in range(3):
        q1, q2 = [mp.mpf(v) for v in p], [mp.mpf(v) for v in p]
        q1[i] += h
        q2[i] -= h
        f1 = evaluate(tree, [(v, 0) for v in q1], REAL)[0]
        f2 = evaluate(tree, [(v, 0) for v in q2], REAL)[0]
        g.append((f1 - f2) / (2 * h))
    return g


def leaving(rng, tree, box, rays, answers):
    """Rays that leave the surface, as shadow and reflected rays do: from each hit
    of `rays`, started 1e-7 to 1e-4 of the box off it along the normal, half to
    each side, in a random direction on that side, a third of them nearly along
    the surface (which they may meet again close by). `lgc trace --from-surface`
    tests each from its start first."""
    size = math.sqrt(sum((box[3 + i] - box[i]) ** 2 for i in range(3)))
    out = []
    for (o, d), answer in zip(rays, answers):
        if answer[0] != "hit":
            continue
        p = [o[i] + answer[1] * d[i] for i in range(3)]
        g = gradient(tree, p, 1e-6 * size)
        gn = mp.sqrt(sum(v * v for v in g))
        if not gn > 0 or not mp.isfinite(gn):
            continue
        n = [float(v / gn) for v in g]
        for side in (1.0, -1.0):
            l = [rng.gauss(0, 1) for _ in range(3)]
            ln = sum(l[i] * n[i] for i in range(3))
            if ln * side < 0:
                l = [l[i] - 2 * ln * n[i] for i in range(3)]
                ln = -ln
            if rng.random() < 0.33:
                l = [l[i] - 0.97 * ln * n[i] for i in range(3)]
            step = side * size * 10 ** rng.uniform(-7, -4)
            out.append(([p[i] + step * n[i] for i in range(3)], l))
    return out


def run_lgc(lgc, formula, box, rays, bundled=False, from_surface=False):
    text = "".join(" ".join(repr(float(v)) for v in o + d) + "\n" for o, d in rays)
    out = subprocess.run(
        [lgc, "trace", formula, "--box=" + ",".join(repr(float(v)) for v in box)]
        + (["--bundle"] if bundled else [])
        + (["--from-surface"] if from_surface else []),
        input=text, capture_output=True, text=True, check=True,
    ).stdout.split("\n")
    answers = []
    for line in out[: len(rays)]:
        parts = line.split()
        if parts == ["none"]:
            answers.append(("none",))
        elif parts[0] in ("touch", "undecided"):
            answers.append((parts[0], float(parts[1])))
        else:
            answers.append(("hit", float(parts[0])))
    return answers


VM_BINARY = {"add": "+", "sub": "-", "mul": "*", "div": "/"}
VM_CALLS = ("sqrt", "exp", "ln", "sin", "cos", "abs")


def read_vm(path):
    """A model in fidget's .vm format (`_id op args`, one per line, the last
    the surface) as a tree whose shared subexpressions are shared nodes."""
    nodes = {}
    last = None
    for line in open(path):
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        name, op, *args = line.split()
        a = [nodes[v] for v in args] if op != "const" else []
        if op.startswith("var-"):
            node = ("var", "xyz".index(op[4:]))
        elif op == "const":
            node = ("num", float(args[0]))
        elif op in VM_BINARY:
            node = (VM_BINARY[op], a[0], a[1])
        elif op == "neg":
            node = ("neg", a[0])
        elif op == "square":
            node = ("powi", a[0], 2)
        elif op in ("min", "max"):
            node = ("call", op, a)
        elif op in VM_CALLS:
            node = ("call", op, a)
        else:
            raise SyntaxError(f"{path}: {op} is not in the oracle")
        nodes[name] = node
        last = node
    return last


def load(formula):
    """The oracle's tree of a formula, or of a model file."""
    return read_vm(formula) if formula.endswith(".vm") else Parser(formula).parse()


def check(lgc, formula, box, rays, bundled=False, from_surface=False, allow_undecided=False):
    tree = load(formula)
    answers = run_lgc(lgc, formula, box, rays, bundled, from_surface)
    failures = []
    counts = {}
    for (o, d), answer in zip(rays, answers):
        counts[answer[0]] = counts.get(answer[0], 0) + 1
        if answer[0] == "undecided":
            if not allow_undecided:
                failures.append(f"undecided ray {o} {d}")
            continue
        om = [mp.mpf(float(v)) for v in o]
        dm = [mp.mpf(float(v)) for v in d]
        why = judge(tree, om, dm, box[:3], box[3:], answer)
        if why:
            failures.append(f"{formula} ray {' '.join(repr(float(v)) for v in o + d)}: {why}")
    return failures, counts, answers


def tally(into, counts):
    """Adds one check's counts of answers by kind into a running total."""
    for k, v in counts.items():
        into[k] = into.get(k, 0) + v


def main():
    lgc = sys.argv[1]
    per = int(sys.argv[2]) if len(sys.argv) > 2 else 40
    seed = int(sys.argv[3]) if len(sys.argv) > 3 else 2026
    rng = random.Random(seed)
    failures, total = [], 0
    for formula, box, ray in FIXED:
        v = [float(s) for s in ray.split()]
        f, _, _ = check(lgc, formula, box, [(v[:3], v[3:])])
        failures += f
        total += 1
    for name, formula, box in SURFACES:
        rays = []
        for k in range(per):
            g = grazing(rng, name) if k % 4 == 0 else None
            rays.append(g or random_ray(rng, box))
        f, counts, answers = check(lgc, formula, box, rays)
        failures += f
        total += len(rays)
        print(f"{name:<14} {len(rays)} rays: " + ", ".join(f"{v} {k}" for k, v in sorted(counts.items())))
        # Rays leaving the surface from those hits (`lgc trace --from-surface`).
        away = leaving(rng, Parser(formula).parse(), box, rays, answers)
        f, counts, _ = check(lgc, formula, box, away, from_surface=True)
        failures += f
        total += len(away)
        print(f"{name:<14} {len(away)} rays leaving it: " + ", ".join(f"{v} {k}" for k, v in sorted(counts.items())))
    # Real models (fidget's .vm format): rays through their middle, a fifth as
    # many (each evaluation of the oracle walks hundreds of operations).
    for name, path, box in MODELS:
        rays = [random_ray(rng, box) for _ in range(max(1, per // 5))]
        f, counts, _ = check(lgc, path, box, rays)
        failures += f
        total += len(rays)
        print(f"{name:<14} {len(rays)} rays: " + ", ".join(f"{v} {k}" for k, v in sorted(counts.items())))
    # The surfaces at other scales: each answer right, or undecided.
    for name, formula, box in SURFACES:
        if name not in SCALED:
            continue
        scaled = {}
        for _ in range(2):
            f_scaled, b_scaled, rays = scaled_case(rng, name, formula, box)
            f, counts, _ = check(lgc, f_scaled, b_scaled, rays, allow_undecided=True)
            failures += f
            total += len(rays)
            tally(scaled, counts)
        print(f"{name:<14} 2 scales, 6 rays each: " + ", ".join(f"{v} {k}" for k, v in sorted(scaled.items())))
    # The same surfaces through bundles of camera rays (`lgc trace --bundle`).
    for name, formula, box in SURFACES:
        bundled = {}
        for _ in range(3):
            rays = bundle(rng, box)
            f, counts, _ = check(lgc, formula, box, rays, bundled=True)
            failures += f
            total += len(rays)
            tally(bundled, counts)
        print(f"{name:<14} 3 bundles of 16: " + ", ".join(f"{v} {k}" for k, v in sorted(bundled.items())))
    for line in failures[:20]:
        print("FAIL", line)
    print(f"rays: {total - len(failures)} passed, {len(failures)} failed")
    sys.exit(1 if failures else 0)


if __name__ == "__main__":
    main()
