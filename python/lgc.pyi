"""lgc: implicit surfaces f(x, y, z) = 0, their derivatives, bounds and
certified ray intersections, over numpy arrays."""

from os import PathLike
from typing import Any, Dict, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str

ArrayLike = npt.ArrayLike

class FormulaError(ValueError):
    """A formula that does not parse. The message shows the source with a
    caret under the error and says what was expected."""

    line: int
    """The 1-based line where the error starts."""
    column: int
    """The 1-based column (in characters) where the error starts."""

class Formula:
    """A formula f(x, y, z), parsed, simplified and differentiated."""

    def __init__(self, text: str) -> None:
        """Parses a formula in lgc's language, such as "x^2+y^2+z^2-1".
        Raises FormulaError when it does not parse."""
    @staticmethod
    def from_file(path: Union[str, "PathLike[str]"]) -> "Formula":
        """Reads a formula from a file: a .vm model (fidget's format) or a
        formula in lgc's language."""
    @property
    def source(self) -> str:
        """The formula's text as given."""
    def eval(self, p: ArrayLike, *, threads: Optional[int] = None) -> npt.NDArray[np.float64]:
        """f at each point: p of shape (N, 3) to an array of shape (N,).
        Any array numpy converts to float64 is accepted, contiguous or not.
        The values are `lgc eval`'s, bit for bit."""
    def grad(self, p: ArrayLike, *, threads: Optional[int] = None) -> npt.NDArray[np.float64]:
        """The gradient of f at each point: (N, 3) to (N, 3), `lgc eval`'s
        values bit for bit."""
    def gradient(self) -> Tuple[str, str, str]:
        """The three partial derivatives, simplified, as formulas that parse
        back (what `lgc grad` prints)."""
    def trace(
        self,
        origins: ArrayLike,
        directions: ArrayLike,
        *,
        box: Optional[Sequence[float]] = None,
        depth: int = 5,
        threads: Optional[int] = None,
    ) -> Tuple[npt.NDArray[np.str_], npt.NDArray[np.float64]]:
        """The first surface hit of each ray origins[i] + t * directions[i],
        t >= 0, inside box (x0, y0, z0, x1, y1, z1; default the cube of
        half-side 2). Returns (kind, t): kind is "hit" (a proved sign
        change), "touch" (f's enclosure holds 0 within the tolerance),
        "none" (proved to miss) or "undecided"; t is in units of the
        direction's length, NaN for "none". `lgc trace`'s answers."""
    def verify(
        self,
        box: Optional[Sequence[float]] = None,
        lipschitz: Union[float, str, None] = None,
        *,
        grad_lipschitz: Union[float, str, None] = None,
        ray: Optional[Sequence[float]] = None,
        t: Optional[Sequence[float]] = None,
        max_boxes: int = 1_000_000,
        threads: Optional[int] = None,
        proof: Union[str, "PathLike[str]", None] = None,
    ) -> Dict[str, Any]:
        """Proves or refutes a claimed bound, as `lgc verify --json`:
        lipschitz=C claims |grad f| <= C over box; grad_lipschitz=C claims
        |g'| <= C along ray (origin, direction) for t in (t0, t1). C is a
        number or a constant expression such as "2*sqrt(3)". The dict has
        "status" ("proved", "refuted" or "undecided"), "claim" and
        "pieces"; a refutation adds "witness" (x, y, z) and "value", a
        certified lower bound of the quantity there (and "t" on a ray); an
        undecided claim adds the "worst" piece and its "bound". With
        proof=PATH it writes the proof file `lgc verify --proof` writes,
        which `lgc check-proof` re-checks, and adds "proof": its path; an
        undecided claim then raises ValueError."""
    def bounds(
        self,
        box: Sequence[float],
        split: int = 0,
        method: str = "best",
        *,
        ray: Optional[Sequence[float]] = None,
        t: Optional[Sequence[float]] = None,
        threads: Optional[int] = None,
    ) -> Dict[str, Any]:
        """f's enclosure over box ("f": [lo, hi]), L (a sound bound of
        |grad f| there) beside a sampled maximum ("L_sampled", "L_ratio",
        "L_point"), and with ray and t, G (a bound of |g'| along the
        segment) likewise: the keys of `lgc bounds --json`. split=n bounds
        8^n sub-boxes (2^n sub-segments); method is "natural", "centred",
        "bernstein", "taylor", "affine" or "best". An infinite bound is None, with its
        reason in "L_note" or "G_note"."""
    def bracket(
        self,
        box: Sequence[float],
        tolerance: float = 0.01,
        method: str = "best",
        *,
        ray: Optional[Sequence[float]] = None,
        t: Optional[Sequence[float]] = None,
        max_boxes: int = 1_000_000,
        threads: Optional[int] = None,
    ) -> Dict[str, Any]:
        """A certified bracket of the true maximum of |grad f| over box (and
        of |g'| along the ray): "L_lower" <= max <= "L", certified at
        "L_point", "L_reached" when L <= L_lower * (1 + tolerance), and
        "pieces": the keys of `lgc bounds --tolerance --json`."""


def render(
    source: Union[Formula, str, "PathLike[str]"],
    size: Tuple[int, int] = (1024, 768),
    *,
    box: Optional[Sequence[float]] = None,
    depth: int = 5,
    color: Optional[Sequence[float]] = None,
    eye: Optional[Sequence[float]] = None,
    look_at: Optional[Sequence[float]] = None,
    up: Optional[Sequence[float]] = None,
    fov: Optional[float] = None,
    max_depth: Optional[int] = None,
    min_weight: Optional[float] = None,
    samples: int = 1,
    threads: Optional[int] = None,
    no_shadows: bool = False,
) -> "np.ndarray[Any, np.dtype[np.uint8]]":
    """Renders a formula, a Formula or a scene file into an image of shape
    (height, width, 3), 8-bit sRGB: the pixels `lgc render` writes.

    source is a Formula, formula text (or a scene's, with { ... } blocks), or
    a file: a PathLike, or a str ending in .lgc or .vm. The keywords are the
    CLI's options: box (default -2..2 on each axis) and color for formulas;
    max_depth (default 5) and min_weight (default 1/1024) for scenes; eye,
    look_at, up and fov (default 30 degrees) override a scene's camera and
    the default three-quarter view. Raises FormulaError for a source that
    does not parse, or a scene camera that cannot be placed (located in the
    file), ValueError for other bad values."""
