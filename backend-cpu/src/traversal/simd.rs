//! Four f32 lanes ([`F4`]: SSE on x86-64, always present there, plain arrays elsewhere),
//! and eight ([`F8`]: AVX, x86-64 only, for code that runs where the CPU has AVX).
//!
//! Only what the box and triangle tests need (the 8-lane box test runs as two halves
//! where it does not run on AVX, `slab::Halves`). Every operation is the IEEE operation
//! of the scalar code lane by lane, in the same order (no fused multiply-add), so a lane of
//! a 4-wide test computes bit for bit what the scalar test computes. `min` and `max` are the
//! scalar code's selections, NaN included: `a.min(b)` is `if a < b { a } else { b }` and
//! `a.max(b)` is `if a > b { a } else { b }` (SSE's `minps`/`maxps` behave exactly so).
//!
//! [`Lanes`] is what the block triangle tests are written in, so that one test serves one
//! block ([`F4`]) and two blocks at once ([`F8`]) with the same arithmetic per lane.

use std::ops::{Add, BitAnd, BitOr, Div, Mul, Sub};

/// Lanes of f32 with the scalar code's IEEE operations, and their comparisons as masks.
pub trait Lanes:
    Copy + Add<Output = Self> + Sub<Output = Self> + Mul<Output = Self> + Div<Output = Self>
{
    /// The lanes as an array.
    type Array: Copy + Default + AsRef<[f32]> + AsMut<[f32]>;
    /// One mask per lane (all ones or all zeros).
    type Mask: Copy + BitAnd<Output = Self::Mask> + BitOr<Output = Self::Mask>;
    /// The number of lanes.
    const N: usize;
    /// The same value in every lane.
    fn splat(x: f32) -> Self;
    /// Lanes from an array.
    fn from_array(a: &Self::Array) -> Self;
    /// The lanes as an array.
    fn to_array(self) -> Self::Array;
    /// `self < b`.
    fn lt(self, b: Self) -> Self::Mask;
    /// `self <= b`.
    fn le(self, b: Self) -> Self::Mask;
    /// `self > b`.
    fn gt(self, b: Self) -> Self::Mask;
    /// `self == b`.
    fn eq(self, b: Self) -> Self::Mask;
    /// Per lane `if self < b { self } else { b }` (as SSE's `minps`).
    fn min(self, b: Self) -> Self;
    /// Per lane `if self > b { self } else { b }` (as SSE's `maxps`).
    fn max(self, b: Self) -> Self;
    /// Lane `i` set is bit `i`.
    fn bits(m: Self::Mask) -> u32;
}

impl Lanes for F4 {
    type Array = [f32; 4];
    type Mask = imp::M4;
    const N: usize = 4;
    #[inline(always)]
    fn splat(x: f32) -> F4 {
        F4::splat(x)
    }
    #[inline(always)]
    fn from_array(a: &[f32; 4]) -> F4 {
        F4::load(a)
    }
    #[inline(always)]
    fn to_array(self) -> [f32; 4] {
        F4::to_array(self)
    }
    #[inline(always)]
    fn lt(self, b: F4) -> imp::M4 {
        F4::lt(self, b)
    }
    #[inline(always)]
    fn le(self, b: F4) -> imp::M4 {
        F4::le(self, b)
    }
    #[inline(always)]
    fn gt(self, b: F4) -> imp::M4 {
        F4::gt(self, b)
    }
    #[inline(always)]
    fn eq(self, b: F4) -> imp::M4 {
        F4::eq(self, b)
    }
    #[inline(always)]
    fn min(self, b: F4) -> F4 {
        F4::min(self, b)
    }
    #[inline(always)]
    fn max(self, b: F4) -> F4 {
        F4::max(self, b)
    }
    #[inline(always)]
    fn bits(m: imp::M4) -> u32 {
        m.bits()
    }
}

// SAFETY (every `unsafe` in `imp` for x86-64): SSE and SSE2 are part of the x86-64
// baseline, so these intrinsics are always available; loads and stores go through arrays
// of the right size.
#[cfg(target_arch = "x86_64")]
mod imp {
    use std::arch::x86_64::*;

