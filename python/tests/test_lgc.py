"""The Python module against the command line (bit for bit), finite
differences, and bad input. Run with pytest after `pip install ./python`;
LGC_BIN names the `lgc` binary (default: the repository's release build)."""

import json
import math
import os
import subprocess
import pathlib

import numpy as np
import pytest

import lgc

ROOT = pathlib.Path(__file__).resolve().parents[2]
LGC = os.environ.get("LGC_BIN", str(ROOT / "target" / "release" / "lgc"))
SURFACES = json.loads((ROOT / "examples" / "surfaces.json").read_text())
BEAR = ROOT / "examples" / "models" / "bear.vm"


def cli(*args, stdin=None):
    out = subprocess.run([LGC, *args], input=stdin, capture_output=True, text=True, check=True)
    return out.stdout


def sample(box, n, seed):
    rng = np.random.default_rng(seed)
    lo, hi = np.array(box[:3], float), np.array(box[3:], float)
    return lo + (hi - lo) * rng.random((n, 3))


@pytest.mark.parametrize("name", sorted(SURFACES))
def test_eval_and_grad_are_the_clis_bit_for_bit(name):
    s = SURFACES[name]
    f = lgc.Formula(s["expr"])
    points = sample(s["box"], 12, seed=len(name))
    values, gradients = f.eval(points), f.grad(points)
    for p, v, g in zip(points, values, gradients):
        at = ",".join(repr(float(x)) for x in p)
        expected = json.loads(cli("eval", s["expr"], "--at", at, "--json"))
        assert np.float64(expected["f"]).tobytes() == v.tobytes(), (name, p)
        assert np.array(expected["grad"], float).tobytes() == g.tobytes(), (name, p)


@pytest.mark.parametrize("name", sorted(SURFACES))
def test_gradient_prints_what_lgc_grad_prints(name):
    expr = SURFACES[name]["expr"]
    expected = json.loads(cli("grad", expr, "--json"))["grad"]
    assert list(lgc.Formula(expr).gradient()) == expected


def test_grad_matches_finite_differences_and_gradient_parses_back():
    f = lgc.Formula("sin(x*y) + exp(z)*x^3 - sqrt(1 + y^2)")
    p = sample([-1, -1, -1, 1, 1, 1], 50, seed=3)
    h = 1e-6
    for axis in range(3):
        step = np.zeros(3)
        step[axis] = h
        central = (f.eval(p + step) - f.eval(p - step)) / (2 * h)
        assert np.allclose(f.grad(p)[:, axis], central, rtol=1e-6, atol=1e-6)
        # The printed derivative is a formula with the same values.
        derivative = lgc.Formula(f.gradient()[axis])
        assert np.allclose(derivative.eval(p), f.grad(p)[:, axis], rtol=1e-12, atol=1e-12)


def test_trace_answers_are_lgc_traces():
    expr = SURFACES["torus"]["expr"]
    box = SURFACES["torus"]["box"]
    rng = np.random.default_rng(5)
    origins = rng.normal(size=(200, 3)) * 3
    directions = rng.random((200, 3)) * 2 - 1 - origins * 0.2
    kind, t = lgc.Formula(expr).trace(origins, directions, box=box)
    text = "".join(" ".join(repr(float(x)) for x in (*o, *d)) + "\n" for o, d in zip(origins, directions))
    lines = cli("trace", expr, "--box=" + ",".join(map(str, box)), stdin=text).splitlines()
    assert len(lines) == len(kind) == len(t)
    assert {"hit", "none"} <= set(kind)
    for line, k, s in zip(lines, kind, t):
        if line == "none":
            assert k == "none" and math.isnan(s)
        else:
            words = line.split()
            assert k == (words[0] if len(words) == 2 else "hit")
            assert float(words[-1]) == s


def test_a_hit_is_a_root_and_threads_give_the_same_answers():
    f = lgc.Formula("x^2+y^2+z^2-1")
    origins = np.tile([-3.0, 0.0, 0.0], (64, 1))
    directions = np.column_stack([np.ones(64), np.linspace(-0.3, 0.3, 64), np.zeros(64)])
    kind, t = f.trace(origins, directions, box=[-2, -2, -2, 2, 2, 2], threads=1)
    kind2, t2 = f.trace(origins, directions, box=(-2, -2, -2, 2, 2, 2), threads=2)
    assert (kind == kind2).all() and np.array_equal(t, t2, equal_nan=True)
    hits = kind == "hit"
    assert hits.all()
    points = origins[hits] + t[hits, None] * directions[hits]
    assert np.allclose(f.eval(points), 0.0, atol=1e-9)


