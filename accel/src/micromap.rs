//! Opacity micromaps: the built array, and the micro-triangle a hit falls in.
//!
//! Micro-triangles are numbered along OptiX's (and Vulkan's) hierarchical space-filling
//! "bird" curve: at subdivision level `L` a triangle splits into `4^L` micro-triangles, and
//! micro-triangle `i` at level `L` is one of the four children of micro-triangle `i >> 2` at
//! level `L - 1`. [`micro_triangle`] maps an index to its three corners in barycentric
//! coordinates `(u, v)` (weights of vertices 1 and 2, as `rt_triangle_barycentrics`);
//! [`index_of`] descends the hierarchy to find the micro-triangle holding a hit.

use optik_api::semantics::opacity::MicromapState;
use optik_api::{
    OpacityMicromapArrayDesc, OpacityMicromapDesc, OpacityMicromapFormat, micromap_special_index,
};

/// A built opacity micromap array (what `create_opacity_micromap_array` returns a handle to).
#[derive(Clone, Debug, PartialEq)]
pub struct MicromapArrayData {
    /// The micromaps.
    pub micromaps: Vec<OpacityMicromapDesc>,
    /// Their packed states.
    pub data: Vec<u8>,
}

impl MicromapArrayData {
    /// The array of a validated description.
    pub fn new(desc: &OpacityMicromapArrayDesc) -> MicromapArrayData {
        MicromapArrayData {
            micromaps: desc.micromaps.clone(),
            data: desc.data.clone(),
        }
    }

    /// The state at barycentrics `(u, v)` of the triangle using micromap `index` (a
    /// micromap index, or one of the special indices -1..-4).
    pub fn state(&self, index: i32, u: f32, v: f32) -> MicromapState {
        match index {
            micromap_special_index::FULLY_TRANSPARENT => return MicromapState::Transparent,
            micromap_special_index::FULLY_OPAQUE => return MicromapState::Opaque,
            micromap_special_index::FULLY_UNKNOWN_TRANSPARENT => {
                return MicromapState::UnknownTransparent;
            }
            micromap_special_index::FULLY_UNKNOWN_OPAQUE => return MicromapState::UnknownOpaque,
            _ => {}
        }
        // Indices were checked against the array when the structure was built.
        let Some(m) = self.micromaps.get(index as usize) else {
            return MicromapState::Opaque;
        };
        let i = index_of(u, v, m.subdivision_level as u32) as usize;
        let base = m.byte_offset as usize;
        let code = match m.format {
            OpacityMicromapFormat::TwoState => (self.data[base + i / 8] >> (i % 8)) as u32 & 1,
            OpacityMicromapFormat::FourState => {
                (self.data[base + i / 4] >> (2 * (i % 4))) as u32 & 3
            }
        };
        MicromapState::from_code(code)
    }

    /// Bytes held.
    pub fn size_in_bytes(&self) -> u64 {
        (self.data.len() + self.micromaps.len() * std::mem::size_of::<OpacityMicromapDesc>()) as u64
    }
}

/// Bits 0, 2, 4, … of `x` gathered into the low half.
fn even_bits(mut x: u32) -> u32 {
    x &= 0x5555_5555;
    x = (x | (x >> 1)) & 0x3333_3333;
    x = (x | (x >> 2)) & 0x0F0F_0F0F;
    x = (x | (x >> 4)) & 0x00FF_00FF;
    (x | (x >> 8)) & 0x0000_FFFF
}

/// Bit `i` of the result is the XOR of bits `i..` of `x` (a prefix XOR from the top).
fn suffix_xor(mut x: u32) -> u32 {
    x ^= x >> 1;
    x ^= x >> 2;
    x ^= x >> 4;
    x ^= x >> 8;
    x
}

/// The discrete barycentric coordinates of the bird curve's micro-triangle `index` (all
/// levels at once; a level uses its low bits).
fn discrete_barycentrics(index: u32) -> (u32, u32, u32) {
    let b0 = even_bits(index);
    let b1 = even_bits(index >> 1);
    let fx = suffix_xor(b0);
    let fy = suffix_xor(b0 & !b1);
    let t = fy ^ b1;
    let u = (fx & !t) | (b0 & !t) | (!b0 & !fx & t);
    let v = fy ^ b0;
    let w = (!fx & !t) | (b0 & !t) | (!b0 & fx & t);
    (u, v, w)
}

/// The corners `(u, v)` of micro-triangle `index` at subdivision `level`, exact dyadic
/// values. The first corner holds the right angle.
pub fn micro_triangle(index: u32, level: u32) -> [[f64; 2]; 3] {
    if level == 0 {
        return [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]];
    }
    let (mut iu, mut iv, iw) = discrete_barycentrics(index);
    let mask = (1u32 << level) - 1;
    iu &= mask;
    iv &= mask;
    let upright = ((iu ^ iv ^ (iw & mask)) & 1) != 0;
    if !upright {
        iu += 1;
        iv += 1;
    }
    let s = 1.0 / (1u64 << level) as f64;
    let (u, v) = (iu as f64 * s, iv as f64 * s);
    let d = if upright { s } else { -s };
    [[u, v], [u + d, v], [u, v + d]]
}

/// Whether `(u, v)` lies in (or on the boundary of) a micro-triangle from [`micro_triangle`].
fn contains(tri: &[[f64; 2]; 3], u: f64, v: f64) -> bool {
    let [u0, v0] = tri[0];
    let d = tri[1][0] - u0;
    // Legs along +u/+v (upright) or -u/-v; exact for f32 inputs and dyadic corners.
    let (a, b) = ((u - u0) / d, (v - v0) / d);
    a >= 0.0 && b >= 0.0 && a + b <= 1.0
}

