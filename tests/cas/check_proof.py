#!/usr/bin/env python3
"""A second checker of lgc's proof files, written from docs/bounds.md
("Proof files") alone: its own parser of the formula language, its own
differentiation by the documented rules, and mpmath's interval arithmetic
at 113 bits (monotone functions mpmath's iv lacks are evaluated at 113 bits
and widened by 2^-100 of their size). It shares no code with lgc.

Usage:
  check_proof.py FILE.json...        check proof files; exit 1 if any fails
  check_proof.py --lgc PATH_TO_LGC   write proofs of every corpus surface's
                                     L (and G on a ray) with `lgc verify
                                     --proof`, check each, and check that
                                     altered copies are rejected
"""
import json
import math
import os
import re
import subprocess
import sys
import tempfile

import mpmath
from mpmath import iv, mp

PREC = 113
iv.prec = PREC
mp.prec = PREC
WIDEN = mpmath.mpf(2) ** -100
INF = mpmath.inf

# --- intervals: an iv.mpf, or None for the empty set -------------------------


def point(v):
    return iv.mpf([v, v])


def ends(a):
    """(lower, upper) as mpf."""
    return mpmath.mpf(a.a), mpmath.mpf(a.b)


def make(l, h):
    return iv.mpf([l, h])


def mag(a):
    l, h = ends(a)
    return max(abs(l), abs(h))


def mig(a):
    l, h = ends(a)
    if l <= 0 <= h:
        return mpmath.mpf(0)
    return min(abs(l), abs(h))


def hull(a, b):
    (al, ah), (bl, bh) = ends(a), ends(b)
    return make(min(al, bl), max(ah, bh))


def restrict(a, l, h):
    """a ∩ [l, h], None when empty."""
    al, ah = ends(a)
    nl, nh = max(al, l), min(ah, h)
    return None if nl > nh else make(nl, nh)


def monotone(f, a, increasing=True):
    """f over a, for a monotone f computed at 113 bits, widened outward."""
    al, ah = ends(a)

    def at(v, up):
        if v in (INF, -INF):
            return f(v)
        r = f(v)
        return r + WIDEN * (abs(r) + mpmath.mpf(2) ** -1000) * (1 if up else -1)

    if increasing:
        return make(at(al, False), at(ah, True))
    return make(at(ah, False), at(al, True))


def i_sqrt(a):
    a = restrict(a, 0, INF)
    return None if a is None else iv.sqrt(a)


def i_ln(a):
    a = restrict(a, 0, INF)
    if a is None:
        return None
    l, h = ends(a)
    lower = -INF if l == 0 else iv.log(point(l)).a
    return make(lower, iv.log(point(h)).b if h < INF else INF)


def i_cosh(a):
    l, h = ends(a)
    if l >= 0:
        return monotone(mp.cosh, a, True)
    if h <= 0:
        return monotone(mp.cosh, a, False)
    return make(1, max(monotone(mp.cosh, point(l), False).b, monotone(mp.cosh, point(h), True).b))


def i_pow(a, b):
    """a^b = exp(b ln a) for a >= 0; [0, inf] where a reaches 0."""
    a = restrict(a, 0, INF)
    if a is None:
        return None
    if ends(a)[0] > 0:
        return iv.exp(b * i_ln(a))
    return make(0, INF)


def i_choose(c, p, q):
    cl, ch = ends(c)
    if ch < 0:
        return p
    if cl > 0:
        return q
    return hull(p, q)


def i_sign(a):
    l, h = ends(a)
    return make(-1 if l < 0 else (0 if l == 0 else 1), 1 if h > 0 else (0 if h == 0 else -1))


def i_dirac(a):
    l, h = ends(a)
    return make(0, INF) if l <= 0 <= h else point(0)