def test_models_and_formula_files_are_read():
    bear = lgc.Formula.from_file(BEAR)
    p = sample([-1, -1, -1, 1, 1, 1], 5, seed=9)
    expected = [json.loads(cli("eval", str(BEAR), "--at", ",".join(map(repr, map(float, q))), "--json"))["f"] for q in p]
    assert bear.eval(p).tobytes() == np.array(expected, float).tobytes()
    with pytest.raises(OSError, match="cannot read"):
        lgc.Formula.from_file(ROOT / "no such file.vm")


def test_a_bad_formula_raises_formula_error_with_the_caret():
    with pytest.raises(lgc.FormulaError) as caught:
        lgc.Formula("x^2 +\n  y*)")
    e = caught.value
    assert isinstance(e, ValueError)
    assert (e.line, e.column) == (2, 5)
    # The CLI's message, caret and all.
    out = subprocess.run([LGC, "eval", "x^2 +\n  y*)", "--at", "0,0,0"], capture_output=True, text=True)
    assert out.returncode != 0 and out.stdout == ""
    assert str(e).strip() == out.stderr.strip()
    assert "^ no `(` is open here" in str(e)
    with pytest.raises(lgc.FormulaError, match="expected") as caught:
        lgc.Formula("x^2+*y")
    assert (caught.value.line, caught.value.column) == (1, 5)


def test_arrays_are_converted_or_refused_clearly():
    f = lgc.Formula("x + 2*y + 3*z")
    ints = np.arange(12).reshape(4, 3)
    assert f.eval(ints).tolist() == [8.0, 26.0, 44.0, 62.0]
    assert f.eval([[1, 1, 1]]).tolist() == [6.0]
    strided = np.arange(24.0).reshape(4, 6)[:, ::2]
    assert not strided.flags["C_CONTIGUOUS"]
    assert f.eval(strided).tolist() == f.eval(np.ascontiguousarray(strided)).tolist()
    assert f.eval(np.zeros((0, 3))).shape == (0,)
    for bad in (np.zeros((3, 2)), np.zeros(3), np.zeros((2, 3, 1))):
        with pytest.raises(ValueError, match=r"shape \(N, 3\)"):
            f.eval(bad)
    with pytest.raises(TypeError, match="array of numbers"):
        f.grad([["a", "b", "c"]])
    with pytest.raises(ValueError, match="threads"):
        f.eval(ints, threads=0)


def test_bad_rays_and_boxes_are_refused_clearly():
    f = lgc.Formula("x^2+y^2+z^2-1")
    o, d = np.zeros((2, 3)), np.ones((2, 3))
    with pytest.raises(ValueError, match="one direction per origin"):
        f.trace(o, np.ones((3, 3)))
    with pytest.raises(ValueError, match=r"\(0, 0, 0\)"):
        f.trace(o, np.zeros((2, 3)))
    with pytest.raises(ValueError, match="six numbers"):
        f.trace(o, d, box=[0, 0, 0, 1, 1])
    with pytest.raises(ValueError, match="not a box"):
        f.trace(o, d, box=[1, 1, 1, 0, 0, 0])
    with pytest.raises(TypeError, match="six numbers"):
        f.trace(o, d, box="cube")
    with pytest.raises(ValueError, match="too deep"):
        f.trace(o, d, depth=99)


def verify_cli(expr, *args):
    out = subprocess.run([LGC, "verify", expr, *args, "--json"], capture_output=True, text=True)
    assert out.returncode in (0, 3, 4), out.stderr
    return json.loads(out.stdout)


