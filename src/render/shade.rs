//! Shading: Blinn–Phong with a key light that casts hard shadows, a fill light
//! and ambient light, over a background gradient. Colours are linear RGB;
//! conversion to sRGB happens only on output.

use glam::DVec3;

/// A directional light.
#[derive(Debug, Clone, Copy)]
pub struct Light {
    /// Unit vector towards the light.
    pub direction: DVec3,
    /// Linear RGB intensity.
    pub color: DVec3,
    /// Whether the light casts shadows.
    pub shadows: bool,
}

/// Lights and material of a rendering.
#[derive(Debug, Clone)]
pub struct Shading {
    /// The lights.
    pub lights: Vec<Light>,
    /// Ambient light (linear RGB).
    pub ambient: DVec3,
    /// Diffuse colour of the surface (linear RGB).
    pub albedo: DVec3,
    /// Specular strength.
    pub specular: f64,
    /// Blinn–Phong exponent.
    pub shininess: f64,
    /// Background at the top and bottom of the image (linear RGB).
    pub sky: (DVec3, DVec3),
}

/// The sky at the top and at the bottom of the view (linear RGB).
pub const SKY: (DVec3, DVec3) = (DVec3::new(0.30, 0.42, 0.62), DVec3::new(0.90, 0.91, 0.93));

/// Converts an sRGB component in [0, 1] to linear.
pub fn srgb_to_linear(c: f64) -> f64 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// Buckets of the [0, 1] range in [`linear_to_srgb8`]'s index: enough that
/// no bucket holds two thresholds (the curve rises at most 12.92·255 ≈ 3295
/// bytes per unit, less than one per bucket), so one comparison finishes.
const BUCKETS: usize = 4096;

/// The thresholds of [`linear_to_srgb8`] and, per bucket, the byte at its
/// lower edge.
struct SrgbTable {
    /// For each byte v ≥ 1, the smallest linear value the formula maps to
    /// v or above (at index v − 1); `+∞` last, so index 255 compares false.
    thresholds: [f64; 256],
    /// For each bucket `[i/BUCKETS, (i+1)/BUCKETS)`, the byte of its lower edge.
    start: [u8; BUCKETS],
}

impl SrgbTable {
    fn new() -> SrgbTable {
        // A bisection on the bits of f64s in [0, 1], whose order is their
        // values' order, for the first bits the formula maps to v or above.
        // It starts from 2¹² ulps either side of the inverse formula's value
        // where those bracket the threshold (14 evaluations of the formula,
        // not 62 from all of [0, 1]: the table is made on the way to the
        // first pixel), from [0, 1] where not.
        let thresholds: [f64; 256] = std::array::from_fn(|k| {
            if k == 255 {
                return f64::INFINITY;
            }
            let v = k as u8 + 1;
            let reaches = |bits: u64| linear_to_srgb8_by_formula(f64::from_bits(bits)) >= v;
            let guess = srgb_to_linear((f64::from(v) - 0.5) / 255.0).to_bits();
            let (near_lo, near_hi) = (guess.saturating_sub(1 << 12), guess + (1 << 12));
            let (mut lo, mut hi) = if !reaches(near_lo) && reaches(near_hi) {
                (near_lo + 1, near_hi)
            } else {
                (0u64, 1f64.to_bits())
            };
            while lo < hi {
                let mid = lo + (hi - lo) / 2;
                if reaches(mid) {
                    hi = mid;
                } else {
                    lo = mid + 1;
                }
            }
            f64::from_bits(lo)
        });
        let at_edge = |i: usize| {
            let edge = i as f64 / BUCKETS as f64;
            thresholds.partition_point(|&t| t <= edge)
        };
        let start = std::array::from_fn(|i| at_edge(i) as u8);
        // The one comparison in `linear_to_srgb8` needs at most one threshold
        // past each bucket's lower edge and before the next.
        assert!((0..BUCKETS).all(|i| at_edge(i + 1) - at_edge(i) <= 1));
        SrgbTable { thresholds, start }
    }