FUNCS = {
    "sqrt": i_sqrt,
    "abs": lambda a: make(mig(a), mag(a)),
    "sin": iv.sin,
    "cos": iv.cos,
    "tan": iv.tan,
    "asin": lambda a: (lambda r: None if r is None else monotone(mp.asin, r, True))(restrict(a, -1, 1)),
    "acos": lambda a: (lambda r: None if r is None else monotone(mp.acos, r, False))(restrict(a, -1, 1)),
    "atan": lambda a: monotone(mp.atan, a, True),
    "exp": iv.exp,
    "ln": i_ln,
    "sinh": lambda a: monotone(mp.sinh, a, True),
    "cosh": i_cosh,
    "tanh": lambda a: monotone(mp.tanh, a, True),
    "sech": lambda a: point(1) / i_cosh(a),
    "sign": i_sign,
    "dirac": i_dirac,
}

# --- the formula language ------------------------------------------------------

TOKEN = re.compile(r"\s*(?:#[^\n]*|(\d+\.?\d*(?:[eE][-+]?\d+)?|\.\d+(?:[eE][-+]?\d+)?)|([A-Za-z_]\w*)|(\S))")


def tokens(text):
    out, i = [], 0
    while i < len(text):
        m = TOKEN.match(text, i)
        if not m or m.end() == i:
            break
        i = m.end()
        if m.group(1):
            out.append(("num", float(m.group(1))))
        elif m.group(2):
            out.append(("let", None) if m.group(2) == "let" else ("name", m.group(2)))
        elif m.group(3):
            out.append(("op", m.group(3)))
    out.append(("end", None))
    return out


