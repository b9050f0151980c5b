//! The cases have teeth and the oracle's ambiguity bands admit correct `f32` intersectors,
//! shown before any backend runs: a small test-only tracer (brute force over the triangles of
//! a GAS, the standard programs' semantics) stands in for a backend, with a correct watertight
//! `f32` intersector and with deliberately broken ones. The correct one must pass every case
//! it can run; each broken one must fail the cases that guard the rule it breaks.
//!
//! This tracer is test code, written independently of the oracle (`f32` Woop–Benthin–Wald with
//! an `f64` fallback and a top-left tie rule, and Möller–Trumbore), and shares nothing with
//! the backends.

use optik::{GeometryFlags, VertexFormat};
use optik_conformance::case::{Case, ParamWord};
use optik_conformance::judge;
use optik_conformance::kit::{action, prog, rec};
use optik_conformance::runner;
use optik_conformance::scene::{GeomInput, Node};

/// How the stand-in intersector behaves.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Variant {
    /// Watertight f32 test, f64 fallback, top-left rule for exact zeros: correct.
    Watertight,
    /// The same without the tie rule: exact zeros count as inside both neighbours.
    WatertightDoubleHits,
    /// Möller–Trumbore: not watertight.
    MollerTrumbore,
    /// Correct, but accepts t in the closed interval [tmin, tmax].
    ClosedInterval,
    /// Correct, but reports front faces as back faces and the reverse.
    SwappedFacing,
    /// Correct, but without rejecting zero-area triangles up front (their projection can have
    /// a tiny nonzero area after rounding, and then they are hit).
    NoDegenerateCheck,
}

struct Tri {
    v: [[f32; 3]; 3],
    prim: u32,
    flags: GeometryFlags,
}

