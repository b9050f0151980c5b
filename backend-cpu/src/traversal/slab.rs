//! The ray/box slab test.
//!
//! `entry = max(tmin, near distances)`, `exit = min(tmax, far distances)`, hit when
//! `entry <= exit`, where a far distance is `(far − o) · inv_far`, the reciprocal times the
//! exit scale `s` ([`PreparedRay::inv_far`]: `1 + 2γ(3)` for the conservative test, 1 for the
//! plain one), rounded once per ray. A NaN distance arises only
//! from `0 · ∞`, an origin exactly on a slab plane of a ray parallel to it; the comparisons
//! below ignore it, so such a ray counts as inside the slab (boxes are closed), the same for
//! `+0.0` and `-0.0` directions.

use super::ray::{PreparedRay, WideRay, far_reciprocal};
use super::simd::F4;
use crate::accel::wide::{NODE_WIDTH, WideNode};

/// The entry distance of the ray into the box `[min, max]` within `[tmin, tmax]`, or
/// `None` on a miss.
#[inline(always)]
pub fn entry(
    ray: &PreparedRay,
    min: &[f32; 3],
    max: &[f32; 3],
    tmin: f32,
    tmax: f32,
) -> Option<f32> {
    let constants = [ray.origin, ray.inv, ray.inv_far];
    entry_with(constants, ray.negative, [min, max], [tmin, tmax])
}

/// [`entry`] for a [`WideRay`], conservative or not: the arithmetic of each lane of the node
/// tests, in scalar form (the reference the tests hold the node tests and
/// `traversal::misses_bounds` to).
#[cfg(test)]
pub fn entry_wide(
    ray: &WideRay,
    conservative: bool,
    min: &[f32; 3],
    max: &[f32; 3],
    tmin: f32,
    tmax: f32,
) -> Option<f32> {
    let inv_far = super::ray::far_reciprocal(ray.inv1, conservative);
    let constants = [ray.origin1, ray.inv1, inv_far];
    entry_with(constants, ray.negative, [min, max], [tmin, tmax])
}

#[inline(always)]
fn entry_with(
    [origin, inv, inv_far]: [[f32; 3]; 3],
    negative: [bool; 3],
    [min, max]: [&[f32; 3]; 2],
    [tmin, tmax]: [f32; 2],
) -> Option<f32> {
    // The exit starts at `tmax` (never widened) and each far distance comes out widened.
    let mut t0 = tmin;
    let mut t1 = tmax;
    for a in 0..3 {
        let (near, far) = if negative[a] {
            (max[a], min[a])
        } else {
            (min[a], max[a])
        };
        let tn = (near - origin[a]) * inv[a];
        let tf = (far - origin[a]) * inv_far[a];
        // `x > t0` is false for NaN: a NaN distance does not constrain the interval.
        t0 = if tn > t0 { tn } else { t0 };
        t1 = if tf < t1 { tf } else { t1 };
    }
    // Widening the far distances (not the ray's tmax) makes the test conservative; a
    // negative one only grows more negative, so boxes behind the origin still miss.
    if t0 <= t1 { Some(t0) } else { None }
}

/// The slab test of a wide node's eight children at once, lane by lane the arithmetic of
/// [`entry`]: the mask of the children the ray enters (bit `i` for child `i`) and their
/// entry distances. Two forms, bit for bit the same ([`Halves`] on every CPU, [`Avx`] where
/// the CPU has AVX); a walk uses one for all its nodes.
///
/// The conservative widening (or none) is in the far reciprocals `new` prepares once per
/// ray: no node test multiplies by it.
pub trait NodeTest: Copy {
    /// Tests `node`'s children within `[tmin, tmax]` (`tmin` as given when prepared).
    fn entry(&self, node: &WideNode, tmax: f32) -> (u32, [f32; NODE_WIDTH]);
}

/// Per axis, the row of [`WideNode::rows`] holding the near planes and the one holding the
/// far planes for a ray's direction signs: chosen once per ray, not per node, and kept as
/// byte offsets into the node (an index would be scaled by the row's size at every load: six
/// shifts a node).
#[derive(Clone, Copy)]
struct NearFar {
    near: [usize; 3],
    far: [usize; 3],
}