class Terms:
    """The formula's terms, each after its operands, with their derivatives:
    the rules and simplifications of docs/bounds.md."""

    def __init__(self):
        self.t = []
        self.deriv = {}
        self.uppers = {}
        self.zero = self.push(("const", point(0)))
        self.one = self.push(("const", point(1)))

    def operands(self, term):
        k = term[0]
        if k in ("const", "var"):
            return []
        if k in ("neg", "call", "powi"):
            return [term[-1]] if k == "call" else [term[1]]
        return list(term[1:])

    def varies(self, i):
        return self.t[i][0] != "const"

    def push(self, term):
        self.t.append(term)
        i = len(self.t) - 1
        if term[0] not in ("const", "var") and not any(self.varies(o) for o in self.operands(term)):
            vals = {o: self.t[o][1] for o in self.operands(term)}
            self.t[i] = ("const", self.eval_one(term, vals.__getitem__))
        return i

    def is_(self, i, v):
        term = self.t[i]
        if term[0] != "const" or term[1] is None:
            return False
        l, h = ends(term[1])
        return l == h == v

    def const(self, v):
        return self.push(("const", point(v)))

    def add(self, a, b):
        if self.is_(a, 0):
            return b
        if self.is_(b, 0):
            return a
        return self.push(("add", a, b))

    def sub(self, a, b):
        if self.is_(b, 0):
            return a
        if self.is_(a, 0):
            return self.push(("neg", b))
        return self.push(("sub", a, b))

    def mul(self, a, b):
        if self.is_(a, 0) or self.is_(b, 0):
            return self.zero
        if self.is_(a, 1):
            return b
        if self.is_(b, 1):
            return a
        return self.push(("mul", a, b))

    def div(self, a, b):
        return self.zero if self.is_(a, 0) else self.push(("div", a, b))

    def neg(self, a):
        return self.zero if self.is_(a, 0) else self.push(("neg", a))

    def call(self, f, a):
        return self.push(("call", f, a))

    def powi(self, a, n):
        return self.push(("powi", a, n))

    def power(self, a, b):
        term = self.t[b]
        if term[0] == "const" and term[1] is not None:
            l, h = ends(term[1])
            if l == h and l == int(l) and abs(l) <= 1024:
                n = int(l)
                return self.one if n == 0 else a if n == 1 else self.powi(a, n)
        return self.push(("pow", a, b))

    def choose(self, c, p, q):
        return p if p == q else self.push(("choose", c, p, q))

    # reading

    def read(self, text, ray=None):
        self.toks, self.i = tokens(text), 0
        scope = {}
        for k, name in enumerate("xyz"):
            if ray is None:
                scope[name] = self.push(("var", k))
            else:
                o, d = ray
                step = self.mul(self.push(("var", 3)), self.const(d[k]))
                scope[name] = self.add(self.const(o[k]), step)
        scope["pi"], scope["e"] = self.const(math.pi), self.const(math.e)
        while self.peek() == ("let", None):
            self.take()
            name = self.take("name")[1]
            self.take("op", "=")
            scope[name] = self.expr(scope)
            self.take("op", ";")
        root = self.expr(scope)
        self.take("end")
        return root

    def peek(self):
        return self.toks[self.i]

    def take(self, kind=None, value=None):
        tok = self.toks[self.i]
        if kind and tok[0] != kind or value is not None and tok[1] != value:
            raise SyntaxError(f"expected {value or kind}, found {tok[1]!r}")
        self.i += 1
        return tok

    def expr(self, s):
        e = self.term(s)
        while self.peek() in (("op", "+"), ("op", "-")):
            op = self.take()[1]
            r = self.term(s)
            e = self.add(e, r) if op == "+" else self.sub(e, r)
        return e

    def term(self, s):
        e = self.unary(s)
        while self.peek() in (("op", "*"), ("op", "/")):
            op = self.take()[1]
            r = self.unary(s)
            e = self.mul(e, r) if op == "*" else self.div(e, r)
        return e

    def unary(self, s):
        if self.peek() == ("op", "-"):
            self.take()
            return self.neg(self.unary(s))
        a = self.atom(s)
        if self.peek() == ("op", "^"):
            self.take()
            return self.power(a, self.unary(s))
        return a

    def atom(self, s):
        kind, v = self.take()
        if kind == "num":
            return self.const(v)
        if (kind, v) == ("op", "("):
            e = self.expr(s)
            self.take("op", ")")
            return e
        if kind != "name":
            raise SyntaxError(f"unexpected {v!r}")
        if self.peek() != ("op", "("):
            if v not in s:
                raise SyntaxError(f"unknown name {v}")
            return s[v]
        self.take()
        args = [self.expr(s)]
        while self.peek() == ("op", ","):
            self.take()
            args.append(self.expr(s))
        self.take("op", ")")
        if v in FUNCS and v != "dirac" and len(args) == 1:
            return self.call(v, args[0])
        if v == "log" and len(args) == 1:
            return self.div(self.call("ln", args[0]), self.call("ln", self.const(10.0)))
        if v in ("min", "union", "max", "intersect") and len(args) >= 2:
            kind = "min" if v in ("min", "union") else "max"
            e = args[0]
            for a in args[1:]:
                e = self.push((kind, e, a))
            return e
        if v == "subtract" and len(args) == 2:
            return self.push(("max", args[0], self.neg(args[1])))
        if v == "hypot" and len(args) == 2:
            return self.call("sqrt", self.add(self.powi(args[0], 2), self.powi(args[1], 2)))
        if v == "pow" and len(args) == 2:
            return self.power(args[0], args[1])
        raise SyntaxError(f"{v} with {len(args)} arguments is not in the checked language")

    # derivatives

    def derivative(self, i, var):
        if (i, var) in self.deriv:
            return self.deriv[(i, var)]
        stack = [(i, False)]
        while stack:
            j, expanded = stack.pop()
            if (j, var) in self.deriv:
                continue
            if not expanded:
                stack.append((j, True))
                stack.extend((o, False) for o in self.operands(self.t[j]))
                continue
            self.deriv[(j, var)] = self.derive_one(j, var)
        return self.deriv[(i, var)]

    def derive_one(self, this, var):
        term = self.t[this]
        k = term[0]
        d = lambda a: self.deriv[(a, var)]  # noqa: E731
        if k == "const":
            return self.zero
        if k == "var":
            return self.one if term[1] == var else self.zero
        if k == "add":
            return self.add(d(term[1]), d(term[2]))
        if k == "sub":
            return self.sub(d(term[1]), d(term[2]))
        if k == "neg":
            return self.neg(d(term[1]))
        if k == "mul":
            a, b = term[1], term[2]
            return self.add(self.mul(d(a), b), self.mul(a, d(b)))
        if k == "div":
            a, b = term[1], term[2]
            return self.div(self.sub(d(a), self.mul(this, d(b))), b)
        if k == "powi":
            a, n = term[1], term[2]
            lower = self.one if n - 1 == 0 else a if n - 1 == 1 else self.powi(a, n - 1)
            return self.mul(self.mul(self.const(float(n)), d(a)), lower)
        if k == "pow":
            a, b = term[1], term[2]
            s = self.add(self.mul(d(b), self.call("ln", a)), self.mul(b, self.div(d(a), a)))
            return self.mul(this, s)
        if k == "call":
            f, a = term[1], term[2]
            if self.is_(d(a), 0):
                return self.zero
            exps = self.sum_of_exps(a) if f == "ln" else None
            if exps is not None:
                return self.log_sum_exp(*exps, d(exps[0]), d(exps[1]))
            return self.mul(self.slope(f, this, a), d(a))
        if k in ("min", "max"):
            a, b = term[1], term[2]
            c = self.sub(a, b)
            neg, pos = (d(a), d(b)) if k == "min" else (d(b), d(a))
            return self.choose(c, neg, pos)
        if k == "choose":
            c, p, q = term[1], term[2], term[3]
            smooth = self.choose(c, d(p), d(q))
            rate = self.mul(d(c), self.sub(q, p))
            if self.is_(rate, 0):
                return smooth
            return self.add(smooth, self.mul(self.call("dirac", c), rate))
        raise ValueError(k)

    def sum_of_exps(self, u):
        """(a, b) where the term u is exp(a) + exp(b), else None."""
        t = self.t[u]
        if t[0] != "add":
            return None
        p, q = self.t[t[1]], self.t[t[2]]
        if p[0] == "call" and p[1] == "exp" and q[0] == "call" and q[1] == "exp":
            return p[2], q[2]
        return None

    def log_sum_exp(self, a, b, da, db):
        """ln(exp(a) + exp(b))' = 1/2*(a' + b') + 1/2*tanh(1/2*(a - b))*(a' - b')."""
        half = self.const(0.5)
        half_sum = self.mul(half, self.add(da, db))
        diff = self.sub(da, db)
        if self.is_(diff, 0):
            return half_sum
        weight = self.call("tanh", self.mul(half, self.sub(a, b)))
        return self.add(half_sum, self.mul(weight, self.mul(half, diff)))

    def slope(self, f, this, a):
        one = self.one
        if f == "sqrt":
            return self.div(one, self.mul(self.const(2.0), this))
        if f == "abs":
            return self.call("sign", a)
        if f == "sin":
            return self.call("cos", a)
        if f == "cos":
            return self.neg(self.call("sin", a))
        if f == "tan":
            return self.add(one, self.powi(this, 2))
        if f in ("asin", "acos"):
            inv = self.div(one, self.call("sqrt", self.sub(one, self.powi(a, 2))))
            return self.neg(inv) if f == "acos" else inv
        if f == "atan":
            return self.div(one, self.add(one, self.powi(a, 2)))
        if f == "exp":
            return this
        if f == "ln":
            return self.div(one, a)
        if f == "sinh":
            return self.call("cosh", a)
        if f == "cosh":
            return self.call("sinh", a)
        if f == "tanh":
            return self.sub(one, self.powi(this, 2))
        if f == "sech":
            return self.neg(self.mul(this, self.call("tanh", a)))
        if f == "sign":
            return self.mul(self.const(2.0), self.call("dirac", a))
        raise ValueError(f"no derivative of {f}")

    # evaluation

    def eval_one(self, term, at):
        k = term[0]
        if k == "const":
            return term[1]
        ops = [at(o) for o in self.operands(term)]
        if any(v is None for v in ops):
            return None
        if k == "add":
            return ops[0] + ops[1]
        if k == "sub":
            return ops[0] - ops[1]
        if k == "mul":
            return ops[0] * ops[1]
        if k == "div":
            return ops[0] / ops[1]
        if k == "neg":
            return -ops[0]
        if k == "powi":
            return ops[0] ** term[2]
        if k == "pow":
            return i_pow(ops[0], ops[1])
        if k in ("min", "max"):
            (al, ah), (bl, bh) = ends(ops[0]), ends(ops[1])
            f = min if k == "min" else max
            return make(f(al, bl), f(ah, bh))
        if k == "choose":
            return i_choose(*ops)
        if k == "call":
            return FUNCS[term[1]](ops[0])
        raise ValueError(k)

    def evaluate(self, vars4):
        vals = []
        for term in self.t:
            vals.append(vars4[term[1]] if term[0] == "var" else self.eval_one(term, vals.__getitem__))
        return vals


