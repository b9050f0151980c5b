//! The tolerance classes (README.md, "Rules") for one channel of a hit record.
//!
//! `U16` compares as idiff's `-fail 16ε·s -failrelative 16ε` does (|Δ| above both the absolute
//! and the relative bound fails, relative to the mean of the two values), so the same check
//! can be run with `idiff`; `s` scales the absolute floor for scenes far from unit size.

use crate::image::ChannelKind;

/// `f32` machine epsilon (2⁻²³).
pub const EPS: f64 = f32::EPSILON as f64;

/// How one channel is compared.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Tolerance {
    /// `E`: equal (integers, counts, bit patterns; for floats, equal values, NaN never equal).
    Exact,
    /// `F6`: |Δ| ≤ 4·2⁻²⁰ (analytic, well-conditioned floats).
    F6,
    /// `U16`: |Δ| ≤ 16·ε·max(scale, mean(|a|, |b|)).
    U16 {
        /// Magnitude below which the bound stops shrinking (1 for unit-size scenes).
        scale: f64,
    },
    /// `M3`: |Δ| ≤ 1e-3.
    M3,
    /// |Δ| ≤ the given bound.
    Abs(f64),
}

impl Tolerance {
    /// `U16` at unit scale.
    pub const U16: Tolerance = Tolerance::U16 { scale: 1.0 };

    /// The class name for listings.
    pub fn name(&self) -> String {
        match self {
            Tolerance::Exact => "E".into(),
            Tolerance::F6 => "F6".into(),
            Tolerance::U16 { scale } if *scale == 1.0 => "U16".into(),
            Tolerance::U16 { scale } => format!("U16@{scale:e}"),
            Tolerance::M3 => "M3".into(),
            Tolerance::Abs(a) => format!("abs {a:e}"),
        }
    }

    /// The allowed absolute difference between `a` and `b` (0 for exact).
    pub fn bound(&self, a: f64, b: f64) -> f64 {
        match *self {
            Tolerance::Exact => 0.0,
            Tolerance::F6 => 4.0 / 1_048_576.0,
            Tolerance::U16 { scale } => 16.0 * EPS * scale.max(0.5 * (a.abs() + b.abs())),
            Tolerance::M3 => 1e-3,
            Tolerance::Abs(x) => x,
        }
    }

    /// Compares two stored values (bits for floats). Returns `(accepted, error ratio)`, the
    /// ratio being |Δ| / bound (0 when equal, ∞ when unequal under an exact bound).
    pub fn check(&self, kind: ChannelKind, expected: u32, got: u32) -> (bool, f64) {
        match kind {
            ChannelKind::Uint => {
                if expected == got {
                    (true, 0.0)
                } else {
                    (false, f64::INFINITY)
                }
            }
            ChannelKind::Float => {
                let (e, g) = (f32::from_bits(expected) as f64, f32::from_bits(got) as f64);
                if e.is_nan() || g.is_nan() {
                    return (false, f64::INFINITY);
                }
                if e == g {
                    return (true, 0.0);
                }
                let diff = (e - g).abs();
                let bound = self.bound(e, g);
                if bound == 0.0 || !diff.is_finite() {
                    return (false, f64::INFINITY);
                }
                (diff <= bound, diff / bound)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn f(x: f32) -> u32 {
        x.to_bits()
    }

    #[test]
    fn classes() {
        let fl = ChannelKind::Float;
        assert!(Tolerance::Exact.check(fl, f(1.0), f(1.0)).0);
        assert!(!Tolerance::Exact.check(fl, f(1.0), f(1.0000001)).0);
        assert!(
            Tolerance::Exact.check(fl, f(0.0), f(-0.0)).0,
            "equal values"
        );
        assert!(
            !Tolerance::Exact.check(fl, f(f32::NAN), f(f32::NAN)).0,
            "NaN is never equal"
        );
        assert!(Tolerance::F6.check(fl, f(0.25), f(0.25 + 3e-6)).0);
        assert!(!Tolerance::F6.check(fl, f(0.25), f(0.25 + 5e-6)).0);
        // U16 at 1000: 16 ulps of 1000 pass, 40 do not.
        let big = 1000.0f32;
        assert!(
            Tolerance::U16
                .check(fl, f(big), f32::from_bits(big.to_bits() + 16).to_bits())
                .0
        );
        assert!(
            !Tolerance::U16
                .check(fl, f(big), f32::from_bits(big.to_bits() + 40).to_bits())
                .0
        );
        assert!(Tolerance::U16 { scale: 1e5 }.check(fl, f(1.0), f(1.005)).0);
        assert!(Tolerance::M3.check(fl, f(0.5), f(0.5009)).0);
        assert!(!Tolerance::Exact.check(ChannelKind::Uint, 3, 4).0);
        let (ok, ratio) = Tolerance::M3.check(fl, f(1.0), f(1.0005));
        assert!(ok && (ratio - 0.5).abs() < 0.01);
    }
}
