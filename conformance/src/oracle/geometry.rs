//! Ray–primitive relations in `f64`, with the ambiguity bands of DESIGN.md §5.
//!
//! Each test answers "hit", "miss" or "ambiguous". A ray is ambiguous for a triangle when
//! it passes within rounding of one of the triangle's edges (or vertices): the edge
//! function `E = ((a − o) × (b − o)) · d`, whose sign is computed exactly, is smaller than
//! what moving the ray's line by the rounding radius `r` can change
//! (`|E| ≤ r · |d × (b − a)|`). What a correct `f32` intersector may then answer is what an
//! exact test answers for *some* line within `r`: [`cluster_outcomes`] samples those lines
//! around each contact and returns every distinct set of triangles they hit. A watertight
//! mesh therefore admits exactly one hit where a ray crosses it, whichever triangle it is,
//! and never zero or two.

use super::exact;
use super::math::*;

/// Unit roundoff of `f32`.
pub const EPS32: f64 = 1.0 / 16_777_216.0;

/// How wide the ambiguity bands are.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rounding {
    /// Bands are this many `f32` unit roundoffs of the scene scale at the contact.
    pub k: f64,
    /// The case's geometry is exactly computable in `f32` (small dyadic coordinates,
    /// axis-aligned rays): only exact zeros are ambiguous and t is compared exactly.
    pub exact: bool,
}

impl Rounding {
    /// The default: 16 unit roundoffs (≈ 9.5e-7 relative, 8 ulps).
    pub const F32: Rounding = Rounding {
        k: 16.0,
        exact: false,
    };
    /// Exactly computable scenes.
    pub const EXACT: Rounding = Rounding {
        k: 16.0,
        exact: true,
    };

    /// The rounding radius for a contact of magnitude `scale`.
    pub fn radius(&self, scale: f64) -> f64 {
        if self.exact {
            1e-30 * scale.max(1e-300)
        } else {
            self.k * EPS32 * scale
        }
    }

    /// The band around a value of magnitude `scale` (0 when exact).
    pub fn band(&self, scale: f64) -> f64 {
        if self.exact {
            0.0
        } else {
            self.k * EPS32 * scale
        }
    }
}

/// A ray in some object space: origin, direction, and the extra rounding its transforms
/// bring (0 in world space).
#[derive(Clone, Copy, Debug)]
pub struct ObjRay {
    /// Origin.
    pub o: V3,
    /// Direction (not normalised: t is in units of it).
    pub d: V3,
    /// Absolute position error the transforms to this space add.
    pub extra: f64,
}

/// One edge of a triangle seen by a ray.
#[derive(Clone, Copy, Debug)]
pub struct Edge {
    /// The edge function (estimate).
    pub e: f64,
    /// Its exact sign.
    pub sign: i32,
    /// How it changes when the line moves by δ (⟂ d): `E(δ) = E + δ · g`.
    pub g: V3,
    /// Whether moving the line by the rounding radius can change its sign.
    pub near: bool,
}

/// Whether a triangle is hit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Status {
    /// Certainly hit.
    Hit,
    /// Ambiguous: decided per contact cluster by [`cluster_outcomes`].
    Ambiguous,
}

/// A triangle the ray hits or may hit.
#[derive(Clone, Debug)]
pub struct TriContact {
    /// Distance along the ray to the triangle's plane.
    pub t: f64,
    /// How far t may be off in an `f32` implementation.
    pub dt: f64,
    /// Barycentrics `(u, v)` of vertices 1 and 2 (clamped to the triangle).
    pub bary: [f64; 2],
    /// `n · d` in object space, `n = (v1 − v0) × (v2 − v0)`: negative means front.
    pub n_dot_d: f64,
    /// Hit or ambiguous.
    pub status: Status,
    /// The three edges (opposite vertices 0, 1, 2).
    pub edges: [Edge; 3],
    /// The rounding radius used.
    pub r: f64,
}