    /// The table, made on first use.
    #[inline]
    fn get() -> &'static SrgbTable {
        static TABLE: std::sync::OnceLock<SrgbTable> = std::sync::OnceLock::new();
        TABLE.get_or_init(SrgbTable::new)
    }

    /// [`linear_to_srgb8`] of `c`.
    #[inline(always)]
    fn byte(&self, c: f64) -> u8 {
        // NaN and negatives give 0, as the formula does; 1 and above give 255.
        if c.is_nan() || c <= 0.0 {
            return 0;
        }
        if c >= 1.0 {
            return 255;
        }
        // Exact: scaling by a power of two, then the floor, so the bucket's
        // lower edge is at most c (and below BUCKETS, c being below 1; the
        // `min` only spares the bounds check). Through i32, whose conversion
        // from f64 is one instruction and a range check on x86-64, where
        // usize's takes two conversions and a fix-up: 0.992x the
        // instructions of a 1024² render.
        let bucket = ((c * BUCKETS as f64) as i32 as usize).min(BUCKETS - 1);
        let v = self.start[bucket];
        v + u8::from(self.thresholds[usize::from(v)] <= c)
    }
}

/// Converts a linear component to an 8-bit sRGB value: the same byte as
/// [`linear_to_srgb8_by_formula`], read from a table by the value's bucket
/// and one threshold comparison, instead of a `powf` per channel.
#[inline]
pub fn linear_to_srgb8(c: f64) -> u8 {
    SrgbTable::get().byte(c)
}

/// [`linear_to_srgb8`] of each component of a linear RGB colour.
#[inline]
pub fn linear_to_srgb8_rgb(c: DVec3) -> [u8; 3] {
    let table = SrgbTable::get();
    [table.byte(c.x), table.byte(c.y), table.byte(c.z)]
}

/// Converts a linear component to an 8-bit sRGB value by the sRGB formula.
pub fn linear_to_srgb8_by_formula(c: f64) -> u8 {
    let c = c.clamp(0.0, 1.0);
    let s = if c <= 0.003_130_8 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    };
    (s * 255.0 + 0.5).floor() as u8
}

/// Blinn–Phong's highlight `max(cos, 0)^shininess`. Whole exponents (the
/// usual case) are taken by repeated squaring, a few products instead of a
/// `powf`; the result differs from `powf`'s by a few ulps.
#[inline]
pub fn highlight(cos: f64, shininess: f64) -> f64 {
    let c = cos.max(0.0);
    // (A round trip through an integer, rather than `fract`, which calls
    // out to libm on CPUs without SSE4.1's rounding.)
    let whole = shininess as u32;
    if f64::from(whole) == shininess && whole <= 1024 {
        powi_by_squaring(c, whole)
    } else {
        c.powf(shininess)
    }
}

/// `a^k` by repeated squaring, the products in the order of
/// compiler-builtins' `__powidf2` (what `f64::powi` calls for an exponent
/// known only at run time), so the same bits, without the call.
#[inline]
fn powi_by_squaring(mut a: f64, mut k: u32) -> f64 {
    let mut product = 1.0;
    loop {
        if k & 1 != 0 {
            product *= a;
        }
        k >>= 1;
        if k == 0 {
            return product;
        }
        a *= a;
    }
}

impl Shading {
    /// The default studio: a key light from the camera's upper left with
    /// shadows, a dimmer fill from the right, a little ambient light.
    /// `color` is the surface colour in sRGB, components in [0, 1].
    pub fn studio(camera_basis: (DVec3, DVec3, DVec3), color: DVec3) -> Shading {
        let (right, up, forward) = camera_basis;
        let key = (-0.55 * right + 0.85 * up - 0.6 * forward).normalize();
        let fill = (0.9 * right + 0.15 * up - 0.5 * forward).normalize();
        Shading {
            lights: vec![
                Light {
                    direction: key,
                    color: DVec3::splat(1.0),
                    shadows: true,
                },
                Light {
                    direction: fill,
                    color: DVec3::splat(0.28),
                    shadows: false,
                },
            ],
            ambient: DVec3::splat(0.06),
            albedo: color.to_array().map(srgb_to_linear).into(),
            specular: 0.35,
            shininess: 48.0,
            sky: SKY,
        }
    }

    /// The background seen at image height `v` (0 at the top, 1 at the bottom).
    pub fn background(&self, v: f64) -> DVec3 {
        self.sky.0.lerp(self.sky.1, v.clamp(0.0, 1.0))
    }