# --- the checker ---------------------------------------------------------------


class Rejected(Exception):
    pass


QUANTITIES = {}


def quantity(proof):
    """The formula's derivatives for the claim, read once per formula and
    claim (a pure function: altered copies of a proof share it)."""
    key = (proof["formula"], json.dumps(proof["claim"], sort_keys=True))
    if key not in QUANTITIES:
        QUANTITIES[key] = read_quantity(proof)
    return QUANTITIES[key]


def read_quantity(proof):
    claim = proof["claim"]
    t = Terms()
    if claim["quantity"] == "lipschitz":
        f = t.read(proof["formula"])
        return t, [t.derivative(f, v) for v in range(3)]
    r = claim["ray"]
    f = t.read(proof["formula"], ray=(r[:3], r[3:]))
    return t, [t.derivative(t.derivative(f, 3), 3)]


def derivatives(t, roots, region):
    if len(region) == 3:
        vars4 = [make(*region[0]), make(*region[1]), make(*region[2]), point(0)]
    else:
        vars4 = [point(0), point(0), point(0), make(*region[0])]
    vals = t.evaluate(vars4)
    return [vals[r] for r in roots]


def upper(t, roots, region):
    """The quantity's bound over the region, computed once per region."""
    key = tuple(map(tuple, region))
    if key not in t.uppers:
        t.uppers[key] = compute_upper(t, roots, region)
    return t.uppers[key]


