//! Axis-aligned boxes on the host.

use optik_api::Matrix3x4;

/// A box; empty when `min > max` on some axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Aabb {
    pub min: [f32; 3],
    pub max: [f32; 3],
}

impl Aabb {
    /// The empty box: the identity of [`Aabb::union`].
    pub const EMPTY: Aabb = Aabb {
        min: [f32::INFINITY; 3],
        max: [f32::NEG_INFINITY; 3],
    };

    /// The box grown to hold `p`.
    pub fn grow(self, p: [f32; 3]) -> Aabb {
        Aabb {
            min: std::array::from_fn(|i| self.min[i].min(p[i])),
            max: std::array::from_fn(|i| self.max[i].max(p[i])),
        }
    }

    /// The smallest box holding both.
    pub fn union(self, o: Aabb) -> Aabb {
        Aabb {
            min: std::array::from_fn(|i| self.min[i].min(o.min[i])),
            max: std::array::from_fn(|i| self.max[i].max(o.max[i])),
        }
    }

    /// The box widened by `r` on every side.
    pub fn padded(self, r: f32) -> Aabb {
        Aabb {
            min: self.min.map(|v| v - r),
            max: self.max.map(|v| v + r),
        }
    }

    /// Whether the box is non-empty with finite, non-NaN corners: a primitive with such a
    /// box can be hit; any other never is (NaN or infinite geometry is inactive).
    pub fn is_usable(&self) -> bool {
        (0..3).all(|i| {
            self.min[i].is_finite() && self.max[i].is_finite() && self.min[i] <= self.max[i]
        })
    }

    /// Half the surface area (for choosing which child to open when widening nodes).
    pub fn half_area(&self) -> f32 {
        if !self.is_usable() {
            return 0.0;
        }
        let d: [f32; 3] = std::array::from_fn(|i| self.max[i] - self.min[i]);
        d[0] * d[1] + d[1] * d[2] + d[2] * d[0]
    }

    /// The box of the eight transformed corners, rounded outwards by a relative 2⁻²⁰ so
    /// that f32 rounding of the transform never shrinks it below the exact image.
    pub fn transformed(&self, m: &Matrix3x4) -> Aabb {
        if !self.is_usable() {
            return Aabb::EMPTY;
        }
        let mut out = Aabb::EMPTY;
        for corner in 0..8 {
            let p: [f64; 3] = std::array::from_fn(|i| {
                if corner & (1 << i) != 0 {
                    self.max[i] as f64
                } else {
                    self.min[i] as f64
                }
            });
            let q: [f32; 3] = std::array::from_fn(|r| {
                (m[r * 4] as f64 * p[0]
                    + m[r * 4 + 1] as f64 * p[1]
                    + m[r * 4 + 2] as f64 * p[2]
                    + m[r * 4 + 3] as f64) as f32
            });
            out = out.grow(q);
        }
        out.widened_relative()
    }

    /// The box grown by 2⁻²⁰ of its largest coordinate magnitude.
    pub fn widened_relative(self) -> Aabb {
        let scale = (0..3)
            .map(|i| self.min[i].abs().max(self.max[i].abs()))
            .fold(0.0f32, f32::max);
        self.padded(scale * (1.0 / (1u32 << 20) as f32))
    }
}
