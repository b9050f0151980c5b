//! Motion transforms on Vulkan, which has none (DESIGN.md §3 lets a backend emulate them by a
//! faithful scheme it justifies; docs/vulkan-backend.md §2 has the reasons for this one).
//!
//! Every path through a motion transform gets a **proxy** bottom level: one AABB geometry per
//! SBT record of the geometry at its end, one box per primitive, in the same order as the
//! geometry's own Vulkan geometries. So the driver numbers primitives, geometries and SBT
//! records as for static geometry, and any-hit, `REQUIRE_SINGLE_ANYHIT_CALL` and the user's
//! intersection programs work unchanged. A proxy box bounds its primitive over every time:
//! the geometry's box (already a union over motion keys) carried through the path's
//! transforms below the motion transform, then through the motion transform, conservatively
//! ([`bound_static`], [`bound_matrix_motion`], [`bound_srt_motion`]).
//!
//! The path's transforms below its Vulkan instance form its **motion chain**, written to the
//! data table ([`chain_words`]); optik's stages compose it at the ray's time (device_api.rs:
//! `_optik_chain`, with the shared WGSL of `optik_api::wgsl::MOTION`) to carry the ray into
//! the geometry's space, and the object-space device functions apply it on top of Vulkan's
//! built-ins.

#[cfg(test)]
use optik_api::semantics::{affine, motion};
use optik_api::{Matrix3x4, MotionOptions, SrtData};

/// One transform of a motion chain.
#[derive(Clone, Debug, PartialEq)]
pub enum ChainLink {
    /// A fixed object-to-world transform (an instance's or a static transform's).
    Static(Matrix3x4),
    /// Matrix keys, interpolated linearly.
    Matrix(MotionOptions, Vec<Matrix3x4>),
    /// SRT keys, interpolated with nlerp.
    Srt(MotionOptions, Vec<SrtData>),
}

impl ChainLink {
    /// The link as the data-table words `_optik_chain` reads: `[kind, keys, flags, time
    /// begin, time end]` and the matrix or keys.
    fn words(&self, out: &mut Vec<u32>) {
        let header = |out: &mut Vec<u32>, kind: u32, m: &MotionOptions, keys: usize| {
            out.extend_from_slice(&[
                kind,
                keys as u32,
                m.flags.0,
                m.time_begin.to_bits(),
                m.time_end.to_bits(),
            ]);
        };
        match self {
            ChainLink::Static(m) => {
                out.extend_from_slice(&[0, 1, 0, 0, 0]);
                out.extend(m.iter().map(|v| v.to_bits()));
            }
            ChainLink::Matrix(options, keys) => {
                header(out, 1, options, keys.len());
                out.extend(keys.iter().flatten().map(|v| v.to_bits()));
            }
            ChainLink::Srt(options, keys) => {
                header(out, 2, options, keys.len());
                for k in keys {
                    let f: &[f32; 16] = bytemuck::cast_ref(k);
                    out.extend(f.iter().map(|v| v.to_bits()));
                }
            }
        }
    }

    /// Whether the link is a fixed transform.
    pub fn is_static(&self) -> bool {
        matches!(self, ChainLink::Static(_))
    }

    /// The link's object-to-world transform at `time` (key 0 when `time` is `None`, as for
    /// pipelines without motion); `None` when it vanishes then. (The host's reference for
    /// what `_optik_chain` computes.)
    #[cfg(test)]
    pub fn at(&self, time: Option<f32>) -> Option<Matrix3x4> {
        let position = |m: &MotionOptions| match time {
            Some(t) => motion::resolve_key(m, t),
            None => Some(motion::KeyPosition { key: 0, t: 0.0 }),
        };
        match self {
            ChainLink::Static(m) => Some(*m),
            ChainLink::Matrix(m, keys) => Some(motion::interpolate_matrix(keys, position(m)?)),
            ChainLink::Srt(m, keys) => Some(motion::srt_to_matrix(&motion::interpolate_srt(
                keys,
                position(m)?,
            ))),
        }
    }
}

