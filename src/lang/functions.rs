//! The built-in functions and constants of the formula language.
//!
//! One table serves the lowering, the "did you mean" suggestions, `lgc --help`
//! and `docs/language.md`.

/// How many arguments a function takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Arity {
    /// Exactly this many.
    Exactly(usize),
    /// This many or more.
    AtLeast(usize),
}

impl Arity {
    /// True when `n` arguments are accepted.
    pub fn accepts(self, n: usize) -> bool {
        match self {
            Arity::Exactly(k) => n == k,
            Arity::AtLeast(k) => n >= k,
        }
    }

    /// "1 argument", "2 or more arguments", …
    pub fn describe(self) -> String {
        let plural = |k: usize| if k == 1 { "argument" } else { "arguments" };
        match self {
            Arity::Exactly(k) => format!("{k} {}", plural(k)),
            Arity::AtLeast(k) => format!("{k} or more arguments"),
        }
    }
}

/// A built-in function: its name, arity and documented domain.
#[derive(Debug, Clone, Copy)]
pub struct Function {
    /// Name as written in formulas.
    pub name: &'static str,
    /// Accepted argument counts.
    pub arity: Arity,
    /// Usage, as in `atan2(y, x)`.
    pub usage: &'static str,
    /// Meaning and domain.
    pub doc: &'static str,
}

/// Every built-in function, in the order the help text lists them.
pub const FUNCTIONS: &[Function] = &[
    Function { name: "sqrt", arity: Arity::Exactly(1), usage: "sqrt(u)", doc: "square root; domain u >= 0 (its slope is unbounded at 0)" },
    Function { name: "abs", arity: Arity::Exactly(1), usage: "abs(u)", doc: "|u|; all reals; derivative sign(u)" },
    Function { name: "sin", arity: Arity::Exactly(1), usage: "sin(u)", doc: "sine (radians); all reals" },
    Function { name: "cos", arity: Arity::Exactly(1), usage: "cos(u)", doc: "cosine (radians); all reals" },
    Function { name: "tan", arity: Arity::Exactly(1), usage: "tan(u)", doc: "tangent; all reals except the poles pi/2 + k*pi" },
    Function { name: "asin", arity: Arity::Exactly(1), usage: "asin(u)", doc: "arcsine; domain -1 <= u <= 1" },
    Function { name: "acos", arity: Arity::Exactly(1), usage: "acos(u)", doc: "arccosine; domain -1 <= u <= 1" },
    Function { name: "atan", arity: Arity::Exactly(1), usage: "atan(u)", doc: "arctangent; all reals" },
    Function { name: "atan2", arity: Arity::Exactly(2), usage: "atan2(y, x)", doc: "angle of the point (x, y) in (-pi, pi]; all points but the origin" },
    Function { name: "exp", arity: Arity::Exactly(1), usage: "exp(u)", doc: "e^u; all reals" },
    Function { name: "ln", arity: Arity::Exactly(1), usage: "ln(u)", doc: "natural logarithm; domain u > 0" },
    Function { name: "log", arity: Arity::Exactly(1), usage: "log(u)", doc: "base-10 logarithm, ln(u)/ln(10); domain u > 0" },
    Function { name: "sinh", arity: Arity::Exactly(1), usage: "sinh(u)", doc: "hyperbolic sine; all reals" },
    Function { name: "cosh", arity: Arity::Exactly(1), usage: "cosh(u)", doc: "hyperbolic cosine; all reals" },
    Function { name: "tanh", arity: Arity::Exactly(1), usage: "tanh(u)", doc: "hyperbolic tangent; all reals" },
    Function { name: "sech", arity: Arity::Exactly(1), usage: "sech(u)", doc: "hyperbolic secant 1/cosh(u), without overflow; all reals" },
    Function { name: "min", arity: Arity::AtLeast(2), usage: "min(a, b, ...)", doc: "smallest argument; derivative choose(a-b, a', b')" },
    Function { name: "max", arity: Arity::AtLeast(2), usage: "max(a, b, ...)", doc: "largest argument; derivative choose(a-b, b', a')" },
    Function { name: "pow", arity: Arity::Exactly(2), usage: "pow(a, b)", doc: "a^b; any a for an integer constant b, a >= 0 otherwise" },
    Function { name: "floor", arity: Arity::Exactly(1), usage: "floor(u)", doc: "the largest integer <= u; jumps at every integer" },
    Function { name: "ceil", arity: Arity::Exactly(1), usage: "ceil(u)", doc: "the smallest integer >= u; jumps at every integer" },
    Function { name: "round", arity: Arity::Exactly(1), usage: "round(u)", doc: "the nearest integer, halves away from zero; jumps at every half" },
    Function { name: "mod", arity: Arity::Exactly(2), usage: "mod(a, b)", doc: "a - b*floor(a/b): the remainder with the sign of b (b != 0); jumps where a/b is an integer" },
    Function { name: "hypot", arity: Arity::Exactly(2), usage: "hypot(a, b)", doc: "sqrt(a^2 + b^2); all reals" },
    Function { name: "union", arity: Arity::AtLeast(2), usage: "union(a, b, ...)", doc: "CSG union of solids a <= 0, b <= 0: min(a, b, ...)" },
    Function { name: "intersect", arity: Arity::AtLeast(2), usage: "intersect(a, b, ...)", doc: "CSG intersection: max(a, b, ...)" },
    Function { name: "subtract", arity: Arity::Exactly(2), usage: "subtract(a, b)", doc: "CSG difference a minus b: max(a, -b)" },
    Function { name: "blend", arity: Arity::Exactly(3), usage: "blend(a, b, r)", doc: "smooth union with blend radius r > 0: min(a,b) - h^2 r/4, h = max(r - |a-b|, 0)/r" },
    Function { name: "translate", arity: Arity::Exactly(4), usage: "translate(f, dx, dy, dz)", doc: "f moved by (dx, dy, dz): f(x-dx, y-dy, z-dz)" },
    Function { name: "scale", arity: Arity::Exactly(2), usage: "scale(f, s)", doc: "f scaled by s > 0 about the origin: s*f(x/s, y/s, z/s)" },
    Function { name: "rotate", arity: Arity::Exactly(4), usage: "rotate(f, ax, ay, az)", doc: "f rotated by ax, then ay, then az degrees about the x, y and z axes" },
    Function { name: "sign", arity: Arity::Exactly(1), usage: "sign(u)", doc: "-1, 0 or 1; over an interval holding 0 it is [-1, 1]" },
    Function { name: "choose", arity: Arity::Exactly(3), usage: "choose(c, a, b)", doc: "a where c < 0, b where c > 0, (a+b)/2 at 0; over an interval holding 0, the hull of a and b (derivatives of min and max use it)" },
    Function { name: "dirac", arity: Arity::Exactly(1), usage: "dirac(u)", doc: "derivative of a unit step: 0 at every point, [0, inf] over an interval holding 0 (second derivatives of abs, min, max use it)" },
];