/// Tests one triangle. `None`: not hit and not ambiguous, or not a valid triangle (a NaN or
/// infinite coordinate, or exactly zero area: such triangles never hit).
pub fn triangle(v: [V3; 3], ray: &ObjRay, rnd: &Rounding) -> Option<TriContact> {
    if v.iter().any(|p| p.iter().any(|c| !c.is_finite())) {
        return None;
    }
    let scale = v
        .iter()
        .map(|p| max_abs(sub(*p, ray.o)))
        .fold(0.0, f64::max)
        + ray.extra;
    let r = rnd.radius(scale.max(f64::MIN_POSITIVE));
    let edge = |a: V3, b: V3| {
        let (e, sign) = exact::edge_function(a, b, ray.o, ray.d);
        let g = cross(ray.d, sub(b, a));
        Edge {
            e,
            sign,
            g,
            near: e.abs() <= r * length(g),
        }
    };
    let edges = [edge(v[1], v[2]), edge(v[2], v[0]), edge(v[0], v[1])];
    // A definite sign on two edges that disagree: certainly outside.
    let definite: Vec<i32> = edges.iter().filter(|e| !e.near).map(|e| e.sign).collect();
    if definite.contains(&1) && definite.contains(&-1) {
        return None;
    }
    let any_near = edges.iter().any(|e| e.near);
    if is_degenerate(v) {
        return None;
    }
    let n = cross(sub(v[1], v[0]), sub(v[2], v[0]));
    let n_dot_d = dot(n, ray.d);
    if n_dot_d == 0.0 {
        // The ray lies in (or parallel to) the triangle's plane: no intersector reports it.
        return None;
    }
    let t = dot(n, sub(v[0], ray.o)) / n_dot_d;
    let sum = edges[0].e + edges[1].e + edges[2].e;
    let (b1, b2) = if sum != 0.0 {
        (edges[1].e / sum, edges[2].e / sum)
    } else {
        (0.0, 0.0)
    };
    let clamp = |x: f64| x.clamp(0.0, 1.0);
    let dt = if rnd.exact {
        0.0
    } else {
        r * length(n) / n_dot_d.abs() + rnd.band(t.abs())
    };
    Some(TriContact {
        t,
        dt,
        bary: [clamp(b1), clamp(b2)],
        n_dot_d,
        status: if any_near {
            Status::Ambiguous
        } else {
            Status::Hit
        },
        edges,
        r,
    })
}

/// Whether the triangle has exactly zero area: an `f64` filter, then exact arithmetic.
fn is_degenerate(v: [V3; 3]) -> bool {
    let (e1, e2) = (sub(v[1], v[0]), sub(v[2], v[0]));
    let n = cross(e1, e2);
    let bound = 8.0 * f64::EPSILON * (max_abs(e1) * max_abs(e2)) * 2.0;
    if max_abs(n) > bound {
        return false;
    }
    exact::is_degenerate(v[0], v[1], v[2])
}

/// Whether a triangle is hit by the line moved by `delta`; `None` when the moved line lies
/// on one of its edges (a sample too special to use).
fn hit_when_moved(c: &TriContact, delta: V3) -> Option<bool> {
    let mut pos = false;
    let mut neg = false;
    for e in &c.edges {
        let moved = e.e + dot(delta, e.g);
        if moved.abs() <= 1e-9 * length(delta) * length(e.g) && e.near {
            return None;
        }
        if moved > 0.0 {
            pos = true;
        } else if moved < 0.0 {
            neg = true;
        }
    }
    Some(pos != neg)
}

/// Two unit vectors spanning the plane ⟂ `d`.
fn plane_basis(d: V3) -> (V3, V3) {
    let n = normalize(d);
    let helper = if n[0].abs() < 0.6 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 1.0, 0.0]
    };
    let u = normalize(cross(n, helper));
    let v = cross(n, u);
    (u, v)
}