/// The bytes of one row of [`WideNode::rows`].
const ROW_BYTES: usize = std::mem::size_of::<[f32; NODE_WIDTH]>();

impl NearFar {
    #[inline(always)]
    fn of(ray: &WideRay) -> NearFar {
        // Byte by byte (`traversal::words`): the flags were stored one by one moments ago,
        // and a wider load would wait for all of them.
        let negative = super::words(&ray.negative).map(usize::from);
        NearFar {
            near: std::array::from_fn(|a| (a + 3 * negative[a]) * ROW_BYTES),
            far: std::array::from_fn(|a| (a + 3 - 3 * negative[a]) * ROW_BYTES),
        }
    }

    /// The row of `node` at byte offset `offset` (one of `near` and `far`).
    #[inline(always)]
    fn row(node: &WideNode, offset: usize) -> &[f32; NODE_WIDTH] {
        debug_assert!(offset.is_multiple_of(ROW_BYTES) && offset < 6 * ROW_BYTES);
        // SAFETY: `offset` is one that `of` made: `row * ROW_BYTES` for a row below six
        // (`a < 3` and a flag of 0 or 1), and the first six rows of a node are its boxes
        // (`WideNode::rows`), so this is a whole row of the node.
        unsafe {
            &*std::ptr::from_ref(node.rows())
                .cast::<u8>()
                .add(offset)
                .cast::<[f32; NODE_WIDTH]>()
        }
    }
}

/// The 8-lane node test as two 4-lane halves (SSE on x86-64, arrays elsewhere).
#[derive(Clone, Copy)]
pub struct Halves {
    origin: [F4; 3],
    inv: [F4; 3],
    inv_far: [F4; 3],
    tmin: F4,
    near_far: NearFar,
}

impl Halves {
    /// The test's constants for `ray` from `tmin`, conservative (widened far distances,
    /// `ray::far_reciprocal`) or not.
    #[inline(always)]
    pub fn new(ray: &WideRay, tmin: f32, conservative: bool) -> Halves {
        let [origin, inv] = ray.box_constants();
        Halves {
            origin: origin.map(F4::splat),
            inv: inv.map(F4::splat),
            inv_far: far_reciprocal(inv, conservative).map(F4::splat),
            tmin: F4::splat(tmin),
            near_far: NearFar::of(ray),
        }
    }
}

impl NodeTest for Halves {
    #[inline(always)]
    fn entry(&self, node: &WideNode, tmax: f32) -> (u32, [f32; NODE_WIDTH]) {
        let tmax = F4::splat(tmax);
        let mut mask = 0;
        let mut entry = [0.0; NODE_WIDTH];
        for half in 0..2 {
            let mut t0 = self.tmin;
            let mut t1 = tmax;
            for a in 0..3 {
                let near = F4::load_half(NearFar::row(node, self.near_far.near[a]), half);
                let far = F4::load_half(NearFar::row(node, self.near_far.far[a]), half);
                let tn = (near - self.origin[a]) * self.inv[a];
                let tf = (far - self.origin[a]) * self.inv_far[a];
                t0 = tn.max(t0);
                t1 = tf.min(t1);
            }
            mask |= t0.le(t1).bits() << (4 * half);
            entry[4 * half..4 * half + 4].copy_from_slice(&t0.to_array());
        }
        (mask, entry)
    }
}

#[cfg(target_arch = "x86_64")]
pub use avx::{Avx, has_avx};

#[cfg(target_arch = "x86_64")]
mod avx {
    use super::{NearFar, NodeTest, WideNode, WideRay, far_reciprocal};
    use crate::accel::wide::NODE_WIDTH;
    use std::arch::x86_64::*;

