//! Motion: key resolution, matrix lerp and SRT nlerp (DESIGN.md §4; OptiX's
//! `optixResolveMotionKey` and `optixLoadInterpolatedSrtKey`).
//!
//! Keys are evenly spaced from `time_begin` to `time_end`. Outside that range the nearest
//! key is used (clamping) unless `START_VANISH` / `END_VANISH` make the object vanish. A
//! degenerate range (`time_begin == time_end`) uses the first key. Matrices interpolate
//! element by element; SRT keys interpolate all 16 values linearly and then normalise the
//! quaternion (nlerp), as OptiX does — not slerp, as Embree does.

use crate::accel::{Matrix3x4, MotionOptions, SrtData};
use crate::flags::MotionFlags;

/// Where a time falls among the keys: interpolate between `key` and `key + 1` by `t`
/// (`t == 0` uses `key` alone).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KeyPosition {
    /// The earlier key.
    pub key: usize,
    /// Fraction towards the next key, in [0, 1).
    pub t: f32,
}

/// Resolves `time` against motion options; `None` when the object vanishes at that time.
pub fn resolve_key(options: &MotionOptions, time: f32) -> Option<KeyPosition> {
    let n = options.num_keys.max(1) as usize;
    if options.flags.contains(MotionFlags::START_VANISH) && time < options.time_begin {
        return None;
    }
    if options.flags.contains(MotionFlags::END_VANISH) && time > options.time_end {
        return None;
    }
    if n < 2 {
        return Some(KeyPosition { key: 0, t: 0.0 });
    }
    let intervals = (n - 1) as f32;
    let mut x = intervals * ((time - options.time_begin) / (options.time_end - options.time_begin));
    if x.is_nan() {
        x = 0.0;
    }
    let x = x.clamp(0.0, intervals);
    let key = x.floor();
    Some(KeyPosition {
        key: key as usize,
        t: x - key,
    })
}

fn lerp(a: f32, b: f32, t: f32) -> f32 {
    a * (1.0 - t) + b * t
}

/// The matrix at a key position (element-wise lerp).
pub fn interpolate_matrix(keys: &[Matrix3x4], at: KeyPosition) -> Matrix3x4 {
    let a = &keys[at.key.min(keys.len() - 1)];
    if at.t == 0.0 || at.key + 1 >= keys.len() {
        return *a;
    }
    let b = &keys[at.key + 1];
    std::array::from_fn(|i| lerp(a[i], b[i], at.t))
}

/// The SRT key at a key position: all 16 values lerped, then the quaternion normalised.
pub fn interpolate_srt(keys: &[SrtData], at: KeyPosition) -> SrtData {
    let a = keys[at.key.min(keys.len() - 1)];
    if at.t == 0.0 || at.key + 1 >= keys.len() {
        return a;
    }
    let b = keys[at.key + 1];
    let fa: &[f32; 16] = bytemuck::cast_ref(&a);
    let fb: &[f32; 16] = bytemuck::cast_ref(&b);
    let mut f: [f32; 16] = std::array::from_fn(|i| lerp(fa[i], fb[i], at.t));
    let q = [f[9], f[10], f[11], f[12]];
    let len = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
    if len > 0.0 {
        for i in 0..4 {
            f[9 + i] = q[i] / len;
        }
    }
    bytemuck::cast(f)
}

/// The object-to-world matrix of an SRT key: `T · R · S`, where S is the upper-triangular
/// scale/shear matrix with the pivot as its translation.
pub fn srt_to_matrix(k: &SrtData) -> Matrix3x4 {
    let s: Matrix3x4 = [
        k.sx, k.a, k.b, k.pvx, 0.0, k.sy, k.c, k.pvy, 0.0, 0.0, k.sz, k.pvz,
    ];
    let (x, y, z, w) = (k.qx, k.qy, k.qz, k.qw);
    let r: Matrix3x4 = [
        1.0 - 2.0 * (y * y + z * z),
        2.0 * (x * y - z * w),
        2.0 * (x * z + y * w),
        0.0,
        2.0 * (x * y + z * w),
        1.0 - 2.0 * (x * x + z * z),
        2.0 * (y * z - x * w),
        0.0,
        2.0 * (x * z - y * w),
        2.0 * (y * z + x * w),
        1.0 - 2.0 * (x * x + y * y),
        0.0,
    ];
    let rs = super::affine::mul(&r, &s);
    let mut m = rs;
    m[3] += k.tx;
    m[7] += k.ty;
    m[11] += k.tz;
    m
}