/// The sets of triangles (as flags over `members`) that lines within rounding of the ray
/// hit: sampled at two radii in 64 directions, across every near edge, and in every sector
/// between near edges. Every member is ambiguous or hit; all share one object space.
pub fn cluster_outcomes(members: &[&TriContact], d: V3) -> Vec<Vec<bool>> {
    let r = members.iter().map(|c| c.r).fold(0.0, f64::max);
    let (u, v) = plane_basis(d);
    let angle_of = |w: V3| dot(w, v).atan2(dot(w, u));
    let mut angles: Vec<f64> = (0..64)
        .map(|i| 0.1234 + i as f64 * std::f64::consts::TAU / 64.0)
        .collect();
    // The directions of the near edges' lines; the bisectors between consecutive ones sample
    // every sector around a near vertex and cross every near edge (for a lone edge they are
    // its two normals).
    let mut edge_lines = Vec::new();
    for c in members {
        for e in c.edges.iter().filter(|e| e.near && length(e.g) > 0.0) {
            let a = angle_of(e.g);
            edge_lines.push(a + std::f64::consts::FRAC_PI_2);
            edge_lines.push(a - std::f64::consts::FRAC_PI_2);
        }
    }
    edge_lines
        .iter_mut()
        .for_each(|a| *a = a.rem_euclid(std::f64::consts::TAU));
    edge_lines.sort_by(f64::total_cmp);
    edge_lines.dedup_by(|a, b| (*a - *b).abs() < 1e-12);
    for w in edge_lines.windows(2) {
        angles.push(0.5 * (w[0] + w[1]));
    }
    if let (Some(first), Some(last)) = (edge_lines.first(), edge_lines.last()) {
        angles.push(0.5 * (first + last + std::f64::consts::TAU));
    }
    let mut outcomes: Vec<Vec<bool>> = Vec::new();
    for radius in [r, r / 8.0] {
        for a in &angles {
            let delta = add(scale(u, radius * a.cos()), scale(v, radius * a.sin()));
            let hits: Option<Vec<bool>> =
                members.iter().map(|c| hit_when_moved(c, delta)).collect();
            if let Some(h) = hits.filter(|h| !outcomes.contains(h)) {
                outcomes.push(h);
            }
        }
    }
    outcomes
}

/// Whether and where a ray meets a box.
#[derive(Clone, Copy, Debug)]
pub struct BoxContact {
    /// Where the ray enters the box (clamped to tmin).
    pub t_enter: f64,
    /// Whether rounding may decide either way.
    pub ambiguous: bool,
}

/// The slab test of a box `[min.xyz, max.xyz]` against the ray's interval. `None`: the line
/// certainly misses the box, or an invalid box (NaN, or min > max). Definite when the closed
/// box is met within [tmin, tmax]; ambiguous when only the box grown by the rounding radius is
/// met, or only outside the interval (an extra intersection-program call is admissible there,
/// a missing one for a box the ray meets in its interval is not).
pub fn aabb(b: [f64; 6], ray: &ObjRay, tmin: f64, tmax: f64, rnd: &Rounding) -> Option<BoxContact> {
    if b.iter().any(|x| x.is_nan()) || (0..3).any(|i| b[i] > b[i + 3]) {
        return None;
    }
    let scale = (0..6)
        .map(|i| (b[i] - ray.o[i % 3]).abs())
        .fold(0.0, f64::max)
        + ray.extra;
    let r = rnd.radius(scale.max(f64::MIN_POSITIVE));
    let tb = r / length(ray.d).max(f64::MIN_POSITIVE);
    let interval = |grow: f64| -> Option<(f64, f64)> {
        let (mut lo, mut hi) = (f64::NEG_INFINITY, f64::INFINITY);
        for i in 0..3 {
            let (mn, mx) = (b[i] - grow, b[i + 3] + grow);
            if mn > mx {
                return None;
            }
            if ray.d[i] == 0.0 {
                if ray.o[i] < mn || ray.o[i] > mx {
                    return None;
                }
            } else {
                let (t1, t2) = ((mn - ray.o[i]) / ray.d[i], (mx - ray.o[i]) / ray.d[i]);
                lo = lo.max(t1.min(t2));
                hi = hi.min(t1.max(t2));
            }
        }
        (lo <= hi).then_some((lo, hi))
    };
    let (glo, ghi) = interval(r)?;
    if glo > tmax + tb || ghi < tmin - tb {
        // The line meets the box only outside the ray's interval: an implementation may
        // still run the intersection program (Vulkan does not forbid it; its reports are
        // judged against [tmin, tmax] as any other).
        return Some(BoxContact {
            t_enter: glo.max(tmin),
            ambiguous: true,
        });
    }
    // The closed box itself: a ray that meets it must run the intersection program (a box
    // may be enlarged, never shrunk); one that misses it only by rounding may.
    let exact = interval(0.0).filter(|(lo, hi)| *lo <= tmax && *hi >= tmin);
    let t_enter = exact.map_or(glo, |(lo, _)| lo).max(tmin);
    Some(BoxContact {
        t_enter,
        ambiguous: exact.is_none(),
    })
}