    /// Four f32 lanes.
    #[derive(Clone, Copy)]
    pub struct F4(__m128);

    /// Four lane masks (all ones or all zeros per lane).
    #[derive(Clone, Copy)]
    pub struct M4(__m128);

    impl F4 {
        /// Four lanes from an array.
        #[inline(always)]
        pub fn load(a: &[f32; 4]) -> F4 {
            // SAFETY: `a` is 16 readable bytes; the load is unaligned.
            F4(unsafe { _mm_loadu_ps(a.as_ptr()) })
        }

        /// Lanes `4 * half ..` of an 8-lane row (`half` 0 or 1).
        #[inline(always)]
        pub fn load_half(a: &[f32; 8], half: usize) -> F4 {
            // SAFETY: `4 * (half & 1) + 4 <= 8`: 16 readable bytes; the load is unaligned.
            F4(unsafe { _mm_loadu_ps(a.as_ptr().add(4 * (half & 1))) })
        }

        /// The same value in every lane.
        #[inline(always)]
        pub fn splat(x: f32) -> F4 {
            F4(unsafe { _mm_set1_ps(x) })
        }

        /// The lanes as an array.
        #[inline(always)]
        pub fn to_array(self) -> [f32; 4] {
            let mut out = [0.0; 4];
            // SAFETY: `out` is 16 writable bytes; the store is unaligned.
            unsafe { _mm_storeu_ps(out.as_mut_ptr(), self.0) };
            out
        }

        /// `if self < b { self } else { b }` per lane.
        #[inline(always)]
        pub fn min(self, b: F4) -> F4 {
            F4(unsafe { _mm_min_ps(self.0, b.0) })
        }

        /// `if self > b { self } else { b }` per lane.
        #[inline(always)]
        pub fn max(self, b: F4) -> F4 {
            F4(unsafe { _mm_max_ps(self.0, b.0) })
        }

        /// `self < b`.
        #[inline(always)]
        pub fn lt(self, b: F4) -> M4 {
            M4(unsafe { _mm_cmplt_ps(self.0, b.0) })
        }

        /// `self <= b`.
        #[inline(always)]
        pub fn le(self, b: F4) -> M4 {
            M4(unsafe { _mm_cmple_ps(self.0, b.0) })
        }

        /// `self > b`.
        #[inline(always)]
        pub fn gt(self, b: F4) -> M4 {
            M4(unsafe { _mm_cmpgt_ps(self.0, b.0) })
        }

        /// `self == b`.
        #[inline(always)]
        pub fn eq(self, b: F4) -> M4 {
            M4(unsafe { _mm_cmpeq_ps(self.0, b.0) })
        }

        /// Per lane, `a` where `mask` is set, else `b` (no branch).
        #[inline(always)]
        pub fn select(mask: M4, a: F4, b: F4) -> F4 {
            F4(unsafe { _mm_or_ps(_mm_and_ps(mask.0, a.0), _mm_andnot_ps(mask.0, b.0)) })
        }
    }

    impl std::ops::Add for F4 {
        type Output = F4;
        #[inline(always)]
        fn add(self, b: F4) -> F4 {
            F4(unsafe { _mm_add_ps(self.0, b.0) })
        }
    }

    impl std::ops::Sub for F4 {
        type Output = F4;
        #[inline(always)]
        fn sub(self, b: F4) -> F4 {
            F4(unsafe { _mm_sub_ps(self.0, b.0) })
        }
    }

    impl std::ops::Mul for F4 {
        type Output = F4;
        #[inline(always)]
        fn mul(self, b: F4) -> F4 {
            F4(unsafe { _mm_mul_ps(self.0, b.0) })
        }
    }

    impl std::ops::Div for F4 {
        type Output = F4;
        #[inline(always)]
        fn div(self, b: F4) -> F4 {
            F4(unsafe { _mm_div_ps(self.0, b.0) })
        }
    }

    impl M4 {
        /// Lane `i` set is bit `i`.
        #[inline(always)]
        pub fn bits(self) -> u32 {
            unsafe { _mm_movemask_ps(self.0) as u32 }
        }
    }