@pytest.mark.parametrize(
    "claim, cli_args, kwargs",
    [
        (3.4, ["--box", "-1,-1,-1,1,1,1", "--lipschitz", "3.4"], {"box": [-1, -1, -1, 1, 1, 1], "lipschitz": 3.4}),
        ("2*sqrt(3)*1.0001", ["--box", "-1,-1,-1,1,1,1", "--lipschitz", "2*sqrt(3)*1.0001"], {"box": [-1, -1, -1, 1, 1, 1], "lipschitz": "2*sqrt(3)*1.0001"}),
        ("2*sqrt(3)", ["--box", "-1,-1,-1,1,1,1", "--lipschitz", "2*sqrt(3)", "--max-boxes", "50"], {"box": [-1, -1, -1, 1, 1, 1], "lipschitz": "2*sqrt(3)", "max_boxes": 50}),
        (18, ["--ray", "0,0,0,1,2,2", "--t", "-5,5", "--grad-lipschitz", "18"], {"ray": [0, 0, 0, 1, 2, 2], "t": (-5, 5), "grad_lipschitz": 18}),
        (17.9, ["--ray", "0,0,0,1,2,2", "--t", "-5,5", "--grad-lipschitz", "17.9"], {"ray": [0, 0, 0, 1, 2, 2], "t": (-5, 5), "grad_lipschitz": 17.9}),
    ],
)
def test_verify_is_lgc_verify(claim, cli_args, kwargs):
    expr = "x^2+y^2+z^2-1"
    expected = verify_cli(expr, *cli_args)
    got = lgc.Formula(expr).verify(**kwargs)
    assert got["status"] == expected["verdict"]
    for key in ("pieces", "witness", "value", "t", "worst", "bound"):
        if key in expected:
            assert np.array(got[key], float).tobytes() == np.array(expected[key], float).tobytes(), key
    assert set(got) - {"status"} == set(expected) - {"verdict"}


def test_a_refutation_is_a_true_witness():
    f = lgc.Formula("x^2+y^2+z^2-1")
    r = f.verify([-1, -1, -1, 1, 1, 1], lipschitz=3.4)
    assert r["status"] == "refuted" and r["value"] > 3.4
    witness = np.array([r["witness"]])
    assert np.linalg.norm(f.grad(witness)) >= r["value"] * (1 - 1e-15)
    assert f.verify([-1, -1, -1, 1, 1, 1], lipschitz=3.5)["status"] == "proved"


def test_bad_claims_are_refused_clearly():
    f = lgc.Formula("x^2+y^2+z^2-1")
    box = [-1, -1, -1, 1, 1, 1]
    with pytest.raises(ValueError, match="may not depend on x, y or z"):
        f.verify(box, lipschitz="x+1")
    with pytest.raises(ValueError, match="not a finite number"):
        f.verify(box, lipschitz="1/0")
    with pytest.raises(lgc.FormulaError) as caught:
        f.verify(box, lipschitz="2*")
    assert caught.value.column == 3
    with pytest.raises(TypeError, match="number or a constant expression"):
        f.verify(box, lipschitz=[1])
    with pytest.raises(ValueError, match="one claim"):
        f.verify(box)
    with pytest.raises(ValueError, match="needs box"):
        f.verify(lipschitz=2.0)
    with pytest.raises(ValueError, match="needs ray"):
        f.verify(grad_lipschitz=2.0)
    with pytest.raises(ValueError, match="too large"):
        f.verify([-1e308, -1, -1, 1e308, 1, 1], lipschitz=2.0)


def test_every_function_has_a_docstring_and_the_stubs_are_installed():
    for name in ("eval", "grad", "gradient", "trace", "verify", "bounds", "bracket", "from_file"):
        assert getattr(lgc.Formula, name).__doc__, name
    assert lgc.Formula.__doc__ and lgc.FormulaError.__doc__ and lgc.render.__doc__
    stubs = pathlib.Path(lgc.__file__).with_suffix(".pyi")
    assert stubs.exists(), stubs
    for name in ("def eval", "def grad", "def gradient", "def trace", "def verify", "def bounds", "def bracket", "def render", "class FormulaError"):
        assert name in stubs.read_text(), name


@pytest.mark.parametrize("name", sorted(SURFACES))
def test_bounds_are_lgc_bounds(name):
    s = SURFACES[name]
    box = ",".join(map(repr, map(float, s["box"])))
    for split in (0, 1):
        expected = json.loads(cli("bounds", s["expr"], "--box", box, "--split", str(split), "--json"))
        got = lgc.Formula(s["expr"]).bounds(s["box"], split=split)
        assert got == expected, (name, split)