    /// Whether this CPU runs [`Avx`] and the bit-counting instructions (`popcnt`, `lzcnt`,
    /// `tzcnt`) the walk around it is compiled with: detected once, then one load (every
    /// trace asks; four feature lookups cost ~15 instructions a ray).
    #[inline(always)]
    pub fn has_avx() -> bool {
        use std::sync::atomic::{AtomicU8, Ordering};
        // 0: not detected yet, 1: no, 2: yes.
        static DETECTED: AtomicU8 = AtomicU8::new(0);
        match DETECTED.load(Ordering::Relaxed) {
            0 => {
                let has = detect_avx();
                DETECTED.store(1 + has as u8, Ordering::Relaxed);
                has
            }
            known => known == 2,
        }
    }

    #[cold]
    fn detect_avx() -> bool {
        use std::arch::is_x86_feature_detected as has;
        has!("avx") && has!("popcnt") && has!("lzcnt") && has!("bmi1")
    }

    /// The 8-lane node test in one AVX register per row. Its operations are the 4-lane
    /// ones' (`vmaxps`/`vminps` select as `maxps`/`minps` do, NaN included; `_CMP_LE_OQ`
    /// is `cmpleps`), so every lane computes what [`super::Halves`] computes.
    #[derive(Clone, Copy)]
    pub struct Avx {
        origin: [__m256; 3],
        inv: [__m256; 3],
        inv_far: [__m256; 3],
        tmin: __m256,
        near_far: NearFar,
    }

    impl Avx {
        /// The test's constants for `ray` from `tmin`, conservative or not, with `ray`'s box
        /// constants (`WideRay::box_constants`: origin, reciprocal) given as values: the
        /// walk's caller still holds them in registers (`engine::walk_wide_avx`), so only
        /// the direction signs are read from `ray`.
        ///
        /// # Safety
        ///
        /// The CPU has AVX (an `Avx` exists only where its instructions run).
        #[inline(always)]
        pub unsafe fn new(
            ray: &WideRay,
            [origin, inv]: [[f32; 3]; 2],
            tmin: f32,
            conservative: bool,
        ) -> Avx {
            // SAFETY: the caller promises AVX.
            unsafe {
                Avx {
                    origin: origin.map(|x| _mm256_set1_ps(x)),
                    inv: inv.map(|x| _mm256_set1_ps(x)),
                    inv_far: far_reciprocal(inv, conservative).map(|x| _mm256_set1_ps(x)),
                    tmin: _mm256_set1_ps(tmin),
                    near_far: NearFar::of(ray),
                }
            }
        }
    }

    impl NodeTest for Avx {
        #[inline(always)]
        fn entry(&self, node: &WideNode, tmax: f32) -> (u32, [f32; NODE_WIDTH]) {
            let mut entry = [0.0; NODE_WIDTH];
            // SAFETY: an `Avx` exists only where the CPU has AVX (`Avx::new`); the loads
            // read whole rows of the node (32 bytes each), the store the 32-byte `entry`.
            let mask = unsafe {
                let mut t0 = self.tmin;
                let mut t1 = _mm256_set1_ps(tmax);
                for a in 0..3 {
                    let near = NearFar::row(node, self.near_far.near[a]).as_ptr();
                    let far = NearFar::row(node, self.near_far.far[a]).as_ptr();
                    let (near, far) = (_mm256_loadu_ps(near), _mm256_loadu_ps(far));
                    let tn = _mm256_mul_ps(_mm256_sub_ps(near, self.origin[a]), self.inv[a]);
                    let tf = _mm256_mul_ps(_mm256_sub_ps(far, self.origin[a]), self.inv_far[a]);
                    t0 = _mm256_max_ps(tn, t0);
                    t1 = _mm256_min_ps(tf, t1);
                }
                _mm256_storeu_ps(entry.as_mut_ptr(), t0);
                _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(t0, t1)) as u32
            };
            (mask, entry)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::traversal::tests::Rng;

