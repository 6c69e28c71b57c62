//! Geometric optics for Whitted ray tracing: mirror reflection, refraction by
//! Snell's law, and the Fresnel reflectance of a dielectric.

use glam::DVec3;

/// `d` mirrored about the unit normal `n`.
pub fn reflect(d: DVec3, n: DVec3) -> DVec3 {
    d - 2.0 * d.dot(n) * n
}

/// The refracted direction of unit `d` through a surface with unit normal `n`
/// facing the incoming ray (`d·n < 0`), from index `eta_i` into `eta_t`;
/// `None` for total internal reflection.
pub fn refract(d: DVec3, n: DVec3, eta_i: f64, eta_t: f64) -> Option<DVec3> {
    let eta = eta_i / eta_t;
    let cos_i = -d.dot(n);
    let k = 1.0 - eta * eta * (1.0 - cos_i * cos_i);
    (k >= 0.0).then(|| eta * d + (eta * cos_i - k.sqrt()) * n)
}

/// The fraction of unpolarised light a dielectric reflects, for the cosine of
/// the angle of incidence, from index `eta_i` into `eta_t` (1 under total
/// internal reflection).
pub fn fresnel(cos_i: f64, eta_i: f64, eta_t: f64) -> f64 {
    let cos_i = cos_i.clamp(0.0, 1.0);
    let sin_t = eta_i / eta_t * (1.0 - cos_i * cos_i).sqrt();
    if sin_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin_t * sin_t).sqrt();
    let rs = (eta_i * cos_i - eta_t * cos_t) / (eta_i * cos_i + eta_t * cos_t);
    let rp = (eta_t * cos_i - eta_i * cos_t) / (eta_t * cos_i + eta_i * cos_t);
    0.5 * (rs * rs + rp * rp)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reflection_keeps_the_angle_and_length() {
        let n = DVec3::Z;
        let d = DVec3::new(1.0, 0.5, -2.0);
        let r = reflect(d, n);
        assert_eq!(r, DVec3::new(1.0, 0.5, 2.0));
        assert!((r.length() - d.length()).abs() < 1e-15);
    }

    #[test]
    fn refraction_obeys_snells_law() {
        for deg in [0.0f64, 10.0, 30.0, 45.0, 70.0, 89.0] {
            let t = deg.to_radians();
            let d = DVec3::new(t.sin(), 0.0, -t.cos());
            let r = refract(d, DVec3::Z, 1.0, 1.5).unwrap();
            assert!((r.length() - 1.0).abs() < 1e-12);
            let sin_t = r.x;
            assert!((1.0 * t.sin() - 1.5 * sin_t).abs() < 1e-12, "{deg}°");
            assert!(r.z < 0.0, "the ray goes on through");
        }
    }

    #[test]
    fn total_internal_reflection_beyond_the_critical_angle() {
        let critical = (1.0f64 / 1.5).asin();
        let just_below = critical - 0.01;
        let just_above = critical + 0.01;
        let ray = |t: f64| DVec3::new(t.sin(), 0.0, -t.cos());
        assert!(refract(ray(just_below), DVec3::Z, 1.5, 1.0).is_some());
        assert!(refract(ray(just_above), DVec3::Z, 1.5, 1.0).is_none());
        assert_eq!(fresnel(just_above.cos(), 1.5, 1.0), 1.0);
        assert!(fresnel(just_below.cos(), 1.5, 1.0) < 1.0);
    }

    #[test]
    fn fresnel_at_normal_and_grazing_incidence() {
        // ((n1 − n2)/(n1 + n2))² = 0.04 for glass.
        assert!((fresnel(1.0, 1.0, 1.5) - 0.04).abs() < 1e-12);
        assert!((fresnel(1.0, 1.5, 1.0) - 0.04).abs() < 1e-12);
        assert!(fresnel(1e-6, 1.0, 1.5) > 0.99);
        // Reflectance grows with the angle.
        let mut last = 0.0;
        for k in (0..=10).rev() {
            let r = fresnel(f64::from(k) / 10.0, 1.0, 1.5);
            assert!(r >= last);
            last = r;
        }
    }
}