def test_bounds_along_a_ray_and_by_method_are_lgc_bounds():
    expr = "x^2+y^2+z^2-1"
    args = ["--box", "-1,-1,-1,1,1,1", "--ray", "0,0,0,1,2,2", "--t", "-5,5"]
    for method in ("natural", "centred", "bernstein", "affine", "best"):
        expected = json.loads(cli("bounds", expr, *args, "--method", method, "--json"))
        got = lgc.Formula(expr).bounds([-1, -1, -1, 1, 1, 1], method=method, ray=[0, 0, 0, 1, 2, 2], t=[-5, 5])
        assert got == expected, method
        assert {"G", "G_sampled", "G_t", "G_point"} <= set(got)


def test_brackets_are_lgc_brackets_and_enclose_the_maximum():
    expr = SURFACES["torus"]["expr"]
    box = SURFACES["torus"]["box"]
    expected = json.loads(cli("bounds", expr, "--box", ",".join(map(str, box)), "--tolerance", "0.01", "--json"))
    got = lgc.Formula(expr).bracket(box, tolerance=0.01)
    assert got == expected
    assert got["L_reached"] and got["L_lower"] <= got["L"] <= got["L_lower"] * 1.01
    # The certified lower end holds at its point.
    at = np.linalg.norm(lgc.Formula(expr).grad(np.array([got["L_point"]]))[0])
    assert at >= got["L_lower"] * (1 - 1e-12)


def test_an_unbounded_constant_is_none_with_its_reason():
    got = lgc.Formula("sqrt(abs(x))+y").bounds([-1, -1, -1, 1, 1, 1])
    # sqrt at 0 has no finite slope: neither the gradient nor the slopes bound it.
    assert got["L"] is None and "L_note" in got and "L_ratio" not in got


def test_a_balls_centre_takes_its_bound_from_slopes():
    got = lgc.Formula("sqrt(x^2+y^2+z^2)-0.5").bounds([-1, -1, -1, 1, 1, 1])
    # |grad| of the distance is 1 but undefined at the centre, where the
    # interval gradient has no bound; the slopes of f's operations do.
    assert 1 <= got["L"] <= 2 and "slopes" in got["L_note"]


def test_bad_bounds_arguments_are_refused_clearly():
    f = lgc.Formula("sin(x)+y")
    box = [-1, -1, -1, 1, 1, 1]
    with pytest.raises(ValueError, match="method"):
        f.bounds(box, method="ellipsoid")
    with pytest.raises(ValueError, match="polynomial"):
        f.bounds(box, method="bernstein")
    with pytest.raises(ValueError, match="split"):
        f.bounds(box, split=7)
    with pytest.raises(ValueError, match="both ray"):
        f.bounds(box, ray=[0, 0, 0, 1, 0, 0])
    with pytest.raises(ValueError, match="tolerance"):
        f.bracket(box, tolerance=0.0)
    with pytest.raises(ValueError, match="not a segment"):
        f.bounds(box, ray=[0, 0, 0, 1, 0, 0], t=[1, 0])


def test_ctrl_c_interrupts_a_long_call_at_once():
    import signal
    import threading
    import time

    # A claim equal to the irrational maximum: the search runs out its
    # piece budget (several seconds) unless interrupted.
    f = lgc.Formula("x^4+y^4+z^4-1")
    # A process started in the background may inherit SIGINT ignored, and
    # then Python installs no handler: install the one a terminal gets.
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        timer = threading.Timer(0.3, lambda: os.kill(os.getpid(), signal.SIGINT))
        start = time.perf_counter()
        timer.start()
        with pytest.raises(KeyboardInterrupt):
            f.verify([-1, -1, -1, 1, 1, 1], lipschitz="4*sqrt(3)", max_boxes=100_000)
        assert time.perf_counter() - start < 3.0
    finally:
        signal.signal(signal.SIGINT, previous)
    # The module still answers afterwards.
    assert f.verify([-1, -1, -1, 1, 1, 1], lipschitz=6.93)["status"] == "proved"