def compute_upper(t, roots, region):
    m = [mpmath.mpf(0) if d is None else mag(d) for d in derivatives(t, roots, region)]
    if any(v == INF for v in m):
        return INF
    if len(m) == 1:
        return m[0]
    return iv.sqrt(sum((point(v) ** 2 for v in m), point(0))).b


def lower_at(t, roots, at):
    ds = derivatives(t, roots, [(v, v) for v in at])
    if any(d is None for d in ds):
        return mpmath.mpf(0)
    m = [mig(d) for d in ds]
    if len(m) == 1:
        return m[0]
    return iv.sqrt(sum((point(v) ** 2 for v in m), point(0))).a


def constant_of(text):
    t = Terms()
    c = t.read(text)
    if t.varies(c) or t.t[c][1] is None:
        raise Rejected(f"the constant {text!r} is not a constant")
    return t.t[c][1]


def check(proof):
    """What the proof shows, as a dict; raises Rejected."""
    if proof.get("lgc_proof") != 1:
        raise Rejected("not a version 1 proof")
    claim = proof["claim"]
    c = constant_of(claim["constant"])
    cl, ch = ends(c)
    if claim["quantity"] == "lipschitz":
        b = claim["box"]
        root = [(b[0], b[3]), (b[1], b[4]), (b[2], b[5])]
    else:
        root = [tuple(claim["t"])]
    if any(not (l <= h) for l, h in root):
        raise Rejected("the region is empty")
    t, roots = quantity(proof)
    if proof["verdict"] == "refuted":
        w = proof["witness"]
        at = [w["t"]] if claim["quantity"] == "grad_lipschitz" else w["point"]
        if any(not (l <= v <= h) for v, (l, h) in zip(at, root)):
            raise Rejected("the witness is outside the region")
        value = lower_at(t, roots, at)
        if not (mpmath.mpf(w["at_least"]) <= value and mpmath.mpf(w["at_least"]) > ch):
            raise Rejected(f"the witness's value {value} does not refute the claim")
        return {"verdict": "refuted", "value": value}
    stack, leaves, largest = [root], 0, mpmath.mpf(0)
    for k, e in enumerate(proof["tree"]):
        if not stack:
            raise Rejected(f"entry {k} is left over")
        region = stack.pop()
        if isinstance(e, list):
            axis, at = e
            if not (isinstance(axis, int) and 0 <= axis < len(region)):
                raise Rejected(f"entry {k}: no axis {axis}")
            l, h = region[axis]
            if not (l < at < h and at == l + 0.5 * (h - l)):
                raise Rejected(f"entry {k}: the split {at!r} is not the midpoint of {region}")
            low, high = list(region), list(region)
            low[axis], high[axis] = (l, at), (at, h)
            stack += [high, low]
        else:
            u = upper(t, roots, region)
            if not (u <= mpmath.mpf(e)):
                raise Rejected(f"entry {k}: the natural extension gives {mpmath.nstr(u, 20)} over {region}, above the recorded {e!r}")
            if not (mpmath.mpf(e) <= cl):
                raise Rejected(f"entry {k}: the recorded {e!r} exceeds the constant")
            leaves += 1
            largest = max(largest, u)
    if stack:
        raise Rejected(f"{len(stack)} regions are not covered")
    return {"verdict": "proved", "leaves": leaves, "largest": largest}