/// A ray meeting a sphere or capsule from outside.
#[derive(Clone, Copy, Debug)]
pub struct RoundContact {
    /// Entry distance.
    pub t: f64,
    /// How far t may be off.
    pub dt: f64,
    /// Whether the ray is within rounding of the silhouette (or starts within rounding of
    /// the surface): a miss is admissible too.
    pub ambiguous: bool,
    /// The hit point's parameter along a capsule's axis (0 for spheres).
    pub u: f64,
    /// Entering the surface (hit kind 0xFE) rather than leaving it (0xFF).
    pub front: bool,
}

/// The hit of a sphere of centre `c` and radius `radius` (the stable quadratic): the entry
/// (front, hit kind 0xFE) for a ray from outside; with `exits`, the exit (back, 0xFF) for a ray
/// from inside (docs/decisions.md: built-in spheres report both). A ray within rounding of the
/// silhouette, or starting within rounding of the surface, is ambiguous.
pub fn sphere(
    c: V3,
    radius: f64,
    ray: &ObjRay,
    rnd: &Rounding,
    exits: bool,
) -> Option<RoundContact> {
    if !radius.is_finite() || radius <= 0.0 || c.iter().any(|x| !x.is_finite()) {
        return None;
    }
    let f = sub(ray.o, c);
    let a = dot(ray.d, ray.d);
    if a == 0.0 {
        return None;
    }
    let dn = scale(ray.d, 1.0 / a.sqrt());
    let along = dot(f, dn);
    let perp = sub(f, scale(dn, along));
    let dist2 = dot(perp, perp);
    let dist = dist2.sqrt();
    let flen = length(f);
    let rs = rnd.radius(flen + radius + ray.extra);
    if dist > radius + rs {
        return None;
    }
    let on_surface = (flen - radius).abs() <= rs;
    let inside = flen < radius - rs;
    let half = (radius * radius - dist2).max(0.0).sqrt();
    let (t, front) = if inside || (on_surface && along >= 0.0) {
        if !exits {
            return None;
        }
        ((-along + half) / a.sqrt(), false)
    } else {
        if along > 0.0 && !on_surface {
            // Outside and moving away: the sphere lies behind the origin.
            return None;
        }
        ((-along - half) / a.sqrt(), true)
    };
    // Moving the surface by rs moves t by rs / cos(incidence), at most by the tangent bound.
    let surface = (rs * radius / half.max(f64::MIN_POSITIVE)).min(rs + (2.0 * radius * rs).sqrt());
    let dt = if rnd.exact {
        0.0
    } else {
        surface / a.sqrt() + rnd.band(t.abs())
    };
    Some(RoundContact {
        t,
        dt,
        ambiguous: dist >= radius - rs || on_surface,
        u: 0.0,
        front,
    })
}