/// A motion chain's data-table words: the link count, then the links, outermost first.
pub fn chain_words(links: &[ChainLink]) -> Vec<u32> {
    let mut out = vec![links.len() as u32];
    for l in links {
        l.words(&mut out);
    }
    out
}

/// An axis-aligned box `[min xyz, max xyz]`.
pub type Aabb = [f32; 6];

/// Relative padding of bounds carried through transforms: the products and sums of f32
/// transforms round by a few ε of the magnitudes involved (bounds are computed in f64 and
/// rounded outwards, then padded by this much of their own size and magnitude).
const PADDING: f64 = 1.0 / (1u64 << 20) as f64;

/// The box of f64 points, rounded outwards to f32 and padded.
fn padded_box(points: impl Iterator<Item = [f64; 3]>) -> Aabb {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in points {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let size = (0..3).map(|k| hi[k] - lo[k]).fold(0.0, f64::max);
    let mut b = [0.0f32; 6];
    for k in 0..3 {
        let pad = PADDING * (size + lo[k].abs().max(hi[k].abs()));
        b[k] = ((lo[k] - pad) as f32).next_down();
        b[k + 3] = ((hi[k] + pad) as f32).next_up();
    }
    b
}

/// The eight corners of a box, in f64.
fn corners(b: &Aabb) -> impl Iterator<Item = [f64; 3]> + '_ {
    (0..8).map(move |c| {
        std::array::from_fn(|k| {
            if c & (1 << k) == 0 {
                b[k] as f64
            } else {
                b[k + 3] as f64
            }
        })
    })
}

/// optik-accel's bound of `b` under a transform (the one every backend uses), with this
/// backend's proxy-box margin on top: the driver tests rays against the proxy boxes in its
/// own arithmetic, so they get the padding of [`padded_box`].
fn through_accel(b: &Aabb, bound: impl Fn(&optik_accel::Aabb) -> optik_accel::Aabb) -> Aabb {
    let out = bound(&optik_accel::Aabb::from_six(*b));
    if !out.is_usable() {
        return optik_accel::Aabb::EMPTY.to_six();
    }
    padded_box(corners(&out.to_six()))
}

/// A box carried through a fixed transform.
pub fn bound_static(m: &Matrix3x4, b: &Aabb) -> Aabb {
    through_accel(b, |c| c.transformed(m))
}

/// A box carried through matrix motion at every time (`optik_accel::matrix_motion_bounds`).
pub fn bound_matrix_motion(keys: &[Matrix3x4], b: &Aabb) -> Aabb {
    through_accel(b, |c| optik_accel::matrix_motion_bounds(keys, c))
}

/// A box carried through SRT motion at every time (`optik_accel::srt_motion_bounds`).
pub fn bound_srt_motion(keys: &[SrtData], b: &Aabb) -> Aabb {
    through_accel(b, |c| optik_accel::srt_motion_bounds(keys, c))
}

/// A box carried through a link at every time.
pub fn bound(link: &ChainLink, b: &Aabb) -> Aabb {
    if !b.iter().all(|v| v.is_finite()) {
        return *b;
    }
    match link {
        ChainLink::Static(m) => bound_static(m, b),
        ChainLink::Matrix(_, keys) => bound_matrix_motion(keys, b),
        ChainLink::Srt(_, keys) => bound_srt_motion(keys, b),
    }
}