    #[test]
    fn node_tests_agree_with_the_scalar_test_bit_for_bit() {
        let mut rng = Rng(99);
        let mut rnd = || rng.f();
        let specials = [0.0, -0.0, 1.0, f32::INFINITY, f32::NEG_INFINITY];
        #[cfg(target_arch = "x86_64")]
        let mut avx_checked = 0;
        for i in 0..20000 {
            let mut node = WideNode::EMPTY;
            for lane in 0..NODE_WIDTH {
                for a in 0..3 {
                    let lo = (rnd() - 0.5) * 10.0;
                    node.min[a][lane] = lo;
                    node.max[a][lane] = lo + rnd() * 4.0;
                }
            }
            // Unused children: the empty box, in a lane of either half.
            let unused = i % 8;
            if i % 7 == 0 {
                for a in 0..3 {
                    node.min[a][unused] = f32::INFINITY;
                    node.max[a][unused] = f32::NEG_INFINITY;
                }
            }
            let mut o = [
                (rnd() - 0.5) * 20.0,
                (rnd() - 0.5) * 20.0,
                (rnd() - 0.5) * 20.0,
            ];
            let mut d = [rnd() - 0.5, rnd() - 0.5, rnd() - 0.5];
            if i % 3 == 0 {
                // Axis-parallel rays, origins on slab planes: the NaN cases.
                d[i % 2] = specials[i % 2];
                o[(i / 3) % 3] = node.min[(i / 3) % 3][i % NODE_WIDTH];
            }
            let (tmin, tmax) = if i % 5 == 0 {
                (2.0, 3.0)
            } else {
                (0.0, f32::INFINITY)
            };
            for conservative in [false, true] {
                let r = PreparedRay::new(o, d, conservative);
                let wide = WideRay::of(&r);
                let (mask, t) = Halves::new(&wide, tmin, conservative).entry(&node, tmax);
                for (lane, &entered) in t.iter().enumerate() {
                    let min = std::array::from_fn(|a| node.min[a][lane]);
                    let max = std::array::from_fn(|a| node.max[a][lane]);
                    let want = entry(&r, &min, &max, tmin, tmax);
                    let got = (mask >> lane & 1 == 1).then_some(entered);
                    assert_eq!(
                        want.map(f32::to_bits),
                        got.map(f32::to_bits),
                        "{o:?} {d:?} lane {lane}"
                    );
                }
                assert_eq!(
                    mask >> unused & (i % 7 == 0) as u32,
                    0,
                    "empty boxes are never entered"
                );
                #[cfg(target_arch = "x86_64")]
                if has_avx() {
                    // SAFETY: the CPU has AVX.
                    let avx = unsafe { Avx::new(&wide, wide.box_constants(), tmin, conservative) };
                    let (avx_mask, avx_t) = avx.entry(&node, tmax);
                    assert_eq!(avx_mask, mask, "{o:?} {d:?}");
                    assert_eq!(avx_t.map(f32::to_bits), t.map(f32::to_bits), "{o:?} {d:?}");
                    avx_checked += 1;
                }
            }
        }
        // Says in the test output whether this machine checked the AVX form too.
        #[cfg(target_arch = "x86_64")]
        println!("AVX node test checked against the halves on {avx_checked} rays");
    }

    const BOX_MIN: [f32; 3] = [10.0, 0.0, 0.0];
    const BOX_MAX: [f32; 3] = [10.0, 1.0, 1.0];

    fn both(o: [f32; 3], d: [f32; 3], tmin: f32, tmax: f32) -> [Option<f32>; 2] {
        [false, true].map(|c| entry(&PreparedRay::new(o, d, c), &BOX_MIN, &BOX_MAX, tmin, tmax))
    }

    #[test]
    fn signed_zero_directions_agree() {
        for o in [
            [0.0, 1.0, 0.5],
            [0.0, 0.0, 0.5],
            [0.0, 0.5, 0.5],
            [0.0, 1.5, 0.5],
            [0.0, 1.0, 1.0],
        ] {
            for pair in [
                ([1.0, 0.0, 0.0], [1.0, -0.0, 0.0]),
                ([1.0, 0.0, -0.0], [1.0, -0.0, 0.0]),
            ] {
                assert_eq!(
                    both(o, pair.0, 0.0, f32::INFINITY),
                    both(o, pair.1, 0.0, f32::INFINITY),
                    "origin {o:?}"
                );
            }
        }
    }