/// The entry hit of a capsule (a round linear curve segment of constant radius).
pub fn capsule(p0: V3, p1: V3, radius: f64, ray: &ObjRay, rnd: &Rounding) -> Option<RoundContact> {
    let axis = sub(p1, p0);
    let len2 = dot(axis, axis);
    let mut best: Option<RoundContact> = None;
    let mut consider = |c: RoundContact| {
        if best.is_none_or(|b| c.t < b.t) {
            best = Some(c);
        }
    };
    for (end, u) in [(p0, 0.0), (p1, 1.0)] {
        if let Some(mut c) = sphere(end, radius, ray, rnd, false) {
            c.u = u;
            consider(c);
        }
    }
    if len2 > 0.0 {
        // Cylinder: |(o + t d − p0) × â|² = r².
        let ah = scale(axis, 1.0 / len2.sqrt());
        let oc = sub(ray.o, p0);
        let dp = sub(ray.d, scale(ah, dot(ray.d, ah)));
        let op = sub(oc, scale(ah, dot(oc, ah)));
        let a = dot(dp, dp);
        if a > 0.0 {
            let b = dot(op, dp);
            let cq = dot(op, op) - radius * radius;
            let disc = b * b - a * cq;
            let rs = rnd.radius(length(oc) + len2.sqrt() + radius + ray.extra);
            if disc >= -(rs * radius * 2.0) * a && cq > -2.0 * rs * radius {
                let root = disc.max(0.0).sqrt();
                let t = (-b - root) / a;
                let hit = add(oc, scale(ray.d, t));
                let s = dot(hit, ah) / len2.sqrt();
                if (0.0..=1.0).contains(&s) && t > 0.0 {
                    let dt = (rs + (2.0 * radius * rs).sqrt()) / a.sqrt() + rnd.band(t.abs());
                    let ambiguous =
                        disc <= (rs * radius * 2.0) * a || cq.abs() <= 2.0 * rs * radius;
                    consider(RoundContact {
                        t,
                        dt,
                        ambiguous,
                        u: s,
                        front: true,
                    });
                }
            }
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ray(o: V3, d: V3) -> ObjRay {
        ObjRay { o, d, extra: 0.0 }
    }

    #[test]
    fn interior_hit_is_definite_with_barycentrics() {
        let v = [[0.0, 0.0, -2.0], [1.0, 0.0, -2.0], [0.0, 1.0, -2.0]];
        let c = triangle(v, &ray([0.25, 0.5, 0.0], [0.0, 0.0, -1.0]), &Rounding::F32).unwrap();
        assert_eq!(c.status, Status::Hit);
        assert!((c.t - 2.0).abs() < 1e-15);
        assert!((c.bary[0] - 0.25).abs() < 1e-15 && (c.bary[1] - 0.5).abs() < 1e-15);
        assert!(
            c.n_dot_d < 0.0,
            "counter-clockwise seen from the origin faces it"
        );
        assert!(triangle(v, &ray([0.75, 0.5, 0.0], [0.0, 0.0, -1.0]), &Rounding::F32).is_none());
    }

    #[test]
    fn shared_edge_admits_exactly_one_of_two() {
        // Two triangles of a square sharing the diagonal; the ray hits the diagonal exactly.
        let a = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0]];
        let b = [[0.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]];
        let r = ray([0.5, 0.5, 1.0], [0.0, 0.0, -1.0]);
        let ca = triangle(a, &r, &Rounding::F32).unwrap();
        let cb = triangle(b, &r, &Rounding::F32).unwrap();
        assert_eq!(
            (ca.status, cb.status),
            (Status::Ambiguous, Status::Ambiguous)
        );
        let mut outcomes = cluster_outcomes(&[&ca, &cb], r.d);
        outcomes.sort();
        assert_eq!(outcomes, vec![vec![false, true], vec![true, false]]);
    }

    #[test]
    fn closed_fan_vertex_admits_exactly_one() {
        let n = 7;
        let tris: Vec<[V3; 3]> = (0..n)
            .map(|i| {
                let a0 = i as f64 * std::f64::consts::TAU / n as f64;
                let a1 = (i + 1) as f64 * std::f64::consts::TAU / n as f64;
                [
                    [0.0, 0.0, 0.0],
                    [a0.cos(), a0.sin(), 0.0],
                    [a1.cos(), a1.sin(), 0.0],
                ]
            })
            .collect();
        let r = ray([0.0, 0.0, -1.0], [0.0, 0.0, 1.0]);
        let contacts: Vec<TriContact> = tris
            .iter()
            .filter_map(|t| triangle(*t, &r, &Rounding::F32))
            .collect();
        assert_eq!(contacts.len(), n);
        let refs: Vec<&TriContact> = contacts.iter().collect();
        let outcomes = cluster_outcomes(&refs, r.d);
        assert_eq!(outcomes.len(), n, "each triangle of the fan is admissible");
        assert!(
            outcomes
                .iter()
                .all(|o| o.iter().filter(|h| **h).count() == 1)
        );
    }

    #[test]
    fn invalid_triangles_never_hit() {
        let r = ray([0.2, 0.2, 1.0], [0.0, 0.0, -1.0]);
        assert!(
            triangle(
                [[0.0; 3], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]],
                &r,
                &Rounding::F32
            )
            .is_none()
        );
        assert!(
            triangle(
                [[f64::NAN, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
                &r,
                &Rounding::F32
            )
            .is_none()
        );
    }

    #[test]
    fn box_faces_are_ambiguous_only_within_rounding() {
        let b = [0.0, 0.0, 0.0, 1.0, 1.0, 1.0];
        let inside = aabb(
            b,
            &ray([0.5, 0.5, -1.0], [0.0, 0.0, 1.0]),
            0.0,
            10.0,
            &Rounding::F32,
        )
        .unwrap();
        assert!(!inside.ambiguous && (inside.t_enter - 1.0).abs() < 1e-5);
        let on_face = aabb(
            b,
            &ray([1.0, 0.5, -1.0], [0.0, 0.0, 1.0]),
            0.0,
            10.0,
            &Rounding::F32,
        )
        .unwrap();
        assert!(!on_face.ambiguous, "a ray on a face meets the closed box");
        let beside = aabb(
            b,
            &ray([1.0 + 1e-9, 0.5, -1.0], [0.0, 0.0, 1.0]),
            0.0,
            10.0,
            &Rounding::F32,
        )
        .unwrap();
        assert!(beside.ambiguous);
        assert!(
            aabb(
                b,
                &ray([1.1, 0.5, -1.0], [0.0, 0.0, 1.0]),
                0.0,
                10.0,
                &Rounding::F32
            )
            .is_none()
        );
        // Beyond tmax: the program may run, it need not.
        let beyond = aabb(
            b,
            &ray([0.5, 0.5, -1.0], [0.0, 0.0, 1.0]),
            0.0,
            0.5,
            &Rounding::F32,
        )
        .unwrap();
        assert!(beyond.ambiguous);
    }

    #[test]
    fn sphere_entry_and_silhouette() {
        let f = Rounding::F32;
        let c = sphere(
            [0.0, 0.0, 10.0],
            1.0,
            &ray([0.0; 3], [0.0, 0.0, 2.0]),
            &f,
            true,
        )
        .unwrap();
        assert!((c.t - 4.5).abs() < 1e-12 && !c.ambiguous && c.front);
        let s = sphere(
            [0.0, 0.0, 10.0],
            1.0,
            &ray([1.0, 0.0, 0.0], [0.0, 0.0, 1.0]),
            &f,
            true,
        )
        .unwrap();
        assert!(s.ambiguous);
        // From inside: the exit, a back-face hit, for spheres; nothing for curve caps.
        let inside = sphere(
            [0.0, 0.0, 10.0],
            1.0,
            &ray([0.0, 0.0, 10.0], [0.0, 0.0, 1.0]),
            &f,
            true,
        )
        .unwrap();
        assert!((inside.t - 1.0).abs() < 1e-12 && !inside.front);
        assert!(
            sphere(
                [0.0, 0.0, 10.0],
                1.0,
                &ray([0.0, 0.0, 10.0], [0.0, 0.0, 1.0]),
                &f,
                false
            )
            .is_none()
        );
        assert!(
            sphere(
                [0.0, 0.0, -10.0],
                1.0,
                &ray([0.0; 3], [0.0, 0.0, 1.0]),
                &f,
                true
            )
            .is_none(),
            "behind"
        );
        let cap = capsule(
            [0.0, 0.0, 5.0],
            [4.0, 0.0, 5.0],
            0.5,
            &ray([2.0, 0.0, 0.0], [0.0, 0.0, 1.0]),
            &Rounding::F32,
        )
        .unwrap();
        assert!((cap.t - 4.5).abs() < 1e-12 && (cap.u - 0.5).abs() < 1e-12);
    }
}