fn sub(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// A hit: t and barycentrics (u, v) of vertices 1 and 2.
type Hit = (f32, f32, f32);

/// Woop, Benthin and Wald's watertight test.
fn woop(t: &Tri, o: [f32; 3], d: [f32; 3], tie_rule: bool) -> Option<Hit> {
    let kz = (0..3).max_by(|a, b| d[*a].abs().total_cmp(&d[*b].abs()))?;
    let (mut kx, mut ky) = ((kz + 1) % 3, (kz + 2) % 3);
    if d[kz] < 0.0 {
        std::mem::swap(&mut kx, &mut ky);
    }
    let (sx, sy, sz) = (d[kx] / d[kz], d[ky] / d[kz], 1.0 / d[kz]);
    let rel: Vec<[f32; 3]> = t.v.iter().map(|p| sub(*p, o)).collect();
    let proj: Vec<(f32, f32)> = rel
        .iter()
        .map(|p| (p[kx] - sx * p[kz], p[ky] - sy * p[kz]))
        .collect();
    let (a, b, c) = (proj[0], proj[1], proj[2]);
    let edge = |p: (f32, f32), q: (f32, f32)| -> f32 {
        let e = p.0 * q.1 - p.1 * q.0;
        if e != 0.0 {
            return e;
        }
        // The f64 fallback of the paper: exact for these f32 products; keep at least its sign.
        let e64 = p.0 as f64 * q.1 as f64 - p.1 as f64 * q.0 as f64;
        if e64 == 0.0 {
            0.0
        } else {
            (e64 as f32).abs().max(f32::MIN_POSITIVE) * e64.signum() as f32
        }
    };
    // U opposite vertex 0 (edge b→c), V opposite 1 (c→a), W opposite 2 (a→b).
    let (u, v, w) = (edge(c, b), edge(a, c), edge(b, a));
    let det = u + v + w;
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let s = det.signum();
    let inside = |e: f32, p: (f32, f32), q: (f32, f32)| -> bool {
        if e != 0.0 {
            return e.signum() == s;
        }
        if !tie_rule {
            return true;
        }
        // The edge runs p → q in the orientation where the triangle is on its left; one of
        // the two triangles sharing it owns it.
        let (dx, dy) = (s * (q.0 - p.0), s * (q.1 - p.1));
        dy > 0.0 || (dy == 0.0 && dx > 0.0)
    };
    if !(inside(u, c, b) && inside(v, a, c) && inside(w, b, a)) {
        return None;
    }
    let z: Vec<f32> = rel.iter().map(|p| sz * p[kz]).collect();
    let tt = (u * z[0] + v * z[1] + w * z[2]) / det;
    Some((tt, v / det, w / det))
}

/// Möller–Trumbore without an epsilon.
fn moller(t: &Tri, o: [f32; 3], d: [f32; 3]) -> Option<Hit> {
    let e1 = sub(t.v[1], t.v[0]);
    let e2 = sub(t.v[2], t.v[0]);
    let p = cross(d, e2);
    let det = dot(e1, p);
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let inv = 1.0 / det;
    let s = sub(o, t.v[0]);
    let u = dot(s, p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = cross(s, e1);
    let v = dot(d, q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    Some((dot(e2, q) * inv, u, v))
}

/// The triangles of a GAS, if the stand-in can trace it (static float3 triangles, no
/// pre-transform, no per-primitive SBT offsets, one record per input).
fn triangles(case: &Case, node: usize) -> Option<Vec<(Tri, u32)>> {
    let Node::Gas(g) = &case.scene.nodes[node] else {
        return None;
    };
    if g.motion.is_some() {
        return None;
    }
    let mut out = Vec::new();
    for (input, gi) in g.inputs.iter().zip(0u32..) {
        let GeomInput::Triangles(t) = input else {
            return None;
        };
        if t.format != VertexFormat::Float3
            || t.pre_transform.is_some()
            || t.sbt_offsets.is_some()
            || t.keys.len() != 1
            || t.omm.is_some()
        {
            return None;
        }
        for i in 0..t.num_triangles() {
            let idx = t.triangle(i);
            let v = idx.map(|k| t.keys[0][k]);
            out.push((
                Tri {
                    v,
                    prim: i as u32 + t.prim_index_offset,
                    flags: t.flags[0],
                },
                gi,
            ));
        }
    }
    Some(out)
}

/// Whether the stand-in can run the case: the standard raygen, closest-hit, any-hit and miss
/// programs only, and at least one launch against a GAS it can trace.
fn supported(case: &Case) -> bool {
    let p = &case.pipeline;
    p.raygen == prog::RAYGEN
        && p.miss.iter().all(|m| m.as_deref() == Some(prog::MS))
        && p.hit.iter().all(|h| {
            h.closest_hit.as_deref() == Some(prog::CH)
                && h.intersection.is_none()
                && h.any_hit.as_deref().is_none_or(|a| a == prog::AH)
        })
        && p.callables.is_empty()
        && p.exception.is_none()
        && (0..case.launches.len()).any(|k| launch_supported(case, k))
}

/// Whether launch `k` traces a GAS the stand-in can trace.
fn launch_supported(case: &Case, k: usize) -> bool {
    matches!(case.launches[k].params[0], ParamWord::HandleLo(Some(n)) if triangles(case, n).is_some())
}

/// Runs one launch with the stand-in tracer; returns the record buffer.
fn run_launch(case: &Case, k: usize, variant: Variant) -> Vec<u32> {
    let launch = &case.launches[k];
    let ParamWord::HandleLo(Some(root)) = launch.params[0] else {
        unreachable!("checked by supported()")
    };
    let tris = triangles(case, root).expect("checked by supported()");
    let rays = &launch
        .buffers
        .iter()
        .find(|b| b.binding == 1)
        .expect("rays")
        .words;
    let mut out = launch
        .buffers
        .iter()
        .find(|b| b.binding == 2)
        .expect("records")
        .words
        .clone();
    let n = match launch.params[2] {
        ParamWord::U32(n) => n as usize,
        _ => 0,
    };
    for id in 0..n {
        let w = &rays[id * 16..id * 16 + 16];
        let f = |i: usize| f32::from_bits(w[i]);
        let (o, d, tmin, tmax) = ([f(0), f(1), f(2)], [f(4), f(5), f(6)], f(3), f(7));
        let s = id * rec::STRIDE;
        let (mut p0, mut p1) = (0u32, 0u32);
        let valid = o.iter().chain(d.iter()).all(|c| c.is_finite())
            && tmin >= 0.0
            && !tmax.is_nan()
            && tmin <= tmax;
        if valid {
            let mut cands: Vec<(f32, f32, f32, usize)> = Vec::new();
            for (i, (t, _)) in tris.iter().enumerate() {
                // Zero-area triangles never hit (pbrt-v4's test on the stored vertices).
                let area = cross(sub(t.v[1], t.v[0]), sub(t.v[2], t.v[0]));
                if variant != Variant::NoDegenerateCheck && area == [0.0; 3] {
                    continue;
                }
                let hit = match variant {
                    Variant::MollerTrumbore => moller(t, o, d),
                    Variant::WatertightDoubleHits => woop(t, o, d, false),
                    _ => woop(t, o, d, true),
                };
                if let Some((tt, u, v)) = hit {
                    let inside = if variant == Variant::ClosedInterval {
                        tt >= tmin && tt <= tmax
                    } else {
                        tt > tmin && tt < tmax
                    };
                    if inside {
                        cands.push((tt, u, v, i));
                    }
                }
            }
            cands.sort_by(|a, b| a.0.total_cmp(&b.0));
            let mut closest: Option<(f32, f32, f32, usize, usize)> = None;
            for (tt, u, v, i) in cands {
                if closest.is_some_and(|c| tt >= c.0) {
                    continue;
                }
                let (tri, gi) = &tris[i];
                let record = (w[11] & 0xF) as usize + *gi as usize * (w[12] & 0xF) as usize;
                let entry = &case.sbt.hit[record];
                let group = &case.pipeline.hit[entry.group];
                if !tri.flags.contains(GeometryFlags::DISABLE_ANYHIT) && group.any_hit.is_some() {
                    p0 |= 4;
                    p1 += 1;
                    if entry.data.get(1) == Some(&action::IGNORE) {
                        continue;
                    }
                }
                closest = Some((tt, u, v, i, record));
            }
            match closest {
                Some((tt, u, v, i, record)) => {
                    let (tri, gi) = &tris[i];
                    let n = cross(sub(tri.v[1], tri.v[0]), sub(tri.v[2], tri.v[0]));
                    let front = (dot(n, d) < 0.0) != (variant == Variant::SwappedFacing);
                    let words = [
                        (rec::HIT, 1),
                        (rec::T, tt.to_bits()),
                        (rec::PRIM, tri.prim),
                        (rec::INST_ID, 0),
                        (rec::INST_INDEX, 0),
                        (rec::GAS_INDEX, *gi),
                        (rec::HIT_KIND, if front { 0xFE } else { 0xFF }),
                        (rec::ATTR0, u.to_bits()),
                        (rec::ATTR0 + 1, v.to_bits()),
                        (rec::SBT_INDEX, case.sbt.hit[record].data[0]),
                    ];
                    for (k, v) in words {
                        out[s + k] = v;
                    }
                    p0 |= 8;
                }
                None => {
                    out[s + rec::HIT] = 0;
                    out[s + rec::SBT_INDEX] = case.sbt.miss[(w[13] & 0xFFFF) as usize].data[0];
                    p0 |= 16;
                }
            }
        }
        out[s + rec::PROGRAMS] |= p0 | 1;
        out[s + rec::AH_COUNT] = p1;
        let payload = [p0, p1, w[14], 0, 0, 0, 0, 0];
        for (k, v) in payload.into_iter().enumerate() {
            out[s + rec::PAYLOAD0 + k] = v;
        }
    }
    out
}

/// Runs every supported case with `variant`; returns (case name, pass, detail).
fn run(variant: Variant, only: &[&str]) -> Vec<(String, bool, String)> {
    let mut results = Vec::new();
    for case in optik_conformance::catalog::all()
        .into_iter()
        .filter(supported)
    {
        if !only.is_empty() && !only.contains(&case.name.as_str()) {
            continue;
        }
        let expected = runner::expectations(&case).unwrap_or_else(|e| panic!("{}: {e}", case.name));
        let mut pass = true;
        let mut detail = String::new();
        for (k, e) in expected
            .iter()
            .enumerate()
            .filter(|(k, _)| launch_supported(&case, *k))
        {
            let words = run_launch(&case, k, variant);
            let image = judge::image_from_words(&case, e.width, e.height, &words);
            let v = judge::judge(&case, e, &image, None);
            if !v.pass {
                pass = false;
                detail = format!("launch {k}: {}", v.detail);
            }
        }
        results.push((case.name.clone(), pass, detail));
    }
    results
}

#[test]
fn a_correct_watertight_f32_intersector_passes_every_case_it_can_run() {
    let results = run(Variant::Watertight, &[]);
    assert!(
        results.len() >= 15,
        "only {} cases ran: {:?}",
        results.len(),
        results.iter().map(|r| &r.0).collect::<Vec<_>>()
    );
    let failures: Vec<String> = results
        .iter()
        .filter(|r| !r.1)
        .map(|r| format!("{}: {}", r.0, r.2))
        .collect();
    assert!(
        failures.is_empty(),
        "a correct intersector fails:\n{}",
        failures.join("\n")
    );
    eprintln!(
        "passed: {:?}",
        results.iter().map(|r| &r.0).collect::<Vec<_>>()
    );
}

/// Asserts every case of `names` fails with `variant`.
fn assert_fail(variant: Variant, names: &[&str]) {
    let results = run(variant, names);
    assert_eq!(
        results.len(),
        names.len(),
        "cases not runnable: {names:?} vs {:?}",
        results.iter().map(|r| &r.0).collect::<Vec<_>>()
    );
    for (name, pass, detail) in &results {
        assert!(!pass, "{name} does not catch {variant:?}");
        eprintln!("{name} catches {variant:?}: {detail}");
    }
}

#[test]
fn moller_trumbore_leaks_through_shared_edges_and_vertices() {
    assert_fail(
        Variant::MollerTrumbore,
        &[
            "tri.closed_fan",
            "numerics.shared_vertex_origin",
            "numerics.fan_high_valence",
        ],
    );
}

#[test]
fn double_hits_on_exact_edges_break_the_closed_mesh_invariant() {
    assert_fail(
        Variant::WatertightDoubleHits,
        &[
            "tri.closed_fan",
            "numerics.axis_aligned_integer_mesh",
            "numerics.shared_vertex_origin",
        ],
    );
}

#[test]
fn a_closed_t_interval_is_caught() {
    assert_fail(
        Variant::ClosedInterval,
        &["tri.t_interval_bounds", "numerics.tmin_tmax_ulps"],
    );
}

#[test]
fn swapped_facing_is_caught() {
    assert_fail(
        Variant::SwappedFacing,
        &[
            "tri.t_plane",
            "tri.complex_mesh_hitrate",
            "tri.barycentrics",
        ],
    );
}

#[test]
fn hitting_degenerate_triangles_is_caught() {
    assert_fail(
        Variant::NoDegenerateCheck,
        &["numerics.degenerate_neighbours"],
    );
}
