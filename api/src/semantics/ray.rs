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