    impl std::ops::BitAnd for M4 {
        type Output = M4;
        #[inline(always)]
        fn bitand(self, b: M4) -> M4 {
            M4(unsafe { _mm_and_ps(self.0, b.0) })
        }
    }

    impl std::ops::BitOr for M4 {
        type Output = M4;
        #[inline(always)]
        fn bitor(self, b: M4) -> M4 {
            M4(unsafe { _mm_or_ps(self.0, b.0) })
        }
    }

    /// Eight f32 lanes (AVX).
    ///
    /// Every operation runs AVX instructions: values of this type exist only in code that
    /// runs where the CPU has AVX (the block tests of `Walker::leaf_blocks_avx`, entered
    /// after `slab::has_avx`); [`F8::pair`] and [`F8::from_f4`] say so in their contracts,
    /// and debug builds check it where values are made from scalars.
    #[derive(Clone, Copy)]
    pub struct F8(__m256);

    /// Eight lane masks (all ones or all zeros per lane).
    #[derive(Clone, Copy)]
    pub struct M8(__m256);

    /// Debug builds: the CPU has AVX (the contract of every way to make an [`F8`]).
    #[inline(always)]
    fn debug_check_avx() {
        debug_assert!(std::arch::is_x86_feature_detected!("avx"));
    }

    impl F8 {
        /// Lanes 0–3 from `low`, 4–7 from `high`.
        ///
        /// # Safety
        /// The CPU has AVX.
        #[inline(always)]
        pub unsafe fn pair(low: &[f32; 4], high: &[f32; 4]) -> F8 {
            debug_check_avx();
            // SAFETY: AVX by the contract; 16 readable bytes each, unaligned loads.
            F8(unsafe { _mm256_loadu2_m128(high.as_ptr(), low.as_ptr()) })
        }

        /// `x` in both halves.
        ///
        /// # Safety
        /// The CPU has AVX.
        #[inline(always)]
        pub unsafe fn from_f4(x: F4) -> F8 {
            debug_check_avx();
            // SAFETY: AVX by the contract.
            F8(unsafe { _mm256_set_m128(x.0, x.0) })
        }
    }

    // SAFETY (every `unsafe` below): an `F8` exists only where the CPU has AVX (above).
    impl super::Lanes for F8 {
        type Array = [f32; 8];
        type Mask = M8;
        const N: usize = 8;
        #[inline(always)]
        fn splat(x: f32) -> F8 {
            debug_check_avx();
            F8(unsafe { _mm256_set1_ps(x) })
        }
        #[inline(always)]
        fn from_array(a: &[f32; 8]) -> F8 {
            debug_check_avx();
            // 32 readable bytes, unaligned load.
            F8(unsafe { _mm256_loadu_ps(a.as_ptr()) })
        }
        #[inline(always)]
        fn to_array(self) -> [f32; 8] {
            let mut out = [0.0; 8];
            // 32 writable bytes, unaligned store.
            unsafe { _mm256_storeu_ps(out.as_mut_ptr(), self.0) };
            out
        }
        // The ordered, non-signalling predicates: false for NaN, as SSE's `cmpltps` and
        // the scalar comparisons.
        #[inline(always)]
        fn lt(self, b: F8) -> M8 {
            M8(unsafe { _mm256_cmp_ps::<_CMP_LT_OQ>(self.0, b.0) })
        }
        #[inline(always)]
        fn le(self, b: F8) -> M8 {
            M8(unsafe { _mm256_cmp_ps::<_CMP_LE_OQ>(self.0, b.0) })
        }
        #[inline(always)]
        fn gt(self, b: F8) -> M8 {
            M8(unsafe { _mm256_cmp_ps::<_CMP_GT_OQ>(self.0, b.0) })
        }
        #[inline(always)]
        fn eq(self, b: F8) -> M8 {
            M8(unsafe { _mm256_cmp_ps::<_CMP_EQ_OQ>(self.0, b.0) })
        }
        // `vminps`/`vmaxps` return the second operand where either lane is NaN, as
        // `minps`/`maxps` and the scalar selections do.
        #[inline(always)]
        fn min(self, b: F8) -> F8 {
            F8(unsafe { _mm256_min_ps(self.0, b.0) })
        }
        #[inline(always)]
        fn max(self, b: F8) -> F8 {
            F8(unsafe { _mm256_max_ps(self.0, b.0) })
        }
        #[inline(always)]
        fn bits(m: M8) -> u32 {
            unsafe { _mm256_movemask_ps(m.0) as u32 }
        }
    }