/// The micro-triangle at subdivision `level` holding barycentrics `(u, v)`. Points on a
/// shared edge go to the child that comes first along the curve; points a rounding error
/// outside the triangle go to the nearest child.
pub fn index_of(u: f32, v: f32, level: u32) -> u32 {
    let (u, v) = (u as f64, v as f64);
    let mut index = 0u32;
    for l in 1..=level {
        let children = std::array::from_fn::<u32, 4, _>(|k| index * 4 + k as u32);
        index = children
            .iter()
            .copied()
            .find(|&c| contains(&micro_triangle(c, l), u, v))
            .unwrap_or_else(|| {
                let dist = |c: u32| {
                    let t = micro_triangle(c, l);
                    let (cu, cv) = (
                        (t[0][0] + t[1][0] + t[2][0]) / 3.0,
                        (t[0][1] + t[1][1] + t[2][1]) / 3.0,
                    );
                    (cu - u).powi(2) + (cv - v).powi(2)
                };
                children
                    .iter()
                    .copied()
                    .min_by(|&a, &b| dist(a).total_cmp(&dist(b)))
                    .unwrap_or(index * 4)
            });
    }
    index
}

#[cfg(test)]
mod tests {
    use super::*;

    fn area(t: &[[f64; 2]; 3]) -> f64 {
        ((t[1][0] - t[0][0]) * (t[2][1] - t[0][1]) - (t[2][0] - t[0][0]) * (t[1][1] - t[0][1]))
            .abs()
            / 2.0
    }

    #[test]
    fn level_one_matches_optix_order() {
        // OptiX's level-1 order: the corner at vertex 0, the middle (inverted), the corner at
        // vertex 1, the corner at vertex 2 (optixMicromapIndexToBaseBarycentrics).
        let centroid = |i| {
            let t = micro_triangle(i, 1);
            (
                (t[0][0] + t[1][0] + t[2][0]) / 3.0,
                (t[0][1] + t[1][1] + t[2][1]) / 3.0,
            )
        };
        let c: Vec<(f64, f64)> = (0..4).map(centroid).collect();
        let near =
            |a: (f64, f64), b: (f64, f64)| (a.0 - b.0).abs() < 1e-9 && (a.1 - b.1).abs() < 1e-9;
        assert!(near(c[0], (1.0 / 6.0, 1.0 / 6.0)), "{c:?}");
        assert!(near(c[1], (1.0 / 3.0, 1.0 / 3.0)), "{c:?}");
        assert!(near(c[2], (2.0 / 3.0, 1.0 / 6.0)), "{c:?}");
        assert!(near(c[3], (1.0 / 6.0, 2.0 / 3.0)), "{c:?}");
    }

    #[test]
    fn curve_is_hierarchical_and_tiles_the_triangle() {
        for level in 1..=5u32 {
            let n = 1u32 << (2 * level);
            let mut total = 0.0;
            for i in 0..n {
                let t = micro_triangle(i, level);
                total += area(&t);
                let parent = micro_triangle(i >> 2, level - 1);
                for corner in t {
                    assert!(
                        contains(&parent, corner[0], corner[1]),
                        "level {level} index {i} leaves its parent"
                    );
                }
                // The centroid finds its own micro-triangle.
                let (cu, cv) = (
                    (t[0][0] + t[1][0] + t[2][0]) / 3.0,
                    (t[0][1] + t[1][1] + t[2][1]) / 3.0,
                );
                assert_eq!(index_of(cu as f32, cv as f32, level), i);
            }
            assert!((total - 0.5).abs() < 1e-12);
        }
        // Level 12: a point near vertex 1 lands in a micro-triangle holding it.
        let i = index_of(0.999, 0.0004, 12);
        assert!(contains(
            &micro_triangle(i, 12),
            0.999f32 as f64,
            0.0004f32 as f64
        ));
    }

    #[test]
    fn states_read_packed_bits() {
        use MicromapState::*;
        let two = MicromapArrayData {
            micromaps: vec![OpacityMicromapDesc {
                byte_offset: 0,
                subdivision_level: 1,
                format: OpacityMicromapFormat::TwoState,
            }],
            data: vec![0b0101],
        };
        let centres = [
            (1.0 / 6.0, 1.0 / 6.0),
            (1.0 / 3.0, 1.0 / 3.0),
            (2.0 / 3.0, 1.0 / 6.0),
            (1.0 / 6.0, 2.0 / 3.0),
        ];
        let got: Vec<MicromapState> = centres
            .iter()
            .map(|&(u, v)| two.state(0, u as f32, v as f32))
            .collect();
        assert_eq!(got, vec![Opaque, Transparent, Opaque, Transparent]);
        let four = MicromapArrayData {
            micromaps: vec![OpacityMicromapDesc {
                byte_offset: 1,
                subdivision_level: 1,
                format: OpacityMicromapFormat::FourState,
            }],
            data: vec![0xFF, 0b11_10_01_00],
        };
        let got: Vec<MicromapState> = centres
            .iter()
            .map(|&(u, v)| four.state(0, u as f32, v as f32))
            .collect();
        assert_eq!(
            got,
            vec![Transparent, Opaque, UnknownTransparent, UnknownOpaque]
        );
        assert_eq!(four.state(-1, 0.1, 0.1), Transparent);
        assert_eq!(four.state(-2, 0.1, 0.1), Opaque);
        assert_eq!(four.state(-3, 0.1, 0.1), UnknownTransparent);
        assert_eq!(four.state(-4, 0.1, 0.1), UnknownOpaque);
    }
}