def read_ppm(path):
    """A binary PPM as `lgc render -o x.ppm` writes it: (H, W, 3) uint8."""
    data = pathlib.Path(path).read_bytes()
    fields, at = [], 0
    while len(fields) < 4:  # magic, width, height, maxval
        while data[at : at + 1].isspace():
            at += 1
        end = at
        while not data[end : end + 1].isspace():
            end += 1
        fields.append(data[at:end])
        at = end
    assert fields[0] == b"P6" and fields[3] == b"255"
    width, height = int(fields[1]), int(fields[2])
    # One whitespace byte ends the header; the pixels follow.
    return np.frombuffer(data[at + 1 :], np.uint8).reshape(height, width, 3)


@pytest.mark.parametrize(
    "source, cli_args, kwargs",
    [
        ("x^2+y^2+z^2-1", [], {}),
        (
            SURFACES["torus"]["expr"],
            ["--box=-1.5,-1.5,-0.5,1.5,1.5,0.5", "--color", "0.2,0.5,0.9", "--eye=3,-2,2", "--fov", "40", "--no-shadows"],
            {"box": [-1.5, -1.5, -0.5, 1.5, 1.5, 0.5], "color": (0.2, 0.5, 0.9), "eye": (3, -2, 2), "fov": 40, "no_shadows": True},
        ),
        (SURFACES["tangle_cube"]["expr"], ["--depth", "6", "--samples", "2", "--up=0,1,0"], {"depth": 6, "samples": 2, "up": [0, 1, 0]}),
        (str(ROOT / "examples" / "glass.lgc"), ["--max-depth", "2"], {"max_depth": 2}),
        (ROOT / "examples" / "csg_part.lgc", ["--look-at=0,0,0.2", "--min-weight", "0.01"], {"look_at": (0, 0, 0.2), "min_weight": 0.01}),
    ],
)
def test_render_gives_the_pixels_lgc_render_writes(tmp_path, source, cli_args, kwargs):
    import warnings

    out = tmp_path / "expected.ppm"
    ran = subprocess.run([LGC, "render", str(source), "--size", "96x64", "-o", str(out), *cli_args], capture_output=True, text=True, check=True)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        image = lgc.render(source, size=(96, 64), threads=2, **kwargs)
    # The same warnings as the command line's.
    clipped = any("clipped" in str(w.message) for w in caught)
    assert clipped == ("may be clipped" in ran.stderr), (ran.stderr, [str(w.message) for w in caught])
    assert image.shape == (64, 96, 3) and image.dtype == np.uint8
    assert np.array_equal(image, read_ppm(out))
    # The picture shows something: not one flat colour.
    assert len(np.unique(image.reshape(-1, 3), axis=0)) > 10


def test_render_takes_a_formula_object_and_a_vm_model():
    f = lgc.Formula(SURFACES["torus"]["expr"])
    assert np.array_equal(lgc.render(f, size=(40, 30)), lgc.render(SURFACES["torus"]["expr"], size=(40, 30)))
    bear = lgc.render(BEAR, size=(32, 24), depth=4)
    assert bear.shape == (24, 32, 3)


def test_bad_render_arguments_are_refused_clearly(tmp_path):
    sphere = "x^2+y^2+z^2-1"
    with pytest.raises(ValueError, match="between 1 and 16384"):
        lgc.render(sphere, size=(0, 10))
    with pytest.raises(ValueError, match="between 1 and 16384"):
        lgc.render(sphere, size=(20000, 10))
    with pytest.raises(TypeError, match="two whole numbers"):
        lgc.render(sphere, size="320x240")
    with pytest.raises(ValueError, match="samples=0"):
        lgc.render(sphere, size=(8, 8), samples=0)
    with pytest.raises(ValueError, match="flat"):
        lgc.render(sphere, size=(8, 8), box=[-1, -1, 0, 1, 1, 0])
    with pytest.raises(ValueError, match="between 0 and 1"):
        lgc.render(sphere, size=(8, 8), color=(1.5, 0, 0))
    with pytest.raises(ValueError, match="up vector cannot be"):
        lgc.render(sphere, size=(8, 8), up=(0, 0, 0))
    with pytest.raises(ValueError, match="finite"):
        lgc.render(sphere, size=(8, 8), eye=(float("nan"), 0, 0))
    with pytest.raises(ValueError, match="cannot place the camera"):
        lgc.render(sphere, size=(8, 8), eye=(0, 0, 0), look_at=(0, 0, 0))
    with pytest.raises(ValueError, match="too deep"):
        lgc.render(sphere, size=(8, 8), depth=11)
    with pytest.raises(ValueError, match="max_depth applies to scenes"):
        lgc.render(sphere, size=(8, 8), max_depth=2)
    with pytest.raises(ValueError, match="box applies to formulas"):
        lgc.render(ROOT / "examples" / "glass.lgc", size=(8, 8), box=[-1, -1, -1, 1, 1, 1])
    with pytest.raises(TypeError, match="source must be"):
        lgc.render(42)
    with pytest.raises(OSError, match="cannot read"):
        lgc.render("no_such_scene.lgc")
    with pytest.raises(lgc.FormulaError) as bad:
        lgc.render("x^2+*y", size=(8, 8))
    assert bad.value.column == 5
    # A scene whose own camera cannot be placed: the caret is in the file.
    scene = tmp_path / "bad.lgc"
    scene.write_text("camera { eye = (0, 0, 5); look_at = (0, 0, 0); }\nsphere { center = (0, 0, 0); radius = 1; }\n")
    with pytest.raises(lgc.FormulaError, match="cannot place the camera") as bad:
        lgc.render(scene, size=(8, 8))
    assert bad.value.line == 1
    # The same scene renders once the caller sets `up` across the view.
    assert lgc.render(scene, size=(8, 8), up=(0, 1, 0)).shape == (8, 8, 3)