/// Named constants: `pi` and `e`.
pub const CONSTANTS: &[(&str, f64)] = &[("pi", std::f64::consts::PI), ("e", std::f64::consts::E)];

/// The built-in function called `name`.
pub fn function(name: &str) -> Option<&'static Function> {
    FUNCTIONS.iter().find(|f| f.name == name)
}

/// The value of the named constant `name`.
pub fn constant(name: &str) -> Option<f64> {
    CONSTANTS.iter().find(|(n, _)| *n == name).map(|&(_, v)| v)
}

/// The candidate closest to `name` by edit distance, if it is close enough to
/// be what the user meant.
pub fn closest<'a>(name: &str, candidates: impl IntoIterator<Item = &'a str>) -> Option<&'a str> {
    candidates
        .into_iter()
        .map(|c| (strsim::damerau_levenshtein(name, c), c))
        .filter(|&(d, c)| d <= 2 && d < name.len().max(c.len()))
        .min_by_key(|&(d, _)| d)
        .map(|(_, c)| c)
}

/// The language reference shown by `lgc --help` and in `docs/language.md`.
pub fn language_reference() -> String {
    let mut s = String::from(
        "FORMULA LANGUAGE\n  \
         numbers: 2  0.5  .5  1e-3  2.5E+4     variables: x y z     constants: pi e\n  \
         operators: + - * / ^   (^ is right-associative and binds tighter than unary minus:\n             \
         -x^2 = -(x^2), 2^3^2 = 512)\n  \
         bindings: `let r = 0.5; x^2 + y^2 + z^2 - r^2`   comments: # to end of line\n  \
         newlines may appear anywhere; `-f FILE` reads a formula from a file (`-f -`: stdin)\n  \
         dx dy dz name the ray direction in printed directional derivatives\n\nFUNCTIONS\n",
    );
    for f in FUNCTIONS {
        s.push_str(&format!("  {:<16} {}\n", f.usage, f.doc));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn suggestions_find_near_misses_only() {
        let names = FUNCTIONS.iter().map(|f| f.name);
        assert_eq!(closest("sn", names.clone()), Some("sin"));
        assert_eq!(closest("sqr", names.clone()), Some("sqrt"));
        assert!(matches!(
            closest("atan3", names.clone()),
            Some("atan" | "atan2")
        ));
        assert_eq!(closest("banana", names), None);
    }
}