/// The composed object-to-world transform of `links` at `time`, `None` when one vanishes.
#[cfg(test)]
pub fn compose(links: &[ChainLink], time: Option<f32>) -> Option<Matrix3x4> {
    links.iter().try_fold(optik_api::IDENTITY_3X4, |m, l| {
        Some(affine::mul(&m, &l.at(time)?))
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use optik_api::{IDENTITY_3X4, MotionFlags};

    fn options(keys: u16) -> MotionOptions {
        MotionOptions {
            num_keys: keys,
            flags: MotionFlags::NONE,
            time_begin: 0.0,
            time_end: 1.0,
        }
    }

    fn inside(b: &Aabb, p: [f32; 3]) -> bool {
        (0..3).all(|k| b[k] <= p[k] && p[k] <= b[k + 3])
    }

    fn srt_about_z(angle: f32, t: [f32; 3], scale: f32) -> SrtData {
        let (s, c) = (angle * 0.5).sin_cos();
        SrtData {
            sx: scale,
            sy: scale,
            sz: scale,
            qz: s,
            qw: c,
            tx: t[0],
            ty: t[1],
            tz: t[2],
            ..SrtData::identity()
        }
    }

    /// Sampled over time, every corner of the box stays inside the motion bounds.
    #[test]
    fn motion_bounds_hold_the_box_at_every_sampled_time() {
        let b: Aabb = [0.5, -0.25, 0.0, 1.5, 0.25, 0.1];
        let mut m1 = IDENTITY_3X4;
        m1[3] = 3.0;
        m1[0] = 0.0;
        m1[1] = -1.0;
        m1[4] = 1.0;
        m1[5] = 0.0;
        let matrix = ChainLink::Matrix(options(2), vec![IDENTITY_3X4, m1]);
        let srt = ChainLink::Srt(
            options(3),
            vec![
                srt_about_z(0.0, [0.0; 3], 1.0),
                srt_about_z(2.0, [1.0, 2.0, 0.0], 2.0),
                srt_about_z(3.0, [-1.0, 0.0, 1.0], 0.5),
            ],
        );
        for link in [matrix, srt] {
            let bounds = bound(&link, &b);
            for i in 0..=200 {
                let time = i as f32 / 200.0;
                let m = link.at(Some(time)).unwrap();
                for p in corners(&b) {
                    let q = affine::transform_point(&m, p.map(|c| c as f32));
                    assert!(
                        inside(&bounds, q),
                        "{link:?} at {time}: {q:?} outside {bounds:?}"
                    );
                }
            }
        }
    }

    #[test]
    fn static_bounds_round_outwards() {
        let m: Matrix3x4 = [0.1, 0.0, 0.0, 1e5, 0.0, 0.3, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0];
        let b = bound_static(&m, &[1.0, 1.0, 1.0, 2.0, 2.0, 2.0]);
        assert!(b[0] < 1e5 + 0.1 && b[3] > 1e5 + 0.2);
        assert!(b[1] < 0.3 && b[4] > 0.6);
    }

    #[test]
    fn chains_encode_their_links_and_compose_outermost_first() {
        let mut shift = IDENTITY_3X4;
        shift[3] = 1.0;
        let mut scale = IDENTITY_3X4;
        scale[0] = 2.0;
        let links = [
            ChainLink::Static(shift),
            ChainLink::Matrix(options(2), vec![scale, scale]),
        ];
        let words = chain_words(&links);
        assert_eq!(words[0], 2);
        assert_eq!(&words[1..6], &[0, 1, 0, 0, 0]);
        assert_eq!(words.len(), 1 + (5 + 12) + (5 + 24));
        // x ↦ 2x + 1: the scale applies first.
        let m = compose(&links, Some(0.5)).unwrap();
        assert_eq!(affine::transform_point(&m, [1.0, 0.0, 0.0])[0], 3.0);
        let vanishing = ChainLink::Matrix(
            MotionOptions {
                flags: MotionFlags::END_VANISH,
                ..options(2)
            },
            vec![IDENTITY_3X4; 2],
        );
        assert_eq!(compose(std::slice::from_ref(&vanishing), Some(2.0)), None);
        assert!(
            compose(&[vanishing], None).is_some(),
            "key 0 without motion"
        );
    }
}