# --- CI: proofs of the corpus, and altered copies ------------------------------


def run(lgc, *args):
    return subprocess.run([lgc, *args], capture_output=True, text=True)


def rejected(proof):
    try:
        check(proof)
    except Rejected:
        return True
    return False


def corpus(lgc):
    here = os.path.dirname(os.path.abspath(__file__))
    surfaces = json.load(open(os.path.join(here, "..", "..", "examples", "surfaces.json")))
    # A narrow ridge: its proof splits only the two coordinates it varies in.
    surfaces["ridge"] = {"expr": "x + exp(-((y-0.2)^2+z^2)*900)", "box": [-1, -1, -1, 1, 1, 1]}
    # Two balls' exponential smooth union, whose derivative is the documented
    # weighted mean (L <= 1.5 takes 982 leaves; 240,159 by the quotient of
    # exponentials).
    union = "-ln(exp(-16*(sqrt(x^2+y^2+z^2)-0.8)) + exp(-16*(sqrt((x-0.7)^2+y^2+z^2)-0.5)))/16"
    surfaces["smooth union"] = {"expr": union, "claims": [
        (["--box=0.1,0.1,0.1,1,1,1", "--lipschitz", "1.5"], "L"),
        (["--ray=-1,0.3,0.2,1,0,0", "--t=0,2", "--grad-lipschitz", "6"], "G"),
    ]}
    failures, proofs = [], 0
    with tempfile.TemporaryDirectory() as tmp:
        for name, s in surfaces.items():
            if "claims" in s:
                proofs += check_claims(lgc, tmp, name, s["expr"], s["claims"], failures)
                continue
            box = ",".join(repr(float(v)) for v in s["box"])
            b = json.loads(run(lgc, "bounds", s["expr"], "--box=" + box, "--tolerance", "0.01", "--json").stdout)
            b0 = s["box"]
            centre = [(b0[k] + b0[k + 3]) / 2 for k in range(3)]
            half = [(b0[k + 3] - b0[k]) / 2 for k in range(3)]
            ray = [centre[0] - half[0], centre[1] - half[1] * 0.3, centre[2] + half[2] * 0.2, 1.0, 0.3, -0.2]
            claims = [(["--box=" + box, "--lipschitz", repr(b["L"] * 1.02)], "L")]
            g = json.loads(run(lgc, "bounds", s["expr"], "--box=" + box, "--ray=" + ",".join(map(repr, ray)), "--t=0," + repr(2 * half[0]), "--tolerance", "0.01", "--json").stdout).get("G")
            if g is not None:
                claims.append((["--ray=" + ",".join(map(repr, ray)), "--t=0," + repr(2 * half[0]), "--grad-lipschitz", repr(g * 1.02)], "G"))
            claims.append((["--box=" + box, "--lipschitz", repr(b["L_lower"] * 0.9)], "L refuted"))
            proofs += check_claims(lgc, tmp, name, s["expr"], claims, failures)
    return proofs, failures