def test_verify_writes_the_proof_file_lgc_verify_writes(tmp_path):
    tangle = SURFACES["tangle_cube"]
    box = tangle["box"]
    mine, theirs = tmp_path / "python.json", tmp_path / "cli.json"
    f = lgc.Formula(tangle["expr"])
    for claim, kwargs, args in [
        ("140", {"lipschitz": "140"}, ["--box=" + ",".join(map(str, box)), "--lipschitz", "140"]),
        ("100", {"lipschitz": 100.0}, ["--box=" + ",".join(map(str, box)), "--lipschitz", "100.0"]),
        ("200", {"grad_lipschitz": 200.0, "ray": [-3, 0.1, 0.2, 1, 0.1, 0], "t": [0, 6]},
         ["--ray=-3,0.1,0.2,1,0.1,0", "--t=0,6", "--grad-lipschitz", "200.0"]),
    ]:
        answer = f.verify(box, proof=mine, **kwargs)
        assert answer["proof"] == str(mine), claim
        subprocess.run([LGC, "verify", tangle["expr"], *args, "--proof", str(theirs)], capture_output=True)
        assert mine.read_bytes() == theirs.read_bytes(), claim
        checked = json.loads(cli("check-proof", str(mine), "--json"))
        assert checked["valid"] and checked["verdict"] == answer["status"], claim
    # No file for an undecided claim, or for a .vm model.
    undecided = tmp_path / "undecided.json"
    with pytest.raises(ValueError, match="no proof written: the claim is undecided"):
        lgc.Formula("x^2+y^2+z^2-1").verify([-1, -1, -1, 1, 1, 1], lipschitz="2*sqrt(3)", max_boxes=100, proof=undecided)
    assert not undecided.exists()
    with pytest.raises(ValueError, match=".vm model"):
        lgc.Formula.from_file(BEAR).verify([-1, -1, -1, 1, 1, 1], lipschitz=1e9, proof=undecided)
    # A function the checker does not read is located in the formula.
    with pytest.raises(lgc.FormulaError) as bad:
        lgc.Formula("translate(x^2+y^2+z^2-1, 0.1, 0, 0)").verify([-1, -1, -1, 1, 1, 1], lipschitz=5, proof=undecided)
    assert bad.value.column == 1
    assert not undecided.exists()


def test_render_warns_when_nothing_is_seen_or_the_surface_is_clipped():
    import warnings

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        lgc.render("x^2+y^2+z^2+1", size=(16, 12))  # f > 0: no surface at all
        lgc.render("x^2+y^2+z^2-1", size=(16, 12), box=[-0.8, -0.8, -0.8, 0.8, 0.8, 0.8])
        lgc.render("x^2+y^2+z^2-1", size=(16, 12))
    messages = [str(w.message) for w in caught]
    assert any("nothing to see" in m for m in messages), messages
    assert any("clipped" in m for m in messages), messages
    assert len(messages) == 2, messages  # the last one is silent