    /// The colour of a surface point with unit normal `n` (facing the viewer),
    /// seen along unit direction `view`; `lit(i)` says whether light `i`
    /// reaches the point.
    pub fn surface(&self, n: DVec3, view: DVec3, mut lit: impl FnMut(usize) -> bool) -> DVec3 {
        let mut c = self.ambient * self.albedo;
        for (i, light) in self.lights.iter().enumerate() {
            let ndl = n.dot(light.direction);
            if ndl <= 0.0 || (light.shadows && !lit(i)) {
                continue;
            }
            let half = (light.direction - view).normalize();
            let spec = highlight(n.dot(half), self.shininess) * self.specular;
            c += light.color * (self.albedo * ndl + DVec3::splat(spec));
        }
        c
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_round_trips_at_8_bits() {
        for v in 0..=255u8 {
            let lin = srgb_to_linear(f64::from(v) / 255.0);
            assert_eq!(linear_to_srgb8(lin), v);
        }
    }

    #[test]
    fn highlights_by_squaring_are_powi_to_the_bit_and_near_powf() {
        // Cosines across [0, 1] (and past it), some just under 1, where a
        // high power is most sensitive.
        let mut cosines: Vec<f64> = (0..=400).map(|k| f64::from(k) / 380.0).collect();
        cosines.extend((1..200).map(|k| 1.0 - f64::from(k) * 1e-9));
        for k in 0..=1024u32 {
            for &c in &cosines {
                let h = highlight(c, f64::from(k));
                // `powi`'s own result is left to the platform; on x86-64 it is
                // compiler-builtins' loop, which this must repeat exactly.
                #[cfg(target_arch = "x86_64")]
                assert_eq!(h.to_bits(), c.powi(k as i32).to_bits(), "{c}^{k}");
                let p = c.powf(f64::from(k));
                assert!(
                    (h - p).abs() <= 1e-12 * p + f64::MIN_POSITIVE,
                    "{c}^{k}: {h} vs {p}"
                );
            }
        }
        // Negative cosines give 0 (1 for the exponent 0); other exponents
        // take powf.
        assert_eq!(highlight(-0.5, 48.0), 0.0);
        assert_eq!(highlight(-0.5, 0.0), 1.0);
        assert_eq!(highlight(0.5, 2.5), 0.5f64.powf(2.5));
        assert_eq!(highlight(0.5, 1025.0), 0.5f64.powf(1025.0));
        assert_eq!(highlight(0.5, -2.0), 0.5f64.powf(-2.0));
        assert!(highlight(0.5, f64::NAN).is_nan());
    }

    #[test]
    fn shadowed_points_get_only_ambient_and_fill() {
        let s = Shading::studio((DVec3::X, DVec3::Z, DVec3::Y), DVec3::ONE);
        let n = -DVec3::Y;
        let lit = s.surface(n, DVec3::Y, |_| true);
        let dark = s.surface(n, DVec3::Y, |_| false);
        assert!(lit.x > dark.x && dark.x >= s.ambient.x);
    }

    #[test]
    fn the_srgb_table_gives_the_formulas_byte() {
        // Around every threshold, and across the range.
        let mut checked = 0;
        for v in 0..=255u32 {
            let c = if v == 0 {
                0.0
            } else {
                srgb_to_linear((f64::from(v) - 0.5) / 255.0)
            };
            let mut x = c;
            for _ in 0..64 {
                x = x.next_down();
            }
            for _ in 0..128 {
                assert_eq!(linear_to_srgb8(x), linear_to_srgb8_by_formula(x), "at {x}");
                x = x.next_up();
                checked += 1;
            }
        }
        // Around every edge of the table's buckets.
        for i in 0..=BUCKETS as u32 {
            let mut x = f64::from(i) / BUCKETS as f64;
            for _ in 0..8 {
                x = x.next_down();
            }
            for _ in 0..16 {
                assert_eq!(linear_to_srgb8(x), linear_to_srgb8_by_formula(x), "at {x}");
                x = x.next_up();
            }
        }
        for k in 0..=100_000 {
            let c = f64::from(k) / 100_000.0 * 1.2 - 0.1;
            assert_eq!(linear_to_srgb8(c), linear_to_srgb8_by_formula(c), "at {c}");
        }
        for c in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY, -0.0, 1.0, 2.0] {
            assert_eq!(linear_to_srgb8(c), linear_to_srgb8_by_formula(c), "at {c}");
        }
        assert!(checked > 30_000);
    }
}