    impl std::ops::Add for F8 {
        type Output = F8;
        #[inline(always)]
        fn add(self, b: F8) -> F8 {
            F8(unsafe { _mm256_add_ps(self.0, b.0) })
        }
    }

    impl std::ops::Sub for F8 {
        type Output = F8;
        #[inline(always)]
        fn sub(self, b: F8) -> F8 {
            F8(unsafe { _mm256_sub_ps(self.0, b.0) })
        }
    }

    impl std::ops::Mul for F8 {
        type Output = F8;
        #[inline(always)]
        fn mul(self, b: F8) -> F8 {
            F8(unsafe { _mm256_mul_ps(self.0, b.0) })
        }
    }

    impl std::ops::Div for F8 {
        type Output = F8;
        #[inline(always)]
        fn div(self, b: F8) -> F8 {
            F8(unsafe { _mm256_div_ps(self.0, b.0) })
        }
    }

    impl std::ops::BitAnd for M8 {
        type Output = M8;
        #[inline(always)]
        fn bitand(self, b: M8) -> M8 {
            M8(unsafe { _mm256_and_ps(self.0, b.0) })
        }
    }

    impl std::ops::BitOr for M8 {
        type Output = M8;
        #[inline(always)]
        fn bitor(self, b: M8) -> M8 {
            M8(unsafe { _mm256_or_ps(self.0, b.0) })
        }
    }
}

#[cfg(not(target_arch = "x86_64"))]
mod imp {
    /// Four f32 lanes.
    #[derive(Clone, Copy)]
    pub struct F4([f32; 4]);

    /// Four lane masks.
    #[derive(Clone, Copy)]
    pub struct M4([bool; 4]);

    impl F4 {
        /// Four lanes from an array.
        #[inline(always)]
        pub fn load(a: &[f32; 4]) -> F4 {
            F4(*a)
        }

        /// Lanes `4 * half ..` of an 8-lane row (`half` 0 or 1).
        #[inline(always)]
        pub fn load_half(a: &[f32; 8], half: usize) -> F4 {
            F4(std::array::from_fn(|i| a[4 * (half & 1) + i]))
        }

        /// The same value in every lane.
        #[inline(always)]
        pub fn splat(x: f32) -> F4 {
            F4([x; 4])
        }

        /// The lanes as an array.
        #[inline(always)]
        pub fn to_array(self) -> [f32; 4] {
            self.0
        }

        #[inline(always)]
        fn zip(self, b: F4, f: impl Fn(f32, f32) -> f32) -> F4 {
            F4(std::array::from_fn(|i| f(self.0[i], b.0[i])))
        }

        #[inline(always)]
        fn test(self, b: F4, f: impl Fn(f32, f32) -> bool) -> M4 {
            M4(std::array::from_fn(|i| f(self.0[i], b.0[i])))
        }

        /// `if self < b { self } else { b }` per lane.
        #[inline(always)]
        pub fn min(self, b: F4) -> F4 {
            self.zip(b, |x, y| if x < y { x } else { y })
        }

        /// `if self > b { self } else { b }` per lane.
        #[inline(always)]
        pub fn max(self, b: F4) -> F4 {
            self.zip(b, |x, y| if x > y { x } else { y })
        }

        /// `self < b`.
        #[inline(always)]
        pub fn lt(self, b: F4) -> M4 {
            self.test(b, |x, y| x < y)
        }

        /// `self <= b`.
        #[inline(always)]
        pub fn le(self, b: F4) -> M4 {
            self.test(b, |x, y| x <= y)
        }

        /// `self > b`.
        #[inline(always)]
        pub fn gt(self, b: F4) -> M4 {
            self.test(b, |x, y| x > y)
        }

