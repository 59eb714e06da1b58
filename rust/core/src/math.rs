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

// The transcendental functions of the world, the laws and the observations come from the `libm`
// crate (a pure-Rust port of musl's), never from std's `f64` methods: those call the platform's
// C library, and glibc, macOS and Windows round differently in the last bit on a fraction of
// arguments (glibc's sincos, atan2 and pow differ from correctly rounded on 0.28 %, 0.09 % and
// 0.08 % of them). One bit is enough for two trajectories to drift apart, and a benchmark's
// episodes must be the same on every machine (docs/tasks.md, "Versions"). `sqrt` and the
// arithmetic operators are exactly rounded by IEEE 754 on every platform and stay as they are.
// `tests::no_platform_transcendentals_outside_tests` keeps the rest of the crate to these.

/// sin(x), the same bits on every platform.
#[inline]
pub fn sin(x: f64) -> f64 {
    libm::sin(x)
}

/// cos(x), the same bits on every platform.
#[inline]
pub fn cos(x: f64) -> f64 {
    libm::cos(x)
}

/// (sin x, cos x), the same bits on every platform (and as [`sin`] and [`cos`] give).
#[inline]
pub fn sin_cos(x: f64) -> (f64, f64) {
    libm::sincos(x)
}

/// atan2(y, x) in (−π, π], the same bits on every platform.
#[inline]
pub fn atan2(y: f64, x: f64) -> f64 {
    libm::atan2(y, x)
}

/// atan(x), the same bits on every platform.
#[inline]
pub fn atan(x: f64) -> f64 {
    libm::atan(x)
}

/// asin(x), the same bits on every platform.
#[inline]
pub fn asin(x: f64) -> f64 {
    libm::asin(x)
}

/// acos(x), the same bits on every platform.
#[inline]
pub fn acos(x: f64) -> f64 {
    libm::acos(x)
}

/// x^y, the same bits on every platform.
#[inline]
pub fn pow(x: f64, y: f64) -> f64 {
    libm::pow(x, y)
}

/// e^x, the same bits on every platform.
#[inline]
pub fn exp(x: f64) -> f64 {
    libm::exp(x)
}

/// The natural logarithm, the same bits on every platform.
#[inline]
pub fn ln(x: f64) -> f64 {
    libm::log(x)
}

/// Maps an angle into [0, 2π) (the `wrap` of docs/world-and-laws.md, Conventions).
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
    wrap(atan2(v.y, v.x))
}

/// Unit vector at angle `a`.
#[inline]
pub fn unit(a: f64) -> Vec2 {
    let (s, c) = sin_cos(a);
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

    /// The source of this crate outside its tests, with every `#[cfg(test)]` item cut out.
    fn non_test_source(text: &str) -> String {
        let mut out = String::new();
        let mut lines = text.lines();
        while let Some(line) = lines.next() {
            if line.trim() != "#[cfg(test)]" {
                out.push_str(line);
                out.push('\n');
                continue;
            }
            // Skip the item the attribute applies to: up to the brace that closes its first one.
            let mut depth = 0i64;
            let mut opened = false;
            for item_line in lines.by_ref() {
                depth += item_line.matches('{').count() as i64 - item_line.matches('}').count() as i64;
                opened |= item_line.contains('{');
                if opened && depth <= 0 {
                    break;
                }
            }
        }
        out
    }

    #[test]
    fn no_platform_transcendentals_outside_tests() {
        // std's f64 methods and rand_distr's normals call the platform's C library (see the
        // comment above `sin`): outside this module and the tests, the crate uses the libm
        // wrappers here and `crate::normal`.
        let calls = [
            ".sin(",
            ".cos(",
            ".sin_cos(",
            ".tan(",
            ".atan2(",
            ".atan(",
            ".asin(",
            ".acos(",
            ".sinh(",
            ".cosh(",
            ".tanh(",
            ".powf(",
            ".exp(",
            ".exp2(",
            ".exp_m1(",
            ".ln(",
            ".ln_1p(",
            ".log(",
            ".log2(",
            ".log10(",
            ".hypot(",
            ".cbrt(",
            "StandardNormal",
            "Normal::new",
            "Exp1",
        ];
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
        let mut files = vec![root.clone()];
        let mut found = Vec::new();
        let mut checked = 0;
        while let Some(path) = files.pop() {
            if path.is_dir() {
                files.extend(std::fs::read_dir(&path).unwrap().map(|e| e.unwrap().path()));
                continue;
            }
            let name = path.strip_prefix(&root).unwrap().to_string_lossy().into_owned();
            if path.extension().is_none_or(|e| e != "rs") || name == "math.rs" || name == "normal.rs" {
                continue;
            }
            checked += 1;
            for line in non_test_source(&std::fs::read_to_string(&path).unwrap()).lines() {
                let code = line.split("//").next().unwrap();
                for call in calls {
                    if code.contains(call) {
                        found.push(format!("{name}: {call} in `{}`", line.trim()));
                    }
                }
            }
        }
        assert!(checked > 20, "only {checked} files checked");
        assert!(found.is_empty(), "platform transcendentals outside the tests:\n{}", found.join("\n"));
    }

    #[test]
    fn the_test_cutter_keeps_code_after_a_test_only_function() {
        let text = "fn a() {}\n#[cfg(test)]\nfn b() {\n    x.sin();\n}\nfn c() { y.cos() }\n";
        let kept = non_test_source(text);
        assert!(kept.contains("fn a") && kept.contains("fn c") && !kept.contains("fn b") && !kept.contains("x.sin"), "{kept}");
    }

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
