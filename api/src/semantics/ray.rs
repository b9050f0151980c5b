//! The invalid-ray policy shared by every backend (DESIGN.md §4).
//!
//! A ray is invalid when its origin or direction has a NaN or infinite component, when tmin
//! is negative or NaN, when tmax is NaN, or when tmin > tmax. An invalid ray **misses without
//! running any program**: no intersection, any-hit, closest-hit or miss program runs and the
//! payload is unchanged. With `ExceptionFlags::DEBUG` the exception program runs with code
//! [`super::exception::INVALID_RAY`] instead. A zero direction is valid (it hits nothing
//! but custom primitives that report). tmax = +∞ is valid.

/// Why a ray is invalid.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum InvalidRay {
    /// A component of the origin is NaN or infinite.
    NonFiniteOrigin,
    /// A component of the direction is NaN or infinite.
    NonFiniteDirection,
    /// tmin is negative or NaN.
    BadTmin,
    /// tmax is NaN.
    NanTmax,
    /// tmin > tmax.
    EmptyInterval,
}

/// Checks a ray against the policy.
pub fn check(
    origin: [f32; 3],
    direction: [f32; 3],
    tmin: f32,
    tmax: f32,
) -> Result<(), InvalidRay> {
    if !origin.iter().all(|c| c.is_finite()) {
        return Err(InvalidRay::NonFiniteOrigin);
    }
    if !direction.iter().all(|c| c.is_finite()) {
        return Err(InvalidRay::NonFiniteDirection);
    }
    // `!(tmin >= 0)` also catches NaN; -0.0 >= 0 holds, so -0.0 is a valid tmin.
    if !(tmin >= 0.0) {
        return Err(InvalidRay::BadTmin);
    }
    if tmax.is_nan() {
        return Err(InvalidRay::NanTmax);
    }
    if tmin > tmax {
        return Err(InvalidRay::EmptyInterval);
    }
    Ok(())
}

/// Whether `check` passes, without saying why not: the form the CPU backend's trace path
/// runs per ray. Branch-free: `x · 0` is `±0` for every finite `x` and NaN for infinities
/// and NaNs, so one comparison of their sum tests all six components; `tmin >= 0` fails for
/// NaN and negative tmin (not `-0.0`), `tmin <= tmax` for NaN tmax and empty intervals.
#[inline]
pub fn is_valid(origin: [f32; 3], direction: [f32; 3], tmin: f32, tmax: f32) -> bool {
    let zeroed = (origin[0] * 0.0 + origin[1] * 0.0)
        + (origin[2] * 0.0 + direction[0] * 0.0)
        + (direction[1] * 0.0 + direction[2] * 0.0);
    (zeroed == 0.0) & (tmin >= 0.0) & (tmin <= tmax)
}

/// Whether a triangle hit at `t` lies in the open interval (tmin, tmax).
pub fn triangle_t_accepted(t: f32, tmin: f32, tmax: f32) -> bool {
    t > tmin && t < tmax
}

/// Whether a reported custom-primitive hit at `t` lies in the closed interval [tmin, tmax].
pub fn reported_t_accepted(t: f32, tmin: f32, tmax: f32) -> bool {
    t >= tmin && t <= tmax
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `is_valid` is `check(..).is_ok()` on every combination of special values.
    #[test]
    fn is_valid_agrees_with_check() {
        let values = [
            0.0,
            -0.0,
            1.0,
            -1.0,
            1e-45,
            3e38,
            -3e38,
            f32::MAX,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
        ];
        let mut seen = [0usize; 2];
        for (i, &a) in values.iter().enumerate() {
            for &b in &values {
                for &c in &values {
                    // Each value in each origin and direction slot, with every interval.
                    let slot = i % 6;
                    let mut v = [0.5f32; 6];
                    v[slot] = a;
                    v[(slot + 3) % 6] = b;
                    let (o, d) = ([v[0], v[1], v[2]], [v[3], v[4], v[5]]);
                    for (tmin, tmax) in [(b, c), (c, b), (0.0, c), (b, f32::INFINITY)] {
                        let want = check(o, d, tmin, tmax).is_ok();
                        assert_eq!(
                            is_valid(o, d, tmin, tmax),
                            want,
                            "{o:?} {d:?} {tmin} {tmax}"
                        );
                        seen[want as usize] += 1;
                    }
                }
            }
        }
        assert!(seen[0] > 1000 && seen[1] > 100, "{seen:?}");
    }

    #[test]
    fn policy_table() {
        let o = [0.0; 3];
        let d = [0.0, 0.0, 1.0];
        assert_eq!(check(o, d, 0.0, f32::INFINITY), Ok(()));
        assert_eq!(check(o, d, -0.0, 1.0), Ok(()));
        assert_eq!(check(o, d, 1.0, 1.0), Ok(()));
        assert_eq!(
            check(o, [0.0; 3], 0.0, 1.0),
            Ok(()),
            "zero direction is valid"
        );
        assert_eq!(
            check([f32::NAN, 0.0, 0.0], d, 0.0, 1.0),
            Err(InvalidRay::NonFiniteOrigin)
        );
        assert_eq!(
            check([f32::INFINITY, 0.0, 0.0], d, 0.0, 1.0),
            Err(InvalidRay::NonFiniteOrigin)
        );
        assert_eq!(
            check(o, [0.0, f32::NEG_INFINITY, 1.0], 0.0, 1.0),
            Err(InvalidRay::NonFiniteDirection)
        );
        assert_eq!(
            check(o, [0.0, f32::NAN, 1.0], 0.0, 1.0),
            Err(InvalidRay::NonFiniteDirection)
        );
        assert_eq!(check(o, d, -1e-30, 1.0), Err(InvalidRay::BadTmin));
        assert_eq!(check(o, d, f32::NAN, 1.0), Err(InvalidRay::BadTmin));
        assert_eq!(check(o, d, 0.0, f32::NAN), Err(InvalidRay::NanTmax));
        assert_eq!(check(o, d, 2.0, 1.0), Err(InvalidRay::EmptyInterval));
    }

    #[test]
    fn intervals_open_for_triangles_closed_for_reports() {
        assert!(!triangle_t_accepted(1.0, 1.0, 2.0));
        assert!(!triangle_t_accepted(2.0, 1.0, 2.0));
        assert!(triangle_t_accepted(1.5, 1.0, 2.0));
        assert!(reported_t_accepted(1.0, 1.0, 2.0));
        assert!(reported_t_accepted(2.0, 1.0, 2.0));
        assert!(!reported_t_accepted(2.0000002, 1.0, 2.0));
    }
}