def check_claims(lgc, tmp, name, expr, claims, failures):
    """Writes each claim's proof with `lgc verify --proof`, checks it and its
    altered copies; returns how many were checked."""
    proofs = 0
    for args, what in claims:
        path = os.path.join(tmp, "p.json")
        out = run(lgc, "verify", expr, *args, "--proof", path)
        if not os.path.exists(path):
            failures.append(f"{name} {what}: no proof written: {out.stderr.strip()}")
            continue
        proof = json.load(open(path))
        os.remove(path)
        try:
            shown = check(proof)
        except Rejected as e:
            failures.append(f"{name} {what}: rejected: {e}")
            continue
        proofs += 1
        failures += [f"{name} {what}: {m}" for m in alterations(proof, shown)]
        print(f"{name:14} {what:10} {shown['verdict']:8} {shown.get('leaves', '')}")
    return proofs


def alterations(proof, shown):
    """Every alteration below makes the proof wrong; each must be rejected."""
    missed = []
    if proof["verdict"] == "refuted":
        w = dict(proof["witness"])
        w["at_least"] = float(shown["value"])
        while w["at_least"] <= shown["value"]:
            w["at_least"] = math.nextafter(w["at_least"], INF)
        if not rejected({**proof, "witness": w}):
            missed.append("at_least above the certified value was accepted")
        return missed
    tree = proof["tree"]
    leaves = [k for k, e in enumerate(tree) if not isinstance(e, list)]
    splits = [k for k, e in enumerate(tree) if isinstance(e, list)]
    # Leaves lowered below what the natural extension shows.
    t, roots = quantity(proof)
    for k in leaves[:: max(1, len(leaves) // 8)]:
        region = region_of(proof, k)
        u = upper(t, roots, region)
        altered = list(tree)
        altered[k] = float(u)
        while altered[k] >= u:
            altered[k] = math.nextafter(altered[k], -INF)
        if not rejected({**proof, "tree": altered}):
            missed.append(f"leaf {k} lowered below its bound was accepted")
    for k in splits[:: max(1, len(splits) // 8)]:
        axis, at = tree[k]
        for moved in (math.nextafter(at, INF), math.nextafter(at, -INF)):
            altered = list(tree)
            altered[k] = [axis, moved]
            if not rejected({**proof, "tree": altered}):
                missed.append(f"split {k} moved by one ulp was accepted")
    if not rejected({**proof, "tree": tree[:-1]}):
        missed.append("a tree missing its last leaf was accepted")
    steeper = {**proof, "formula": "(" + proof["formula"] + ")*1.000001"}
    if "let" not in proof["formula"] and not rejected(steeper):
        missed.append("the formula scaled by 1.000001 was accepted")
    return missed


def region_of(proof, target):
    """The region of tree entry `target`."""
    claim = proof["claim"]
    b = claim.get("box")
    root = [(b[0], b[3]), (b[1], b[4]), (b[2], b[5])] if b else [tuple(claim["t"])]
    stack = [root]
    for k, e in enumerate(proof["tree"]):
        region = stack.pop()
        if k == target:
            return region
        if isinstance(e, list):
            axis, at = e
            low, high = list(region), list(region)
            low[axis], high[axis] = (region[axis][0], at), (at, region[axis][1])
            stack += [high, low]
    raise IndexError(target)


def main():
    if len(sys.argv) == 3 and sys.argv[1] == "--lgc":
        proofs, failures = corpus(sys.argv[2])
        for f in failures:
            print("FAIL", f)
        print(f"{proofs} proofs checked, {len(failures)} failures")
        sys.exit(1 if failures or proofs == 0 else 0)
    bad = 0
    for path in sys.argv[1:]:
        try:
            shown = check(json.load(open(path)))
            print(f"{path}: valid, {shown['verdict']}")
        except (Rejected, SyntaxError, KeyError, ValueError) as e:
            print(f"{path}: rejected: {e}")
            bad += 1
    sys.exit(1 if bad or len(sys.argv) < 2 else 0)


if __name__ == "__main__":
    main()