        /// `self == b`.
        #[inline(always)]
        pub fn eq(self, b: F4) -> M4 {
            self.test(b, |x, y| x == y)
        }

        /// Per lane, `a` where `mask` is set, else `b`.
        #[inline(always)]
        pub fn select(mask: M4, a: F4, b: F4) -> F4 {
            F4(std::array::from_fn(
                |i| if mask.0[i] { a.0[i] } else { b.0[i] },
            ))
        }
    }

    impl std::ops::Add for F4 {
        type Output = F4;
        #[inline(always)]
        fn add(self, b: F4) -> F4 {
            self.zip(b, |x, y| x + y)
        }
    }

    impl std::ops::Sub for F4 {
        type Output = F4;
        #[inline(always)]
        fn sub(self, b: F4) -> F4 {
            self.zip(b, |x, y| x - y)
        }
    }

    impl std::ops::Mul for F4 {
        type Output = F4;
        #[inline(always)]
        fn mul(self, b: F4) -> F4 {
            self.zip(b, |x, y| x * y)
        }
    }

    impl std::ops::Div for F4 {
        type Output = F4;
        #[inline(always)]
        fn div(self, b: F4) -> F4 {
            self.zip(b, |x, y| x / y)
        }
    }

    impl M4 {
        /// Lane `i` set is bit `i`.
        #[inline(always)]
        pub fn bits(self) -> u32 {
            self.0
                .iter()
                .enumerate()
                .fold(0, |acc, (i, &b)| acc | (b as u32) << i)
        }
    }

    impl std::ops::BitAnd for M4 {
        type Output = M4;
        #[inline(always)]
        fn bitand(self, b: M4) -> M4 {
            M4(std::array::from_fn(|i| self.0[i] & b.0[i]))
        }
    }

    impl std::ops::BitOr for M4 {
        type Output = M4;
        #[inline(always)]
        fn bitor(self, b: M4) -> M4 {
            M4(std::array::from_fn(|i| self.0[i] | b.0[i]))
        }
    }
}

pub use imp::F4;
#[cfg(target_arch = "x86_64")]
pub use imp::F8;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lanes_follow_the_scalar_selections_with_nan() {
        let nan = f32::NAN;
        let a = F4::load(&[1.0, nan, 3.0, -0.0]);
        let b = F4::load(&[2.0, 5.0, nan, 0.0]);
        let scalar_min = |x: f32, y: f32| if x < y { x } else { y };
        let scalar_max = |x: f32, y: f32| if x > y { x } else { y };
        let (aa, bb) = (a.to_array(), b.to_array());
        let min = a.min(b).to_array();
        let max = a.max(b).to_array();
        for i in 0..4 {
            assert_eq!(
                min[i].to_bits(),
                scalar_min(aa[i], bb[i]).to_bits(),
                "min {i}"
            );
            assert_eq!(
                max[i].to_bits(),
                scalar_max(aa[i], bb[i]).to_bits(),
                "max {i}"
            );
        }
        assert_eq!(a.lt(b).bits(), 0b0001);
        assert_eq!(a.le(b).bits(), 0b1001);
        assert_eq!(a.gt(b).bits(), 0b0000);
        assert_eq!(a.eq(b).bits(), 0b1000);
        assert_eq!((a.lt(b) | a.eq(b)).bits(), 0b1001);
        assert_eq!((a.le(b) & a.eq(b)).bits(), 0b1000);
        // `select` takes `a` in mask lanes, `b` elsewhere, NaN and signed zero kept as bits.
        let picked = F4::select(a.lt(b) | a.eq(b), a, b).to_array();
        let want = [1.0, 5.0, nan, -0.0];
        assert_eq!(picked.map(f32::to_bits)[..2], want.map(f32::to_bits)[..2]);
        assert!(picked[2].is_nan());
        assert_eq!(picked[3].to_bits(), (-0.0f32).to_bits());
        let q = (a * b + F4::splat(1.0) - b / F4::splat(2.0)).to_array();
        assert_eq!(q[0], 1.0 * 2.0 + 1.0 - 1.0);
        assert!(q[1].is_nan());
    }
}