/// Whether a key set is usable: finite values, and unit quaternions for SRT keys.
pub fn srt_key_is_valid(k: &SrtData) -> bool {
    let f: &[f32; 16] = bytemuck::cast_ref(k);
    let q_len2 = k.qx * k.qx + k.qy * k.qy + k.qz * k.qz + k.qw * k.qw;
    f.iter().all(|v| v.is_finite()) && (q_len2 - 1.0).abs() < 1e-3
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::IDENTITY_3X4;

    fn opts(n: u16, b: f32, e: f32, flags: MotionFlags) -> MotionOptions {
        MotionOptions {
            num_keys: n,
            flags,
            time_begin: b,
            time_end: e,
        }
    }

    #[test]
    fn key_resolution() {
        let o = opts(3, 0.0, 1.0, MotionFlags::NONE);
        assert_eq!(resolve_key(&o, 0.0), Some(KeyPosition { key: 0, t: 0.0 }));
        assert_eq!(resolve_key(&o, 0.25), Some(KeyPosition { key: 0, t: 0.5 }));
        assert_eq!(resolve_key(&o, 0.5), Some(KeyPosition { key: 1, t: 0.0 }));
        assert_eq!(resolve_key(&o, 1.0), Some(KeyPosition { key: 2, t: 0.0 }));
        assert_eq!(resolve_key(&o, -5.0), Some(KeyPosition { key: 0, t: 0.0 }));
        assert_eq!(resolve_key(&o, 7.0), Some(KeyPosition { key: 2, t: 0.0 }));
        assert_eq!(
            resolve_key(&o, f32::NAN),
            Some(KeyPosition { key: 0, t: 0.0 })
        );
        let degenerate = opts(2, 1.0, 1.0, MotionFlags::NONE);
        assert_eq!(
            resolve_key(&degenerate, 1.0),
            Some(KeyPosition { key: 0, t: 0.0 })
        );
        let v = opts(
            2,
            0.0,
            1.0,
            MotionFlags::START_VANISH | MotionFlags::END_VANISH,
        );
        assert_eq!(resolve_key(&v, -0.01), None);
        assert_eq!(resolve_key(&v, 1.01), None);
        assert!(resolve_key(&v, 1.0).is_some());
    }

    #[test]
    fn matrix_lerp() {
        let mut a = IDENTITY_3X4;
        let mut b = IDENTITY_3X4;
        a[3] = 0.0;
        b[3] = 4.0;
        let m = interpolate_matrix(&[a, b], KeyPosition { key: 0, t: 0.25 });
        assert_eq!(m[3], 1.0);
    }

    fn quat_axis_angle(axis: [f32; 3], angle: f32) -> [f32; 4] {
        let (s, c) = (angle * 0.5).sin_cos();
        [axis[0] * s, axis[1] * s, axis[2] * s, c]
    }

    fn slerp(a: [f32; 4], b: [f32; 4], t: f32) -> [f32; 4] {
        let dot: f32 = (0..4).map(|i| a[i] * b[i]).sum();
        let theta = dot.clamp(-1.0, 1.0).acos();
        let s = theta.sin();
        let wa = ((1.0 - t) * theta).sin() / s;
        let wb = (t * theta).sin() / s;
        std::array::from_fn(|i| wa * a[i] + wb * b[i])
    }

    fn key(q: [f32; 4]) -> SrtData {
        SrtData {
            qx: q[0],
            qy: q[1],
            qz: q[2],
            qw: q[3],
            ..SrtData::identity()
        }
    }

    /// nlerp and slerp agree at the keys and at mid-time of a symmetric interval (both lie on
    /// the bisector), and differ in between: at t = 0.25 of a 179° turn nlerp has turned
    /// measurably further than a quarter of the angle, which slerp turns exactly.
    #[test]
    fn nlerp_against_slerp() {
        let axis = [0.0, 0.0, 1.0];
        let q0 = quat_axis_angle(axis, 0.0);
        let q1 = quat_axis_angle(axis, 179f32.to_radians());
        let keys = [key(q0), key(q1)];
        let angle_of = |k: &SrtData| {
            let m = srt_to_matrix(k);
            m[4].atan2(m[0]).to_degrees()
        };
        // Mid-time: both are on the bisector (89.5°).
        let mid = interpolate_srt(&keys, KeyPosition { key: 0, t: 0.5 });
        assert!((angle_of(&mid) - 89.5).abs() < 1e-3, "{}", angle_of(&mid));
        let s = slerp(q0, q1, 0.5);
        assert!((mid.qz - s[2]).abs() < 1e-5 && (mid.qw - s[3]).abs() < 1e-5);
        // Quarter time: slerp turns 44.75°, nlerp about 36.8°.
        let quarter = interpolate_srt(&keys, KeyPosition { key: 0, t: 0.25 });
        let slerp_quarter = slerp(q0, q1, 0.25);
        let slerp_angle = angle_of(&key(slerp_quarter));
        assert!((slerp_angle - 44.75).abs() < 1e-3);
        let nlerp_angle = angle_of(&quarter);
        assert!(
            slerp_angle - nlerp_angle > 5.0,
            "nlerp {nlerp_angle} vs slerp {slerp_angle}"
        );
        assert!((nlerp_angle - 36.77).abs() < 0.05, "{nlerp_angle}");
        // nlerp keeps the object rigid: the interpolated rotation is orthonormal.
        let m = srt_to_matrix(&quarter);
        let len = (m[0] * m[0] + m[4] * m[4] + m[8] * m[8]).sqrt();
        assert!((len - 1.0).abs() < 1e-5);
    }

    #[test]
    fn srt_is_t_r_s_with_pivot() {
        // Scale 2 about pivot (1,0,0), rotate 90° about z, translate (0,0,5).
        let q = quat_axis_angle([0.0, 0.0, 1.0], std::f32::consts::FRAC_PI_2);
        let k = SrtData {
            sx: 2.0,
            sy: 2.0,
            sz: 2.0,
            pvx: 1.0,
            qx: q[0],
            qy: q[1],
            qz: q[2],
            qw: q[3],
            tz: 5.0,
            ..SrtData::identity()
        };
        let m = srt_to_matrix(&k);
        // S maps (1,0,0) to (2+1, 0, 0) = (3,0,0); R to (0,3,0); T to (0,3,5).
        let p = crate::semantics::affine::transform_point(&m, [1.0, 0.0, 0.0]);
        assert!(
            (p[0]).abs() < 1e-5 && (p[1] - 3.0).abs() < 1e-5 && (p[2] - 5.0).abs() < 1e-5,
            "{p:?}"
        );
        assert!(srt_key_is_valid(&k));
        assert!(!srt_key_is_valid(&SrtData { qw: 2.0, ..k }));
    }
}
