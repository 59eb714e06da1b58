//! Vector types and angle helpers: the one place that names the linear-algebra crate.
//!
//! nalgebra comes through parry (`parry2d-f64`), so the world and the geometry queries share
//! one version of it. The world is f64 throughout; observations are f32.

pub use parry2d_f64::na;

/// A 2-D vector (displacement, velocity, position relative to the origin).
pub type Vec2 = na::Vector2<f64>;
/// A point of the plane, as parry's queries take it.
pub type Point2 = na::Point2<f64>;

pub use std::f64::consts::{FRAC_PI_2, PI, TAU};

/// Maps an angle into [0, 2π) (SPEC's `wrap`).
#[inline]
pub fn wrap(a: f64) -> f64 {
    // Fast paths for the common case of an angle within one turn of [0, 2π). Both are exact
    // and equal to `rem_euclid` there: `a + TAU` is what rem_euclid returns for a ∈ (−2π, 0),
    // and `a − TAU` is exact for a ∈ [2π, 4π) (Sterbenz), as fmod is. Saves the fmod call
    // that profiling found at ~4% of a step.
    if (0.0..TAU).contains(&a) {
        return a;
    }
    // Open at −2π: there rem_euclid gives −0.0, and that sign must be kept bit for bit.
    if a > -TAU && a < 0.0 {
        let r = a + TAU;
        return if r >= TAU { 0.0 } else { r };
    }
    if (TAU..2.0 * TAU).contains(&a) {
        return a - TAU;
    }
    let r = a.rem_euclid(TAU);
    // rem_euclid can return TAU itself for tiny negative inputs after rounding.
    if r >= TAU {
        0.0
    } else {
        r
    }
}

/// `a.rem_euclid(TAU)`, bit for bit, without the software `fmod` (a library call of ≈ 35
/// instructions) for the usual case of an angle within one turn of [0, 2π) (an obstacle's
/// orientation after a small turn). Unlike [`wrap`] it keeps rem_euclid's rare result 2π
/// (for a tiny negative `a`), as the obstacle motion always has.
#[inline]
pub fn rem_euclid_tau(a: f64) -> f64 {
    // rem_euclid is `r = a % TAU; if r < 0 { r + TAU } else { r }`. For a ∈ (−2π, 2π) the fmod
    // returns `a` itself; for a ∈ [2π, 4π) it returns a − 2π, which is exact (Sterbenz).
    if (0.0..TAU).contains(&a) {
        a
    } else if a > -TAU && a < 0.0 {
        a + TAU
    } else if (TAU..2.0 * TAU).contains(&a) {
        a - TAU
    } else {
        a.rem_euclid(TAU)
    }
}

/// Maps an angle into (−π, π]: the signed difference helper.
#[inline]
pub fn wrap_pi(a: f64) -> f64 {
    let r = wrap(a);
    if r > PI {
        r - TAU
    } else {
        r
    }
}

/// Direction of a vector as an angle in [0, 2π); the zero vector has direction 0.
#[inline]
pub fn angle_of(v: Vec2) -> f64 {
    wrap(v.y.atan2(v.x))
}

/// Unit vector at angle `a`.
#[inline]
pub fn unit(a: f64) -> Vec2 {
    let (s, c) = a.sin_cos();
    Vec2::new(c, s)
}

/// 2-D cross product (z component of a × b).
#[inline]
pub fn cross(a: Vec2, b: Vec2) -> f64 {
    a.x * b.y - a.y * b.x
}

/// Asks the CPU to start loading every cache line of `s` (a hint: it never faults, changes no
/// value and costs one instruction per 64 bytes; a no-op off x86-64).
#[inline]
pub fn prefetch_slice<T>(s: &[T]) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        let p = s.as_ptr().cast::<i8>();
        let bytes = std::mem::size_of_val(s);
        let mut off = 0;
        while off < bytes {
            // SAFETY: a prefetch only hints the cache; `p + off` stays inside `s`.
            #[allow(unused_unsafe)]
            unsafe {
                _mm_prefetch::<_MM_HINT_T0>(p.add(off))
            };
            off += 64;
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = s;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wrap_maps_into_half_open_turn() {
        assert_eq!(wrap(0.0), 0.0);
        assert!((wrap(-FRAC_PI_2) - 1.5 * PI).abs() < 1e-15);
        assert!((wrap(TAU + 0.25) - 0.25).abs() < 1e-15);
        assert_eq!(wrap(TAU), 0.0);
        assert!(wrap(-1e-300) < TAU);
    }

    #[test]
    fn fast_paths_agree_with_rem_euclid() {
        let mut a = -3.0 * TAU;
        while a < 3.0 * TAU {
            let r = a.rem_euclid(TAU);
            let want = if r >= TAU { 0.0 } else { r };
            assert_eq!(wrap(a).to_bits(), want.to_bits(), "{a}");
            a += 0.0123456789;
        }
        for a in [-TAU, -1e-300, -0.0, TAU, 2.0 * TAU - 1e-15, f64::from_bits(TAU.to_bits() - 1)] {
            let r = a.rem_euclid(TAU);
            assert_eq!(wrap(a).to_bits(), (if r >= TAU { 0.0 } else { r }).to_bits(), "{a}");
        }
    }

    #[test]
    fn rem_euclid_tau_is_rem_euclid_bit_for_bit() {
        let mut a = -3.0 * TAU;
        while a < 3.0 * TAU {
            for x in [a, f64::from_bits(a.to_bits() + 1), f64::from_bits(a.to_bits().wrapping_sub(1))] {
                assert_eq!(rem_euclid_tau(x).to_bits(), x.rem_euclid(TAU).to_bits(), "{x}");
            }
            a += 0.000_987_654_321;
        }
        let edges = [-TAU, -1e-300, -1e-17, -0.0, 0.0, TAU, 2.0 * TAU, -2.0 * TAU, f64::from_bits(TAU.to_bits() - 1), f64::from_bits(TAU.to_bits() + 1), 1e300, -1e300];
        for x in edges {
            assert_eq!(rem_euclid_tau(x).to_bits(), x.rem_euclid(TAU).to_bits(), "{x}");
        }
    }

    #[test]
    fn wrap_pi_is_signed() {
        assert!((wrap_pi(1.5 * PI) + FRAC_PI_2).abs() < 1e-15);
        assert!((wrap_pi(PI) - PI).abs() < 1e-15);
    }

    #[test]
    fn angle_of_quadrants() {
        assert!((angle_of(Vec2::new(0.0, -1.0)) - 1.5 * PI).abs() < 1e-15);
        assert_eq!(angle_of(Vec2::new(1.0, 0.0)), 0.0);
    }
}
