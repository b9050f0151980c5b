//! Axis-aligned boxes as the builders and the traversal store them.

use optik_api::Matrix3x4;

/// An axis-aligned box. The empty box has `min = +∞` and `max = -∞`, so unions ignore it
/// and every slab test misses it.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct Aabb {
    /// Smallest corner.
    pub min: [f32; 3],
    /// Largest corner.
    pub max: [f32; 3],
}

impl Aabb {
    /// The empty box.
    pub const EMPTY: Aabb = Aabb {
        min: [f32::INFINITY; 3],
        max: [f32::NEG_INFINITY; 3],
    };

    /// The box of one point.
    pub fn point(p: [f32; 3]) -> Aabb {
        Aabb { min: p, max: p }
    }

    /// The box from `min.xyz, max.xyz` as custom primitive inputs store it.
    pub fn from_six(v: [f32; 6]) -> Aabb {
        Aabb {
            min: [v[0], v[1], v[2]],
            max: [v[3], v[4], v[5]],
        }
    }

    /// The box as `min.xyz, max.xyz` (custom primitive inputs' and Vulkan's layout).
    pub fn to_six(&self) -> [f32; 6] {
        [
            self.min[0],
            self.min[1],
            self.min[2],
            self.max[0],
            self.max[1],
            self.max[2],
        ]
    }

    /// Whether the box holds at least one point (`min <= max` on every axis).
    pub fn is_valid(&self) -> bool {
        (0..3).all(|i| self.min[i] <= self.max[i])
    }

    /// Whether every coordinate is finite (an empty box is not).
    pub fn is_finite(&self) -> bool {
        self.min
            .iter()
            .chain(self.max.iter())
            .all(|v| v.is_finite())
    }

    /// Grows the box to hold `p`.
    pub fn grow(&mut self, p: [f32; 3]) {
        for ((lo, hi), v) in self.min.iter_mut().zip(self.max.iter_mut()).zip(p) {
            *lo = lo.min(v);
            *hi = hi.max(v);
        }
    }

    /// The smallest box holding both.
    pub fn union(&self, o: &Aabb) -> Aabb {
        Aabb {
            min: std::array::from_fn(|i| self.min[i].min(o.min[i])),
            max: std::array::from_fn(|i| self.max[i].max(o.max[i])),
        }
    }

    /// The box grown by `r` on every side.
    pub fn padded(&self, r: f32) -> Aabb {
        Aabb {
            min: [self.min[0] - r, self.min[1] - r, self.min[2] - r],
            max: [self.max[0] + r, self.max[1] + r, self.max[2] + r],
        }
    }

    /// The box grown outwards by a few ulps of its coordinates, so that rounding in the
    /// computation that produced it cannot leave a point of the true box outside.
    pub fn rounded_out(&self) -> Aabb {
        // 2^-20 relative: a little over 8 ulps, enough for the handful of rounded operations
        // of a transformed corner (matrix product) and far below anything visible.
        let pad = |a: f32, b: f32| (a.abs().max(b.abs())) * (1.0 / 1_048_576.0) + f32::MIN_POSITIVE;
        let mut r = *self;
        for i in 0..3 {
            let p = pad(self.min[i], self.max[i]);
            r.min[i] -= p;
            r.max[i] += p;
        }
        r
    }

    /// The 8 corners.
    pub fn corners(&self) -> [[f32; 3]; 8] {
        std::array::from_fn(|c| {
            [
                if c & 1 == 0 { self.min[0] } else { self.max[0] },
                if c & 2 == 0 { self.min[1] } else { self.max[1] },
                if c & 4 == 0 { self.min[2] } else { self.max[2] },
            ]
        })
    }

    /// The box of this box's corners after `m`, a conservative bound of the transformed box
    /// on every backend: corners are transformed in f64 (so the matrix product adds no
    /// rounding of its own), then the box is rounded out per axis and widened by 2⁻²⁰ of its
    /// largest coordinate magnitude, which covers the f32 rounding of the matrix a traversal
    /// applies to rays. The empty box stays empty.
    pub fn transformed(&self, m: &Matrix3x4) -> Aabb {
        if !self.is_valid() {
            return Aabb::EMPTY;
        }
        let mut r = Aabb::EMPTY;
        for c in self.corners() {
            let p = c.map(f64::from);
            r.grow(std::array::from_fn(|row| {
                (f64::from(m[row * 4]) * p[0]
                    + f64::from(m[row * 4 + 1]) * p[1]
                    + f64::from(m[row * 4 + 2]) * p[2]
                    + f64::from(m[row * 4 + 3])) as f32
            }));
        }
        r.rounded_out().widened_relative()
    }

    /// Whether the box is non-empty with finite corners: a primitive or child with such a
    /// box can be hit; any other never is.
    pub fn is_usable(&self) -> bool {
        self.is_valid() && self.is_finite()
    }

    /// The box grown on every side by 2⁻²⁰ of its largest coordinate magnitude.
    pub fn widened_relative(&self) -> Aabb {
        let scale = (0..3)
            .map(|i| self.min[i].abs().max(self.max[i].abs()))
            .fold(0.0f32, f32::max);
        self.padded(scale * (1.0 / 1_048_576.0))
    }

    /// Half the surface area (a SAH cost measure); 0 for an empty box.
    pub fn half_area(&self) -> f32 {
        if !self.is_valid() {
            return 0.0;
        }
        let d = [
            self.max[0] - self.min[0],
            self.max[1] - self.min[1],
            self.max[2] - self.min[2],
        ];
        d[0] * d[1] + d[1] * d[2] + d[2] * d[0]
    }

    /// The box with every coordinate multiplied by `s` (for `s` > 0: still a box, min below
    /// max; exact for a power of two unless a coordinate underflows).
    pub fn scaled(&self, s: f32) -> Aabb {
        Aabb {
            min: self.min.map(|v| v * s),
            max: self.max.map(|v| v * s),
        }
    }

    pub(crate) fn to_obvhs(self) -> obvhs::aabb::Aabb {
        obvhs::aabb::Aabb::new(self.min.into(), self.max.into())
    }
}

impl Default for Aabb {
    fn default() -> Self {
        Aabb::EMPTY
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn empty_box_is_neutral_for_union() {
        let b = Aabb {
            min: [0.0, 1.0, 2.0],
            max: [1.0, 2.0, 3.0],
        };
        assert_eq!(Aabb::EMPTY.union(&b), b);
        assert_eq!(b.union(&Aabb::EMPTY), b);
        assert!(!Aabb::EMPTY.is_valid());
        assert_eq!(
            Aabb::EMPTY.transformed(&optik_api::IDENTITY_3X4),
            Aabb::EMPTY
        );
    }

    #[test]
    fn transformed_box_holds_transformed_points() {
        let b = Aabb {
            min: [-1.0, 0.5, 2.0],
            max: [3.0, 0.75, 9.0],
        };
        let m: Matrix3x4 = [
            0.3, -0.9, 0.1, 1e5, 0.8, 0.2, -0.4, -7.0, 0.1, 0.3, 0.95, 3.0,
        ];
        let t = b.transformed(&m);
        for c in b.corners() {
            let p = optik_api::semantics::affine::transform_point(&m, c);
            for i in 0..3 {
                assert!(t.min[i] < p[i] && p[i] < t.max[i], "{p:?} outside {t:?}");
            }
        }
    }
}