    #[test]
    fn origin_on_slab_plane_of_parallel_ray_is_inside() {
        // The case obvhs misses (docs/numerics.md F4): origin on the y = 1 plane, d.y = ±0.
        for d in [[1.0, 0.0, 0.0], [1.0, -0.0, 0.0]] {
            assert_eq!(
                both([0.0, 1.0, 0.5], d, 0.0, f32::INFINITY),
                [Some(10.0), Some(10.0)]
            );
            assert_eq!(both([0.0, 0.0, 0.0], d, 0.0, f32::INFINITY)[0], Some(10.0));
        }
        assert_eq!(
            both([0.0, 1.0000001, 0.5], [1.0, 0.0, 0.0], 0.0, f32::INFINITY),
            [None, None]
        );
    }

    #[test]
    fn widening_constant_is_at_least_two_gamma_three() {
        let eps = 2.0f64.powi(-24);
        let gamma3 = 3.0 * eps / (1.0 - 3.0 * eps);
        assert!(crate::traversal::SLAB_WIDENING as f64 >= 1.0 + 2.0 * gamma3);
        assert!((crate::traversal::SLAB_WIDENING as f64) < 1.0 + 4.0 * gamma3);
    }

    #[test]
    fn near_parallel_ray_one_ulp_inside_hits() {
        // docs/numerics.md F3: d.y = 1e-9 travelling just inside the y = 1 face.
        let o = [0.0, 1.0 - f32::EPSILON / 2.0, 0.5];
        assert!(
            both(o, [1.0, 1e-9, 0.0], 0.0, f32::INFINITY)
                .iter()
                .all(|e| e.is_some())
        );
    }

    #[test]
    fn interval_bounds_are_inclusive() {
        assert!(
            both([0.0, 0.5, 0.5], [1.0, 0.0, 0.0], 0.0, 10.0)
                .iter()
                .all(|e| e.is_some())
        );
        assert!(
            both([0.0, 0.5, 0.5], [1.0, 0.0, 0.0], 10.0, 20.0)
                .iter()
                .all(|e| e.is_some())
        );
        assert_eq!(both([0.0, 0.5, 0.5], [1.0, 0.0, 0.0], 0.0, 9.99)[0], None);
        assert_eq!(both([0.0, 0.5, 0.5], [1.0, 0.0, 0.0], 10.01, 20.0)[1], None);
        // A box behind the origin misses.
        assert_eq!(
            both([20.0, 0.5, 0.5], [1.0, 0.0, 0.0], 0.0, f32::INFINITY),
            [None, None]
        );
    }

    #[test]
    fn conservative_test_keeps_grazing_boxes_plain_may_lose() {
        // Rays aimed at the far corner region of a thin box: the conservative test must
        // report every box that the exact (f64) test hits.
        let mut rng = Rng(12345);
        let mut rnd = || rng.f();
        for _ in 0..20000 {
            let min = [
                rnd() * 100.0 - 50.0,
                rnd() * 100.0 - 50.0,
                rnd() * 100.0 - 50.0,
            ];
            let max = [min[0] + rnd() * 1e-3, min[1] + rnd(), min[2] + rnd() * 10.0];
            let o = [
                rnd() * 1e3 - 500.0,
                rnd() * 1e3 - 500.0,
                rnd() * 1e3 - 500.0,
            ];
            let target = [
                min[0] + (max[0] - min[0]) * rnd(),
                max[1],
                min[2] + (max[2] - min[2]) * rnd(),
            ];
            let d = [target[0] - o[0], target[1] - o[1], target[2] - o[2]];
            // Exact test in f64 on the same f32 inputs.
            let (mut t0, mut t1) = (0.0f64, f64::INFINITY);
            for a in 0..3 {
                let inv = 1.0 / d[a] as f64;
                let (p, q) = (
                    (min[a] as f64 - o[a] as f64) * inv,
                    (max[a] as f64 - o[a] as f64) * inv,
                );
                t0 = t0.max(p.min(q));
                t1 = t1.min(p.max(q));
            }
            if t0 <= t1 {
                let r = PreparedRay::new(o, d, true);
                assert!(
                    entry(&r, &min, &max, 0.0, f32::INFINITY).is_some(),
                    "false miss: {o:?} {d:?} {min:?} {max:?}"
                );
            }
        }
    }
}
