//! The oracle's execution model: OptiX's program semantics (DESIGN.md §3–§4) over the
//! brute-force geometry of [`super::geometry`], running a case's program models.
//!
//! One trace: check the ray against the invalid-ray policy; walk every instance and
//! primitive (no BVH) and collect contacts; settle each ambiguity through the [`Chooser`];
//! visit the candidates in t order (or reversed, to show a case does not depend on order);
//! apply culling and opacity rules from `optik_api::semantics` (the spec); run
//! intersection and any-hit models; then the closest-hit or miss model.

use super::choice::Chooser;
use super::geometry::{self, BoxContact, ObjRay, RoundContact, Rounding, TriContact};
use super::math::*;
use super::model::{Flow, Models, Unwind};
use super::prepared::{GasData, PNode, Prims, node_of};
use crate::case::{Case, SbtEntry};
use optik::semantics::{exception, facing, motion, opacity, ray as ray_policy, sbt_index};
use optik::{ExceptionFlags, GeometryFlags, InstanceFlags, ProgramKind, RayFlags};
use std::cell::RefCell;
use std::collections::HashMap;
use std::rc::Rc;

/// The code the model unwinds with when a case relies on undefined behaviour (never a real
/// exception code: user codes are non-negative, built-in ones small negatives).
const UNDEFINED: i32 = i32::MIN;

/// The order candidates are visited in (real traversal order is unspecified, so a case's
/// expectation must not depend on it: the catalog tests both).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Order {
    /// Nearest first.
    Ascending,
    /// Farthest first.
    Descending,
}

/// Pipeline-wide settings the model needs.
#[derive(Clone, Copy, Debug)]
pub struct Settings {
    /// Candidate order.
    pub order: Order,
    /// Exceptions checked.
    pub exceptions: ExceptionFlags,
    /// Whether rays carry time.
    pub motion: bool,
    /// `max_trace_depth` of the link options.
    pub max_trace_depth: u32,
    /// Payload registers (the length of `RtPayload`).
    pub payload_len: usize,
    /// Ambiguity bands.
    pub rounding: Rounding,
}

/// Storage buffers by binding, as words.
pub type Buffers = HashMap<u32, Vec<u32>>;

/// The state of one launch index's run.
pub struct ExecState<'b> {
    chooser: &'b mut Chooser,
    buffers: &'b Buffers,
    /// Writes of this run: (binding, word) → value.
    pub overlay: HashMap<(u32, usize), u32>,
    depth: u32,
    index: [u32; 3],
    dims: [u32; 3],
    params: &'b [u32],
    /// Reads of words no buffer holds, for error reports.
    pub bad_access: Option<String>,
}

impl<'b> ExecState<'b> {
    /// The state for launch index `index`.
    pub fn new(
        chooser: &'b mut Chooser,
        buffers: &'b Buffers,
        params: &'b [u32],
        index: [u32; 3],
        dims: [u32; 3],
    ) -> Self {
        ExecState {
            chooser,
            buffers,
            overlay: HashMap::new(),
            depth: 0,
            index,
            dims,
            params,
            bad_access: None,
        }
    }
}

/// The hit (or, in intersection programs, the primitive) programs see.
#[derive(Clone, Debug)]
pub struct HitInfo {
    /// Distance (f64, as the oracle computed it).
    pub t: f64,
    /// Reported primitive index.
    pub prim: u32,
    /// SBT GAS index.
    pub gas_index: u32,
    /// Instance id (0 without instances).
    pub inst_id: u32,
    /// Instance index (0 without instances).
    pub inst_index: u32,
    /// Hit kind.
    pub hit_kind: u32,
    /// Attribute registers.
    pub attributes: [u32; 8],
    /// Object-space ray.
    pub obj: ObjRay,
    /// Object-to-world and world-to-object.
    pub o2w: M34,
    /// World-to-object.
    pub w2o: M34,
    /// Triangle vertices (object space).
    pub verts: Option<[V3; 3]>,
    /// Sphere centre and radius.
    pub sphere: Option<[f64; 4]>,
    /// Curve parameter.
    pub curve_u: f64,
    /// The hit group record's data.
    pub record: Vec<u32>,
    /// The geometry flags of the primitive's record.
    pub geom_flags: GeometryFlags,
    /// The instance flags on the path (nearest instance).
    pub inst_flags: InstanceFlags,
    /// The opacity micromap state at the hit (level 0: the triangle's).
    pub micromap: Option<opacity::MicromapState>,
}

/// The ray programs see.
#[derive(Clone, Copy, Debug)]
pub struct RayView {
    /// World origin as traced.
    pub origin: [f32; 3],
    /// World direction as traced.
    pub direction: [f32; 3],
    /// tmin.
    pub tmin: f32,
    /// tmax as traced.
    pub tmax: f32,
    /// Time (0 without motion).
    pub time: f32,
    /// Flags as traced.
    pub flags: u32,
    /// Mask as traced.
    pub mask: u32,
    /// SBT offset as traced.
    pub sbt_offset: u32,
    /// SBT stride as traced.
    pub sbt_stride: u32,
}

/// A committed hit.
#[derive(Clone, Debug)]
struct Committed {
    hit: HitInfo,
    dt: f64,
    group: usize,
}

/// The state of one traversal, shared with intersection programs.
pub struct Traversal {
    ray: RayView,
    payload: Vec<u32>,
    closest: Option<Committed>,
    tmax_cur: f64,
    terminated: bool,
    /// The candidate an intersection program is reporting for.
    current: Option<(HitInfo, usize)>,
}

/// The context a program model runs in: the device API.
pub struct Ctx<'a, 'b> {
    eng: &'a Engine<'a>,
    st: &'a mut ExecState<'b>,
    /// The kind of program running.
    pub kind: ProgramKind,
    payload: Vec<u32>,
    hit: Option<HitInfo>,
    ray: Option<RayView>,
    visible_tmax: f64,
    record: Vec<u32>,
    traversal: Option<&'a mut Traversal>,
    exception_code: i32,
}

/// The engine for one case.
pub struct Engine<'c> {
    case: &'c Case,
    nodes: Vec<PNode>,
    models: &'c Models,
    cache: RefCell<HashMap<Vec<u32>, Rc<TraceGeometry>>>,
    /// Settings.
    pub settings: Settings,
}

/// A cluster of ambiguous triangles and the sets of them that may be hit.
struct Cluster {
    members: Vec<usize>,
    outcomes: Vec<Vec<bool>>,
    reason: &'static str,
}

/// Everything a ray meets, before ambiguity is settled.
struct TraceGeometry {
    contacts: Vec<Contact>,
    clusters: Vec<Cluster>,
}

/// A contact of the current trace, before ambiguity is settled.
#[derive(Clone, Debug)]
struct Contact {
    /// The object space (the bits of world-to-object): contacts with identical transforms
    /// share rounding, so one ambiguity cluster may span instances (CTS closedFan2).
    space: [u64; 12],
    path: Path,
    obj: ObjRay,
    prim: u32,
    gas_index: u32,
    geom_flags: GeometryFlags,
    micromap: Option<opacity::MicromapState>,
    geo: Geo,
}

#[derive(Clone, Debug)]
enum Geo {
    Tri(TriContact, [V3; 3]),
    Box(BoxContact),
    Round(RoundContact, Option<[f64; 4]>),
}

#[derive(Clone, Debug)]
struct Path {
    inst_id: u32,
    inst_index: u32,
    sbt_offset: u32,
    inst_flags: InstanceFlags,
    flip: bool,
    w2o: M34,
    o2w: M34,
    instanced: bool,
}

impl<'c> Engine<'c> {
    /// An engine for `case` with these settings.
    pub fn new(case: &'c Case, nodes: Vec<PNode>, settings: Settings) -> Self {
        Engine {
            case,
            nodes,
            models: &case.models,
            cache: RefCell::new(HashMap::new()),
            settings,
        }
    }

    fn model(&self, name: &str) -> Result<&super::model::ProgramFn, Unwind> {
        // A missing model is a defect of the case, caught by the catalog's own tests.
        self.models.get(name).ok_or(Unwind::Throw(UNDEFINED))
    }

    /// Runs the raygen model for one launch index, then the exception model if it threw.
    pub fn run_index(&self, st: &mut ExecState<'_>) -> Result<(), String> {
        let raygen = self.case.pipeline.raygen.clone();
        let f = self
            .model(&raygen)
            .map_err(|_| format!("no model of the raygen program `{raygen}`"))?
            .clone();
        let result = f(&mut Ctx::new(
            self,
            st,
            ProgramKind::Raygen,
            self.case.sbt.raygen_data.clone(),
        ));
        match result {
            Ok(()) | Err(Unwind::Ignore) | Err(Unwind::Terminate) => Ok(()),
            Err(Unwind::Throw(UNDEFINED)) => Err(
                "the case relies on undefined behaviour: a program without a model, or a hit or miss SBT index beyond the table without debug exceptions"
                    .into(),
            ),
            Err(Unwind::Throw(code)) => {
                if let Some(ex) = self.case.pipeline.exception.clone() {
                    let f = self
                        .model(&ex)
                        .map_err(|_| format!("no model of the exception program `{ex}`"))?
                        .clone();
                    let mut ctx = Ctx::new(
                        self,
                        st,
                        ProgramKind::Exception,
                        self.case.sbt.exception_data.clone(),
                    );
                    ctx.exception_code = code;
                    let _ = f(&mut ctx);
                }
                Ok(())
            }
        }
    }

    fn exception_enabled(&self, code: i32) -> bool {
        let f = self.settings.exceptions;
        match code {
            c if c >= 0 => f.contains(ExceptionFlags::USER),
            exception::TRACE_DEPTH_EXCEEDED => f.contains(ExceptionFlags::TRACE_DEPTH),
            exception::STACK_OVERFLOW => f.contains(ExceptionFlags::STACK_OVERFLOW),
            _ => f.contains(ExceptionFlags::DEBUG),
        }
    }

    fn hit_entry(&self, index: u64) -> Option<&SbtEntry> {
        usize::try_from(index)
            .ok()
            .and_then(|i| self.case.sbt.hit.get(i))
    }

    /// Collects every contact of the ray with the traversable `node`.
    fn walk(
        &self,
        node: usize,
        path: &Path,
        wo: V3,
        wd: V3,
        ray: &RayView,
        out: &mut Vec<Contact>,
    ) {
        match &self.nodes[node] {
            PNode::Gas(g) => self.walk_gas(g, path, wo, wd, ray, out),
            PNode::Ias(instances) => {
                for (i, inst) in instances.iter().enumerate() {
                    let (Some(child), Some(w2o)) = (inst.child, inst.w2o) else {
                        continue;
                    };
                    if !sbt_index::instance_visible(inst.mask, ray.mask) {
                        continue;
                    }
                    let p = Path {
                        inst_id: inst.id & sbt_index::INSTANCE_ID_MASK,
                        inst_index: i as u32,
                        sbt_offset: path
                            .sbt_offset
                            .wrapping_add(inst.sbt_offset & sbt_index::INSTANCE_SBT_OFFSET_MASK),
                        inst_flags: inst.flags,
                        flip: path.flip ^ facing::flips(inst.flags),
                        w2o: m_mul(&w2o, &path.w2o),
                        o2w: m_mul(&path.o2w, &inst.o2w),
                        instanced: true,
                    };
                    self.walk(child, &p, wo, wd, ray, out);
                }
            }
            PNode::Transform(kind, child) => {
                let time = ray.time;
                let o2w32 = match kind {
                    crate::scene::TransformKind::Static(m) => Some(*m),
                    crate::scene::TransformKind::MatrixMotion(opts, keys) => {
                        motion::resolve_key(opts, time).map(|k| motion::interpolate_matrix(keys, k))
                    }
                    crate::scene::TransformKind::SrtMotion(opts, keys) => {
                        motion::resolve_key(opts, time)
                            .map(|k| motion::srt_to_matrix(&motion::interpolate_srt(keys, k)))
                    }
                };
                let Some(o2w32) = o2w32 else { return };
                let o2w = m_from_f32(&o2w32);
                let Some(w2o) = m_inverse(&o2w) else { return };
                let p = Path {
                    w2o: m_mul(&w2o, &path.w2o),
                    o2w: m_mul(&path.o2w, &o2w),
                    instanced: true,
                    ..path.clone()
                };
                self.walk(*child, &p, wo, wd, ray, out);
            }
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn walk_gas(
        &self,
        g: &GasData,
        path: &Path,
        wo: V3,
        wd: V3,
        ray: &RayView,
        out: &mut Vec<Contact>,
    ) {
        let key = match &g.motion {
            Some(m) => match motion::resolve_key(m, ray.time) {
                Some(k) => Some(k),
                None => return,
            },
            None => None,
        };
        let o = m_point(&path.w2o, wo);
        let d = m_vector(&path.w2o, wd);
        let mut extra = 0.0;
        // Transforms add a few unit roundoffs of the magnitudes they combine (pbrt-v4's γ(3)
        // bounds): a quarter of the triangle band (4 roundoffs) covers them.
        if path.instanced {
            // Per object coordinate j, the terms Σ_k |W_jk · o_k| + |t_j| the transform sums.
            let terms = (0..3)
                .map(|r| {
                    (0..3)
                        .map(|c| (path.w2o[r * 4 + c] * wo[c]).abs())
                        .sum::<f64>()
                        + path.w2o[r * 4 + 3].abs()
                })
                .fold(0.0, f64::max);
            extra += 0.25 * terms;
        }
        if g.motion.is_some() {
            extra += 0.25 * g.magnitude;
        }
        let obj = ObjRay { o, d, extra };
        let rnd = &self.settings.rounding;
        let lerp = |a: f64, b: f64| match key {
            Some(k) if k.t != 0.0 => a * (1.0 - k.t as f64) + b * k.t as f64,
            _ => a,
        };
        let at = |keys: usize| -> (usize, usize) {
            match key {
                Some(k) => (k.key.min(keys - 1), (k.key + 1).min(keys - 1)),
                None => (0, 0),
            }
        };
        for input in &g.inputs {
            for i in 0..input.count {
                let record = input.offsets.get(i).copied().unwrap_or(0);
                let geom_flags = input
                    .flags
                    .get(record as usize)
                    .copied()
                    .unwrap_or(GeometryFlags::NONE);
                let make = |geo: Geo| Contact {
                    space: path.w2o.map(f64::to_bits),
                    path: path.clone(),
                    obj,
                    prim: i as u32 + input.prim_index_offset,
                    gas_index: sbt_index::sbt_gas_index(input.first_record, record),
                    geom_flags,
                    micromap: None,
                    geo,
                };
                match &input.prims {
                    Prims::Triangles { keys, tris, omm } => {
                        let Some(tri) = tris[i] else { continue };
                        let (ka, kb) = at(keys.len());
                        let v: [V3; 3] = std::array::from_fn(|j| {
                            let (a, b) = (keys[ka][tri[j]], keys[kb][tri[j]]);
                            [lerp(a[0], b[0]), lerp(a[1], b[1]), lerp(a[2], b[2])]
                        });
                        if let Some(c) = geometry::triangle(v, &obj, rnd) {
                            let mut contact = make(Geo::Tri(c, v));
                            contact.micromap = omm.as_ref().and_then(|m| m.get(i).copied());
                            out.push(contact);
                        }
                    }
                    Prims::Aabbs(keys) => {
                        let (ka, kb) = at(keys.len());
                        let b: [f64; 6] =
                            std::array::from_fn(|j| lerp(keys[ka][i][j], keys[kb][i][j]));
                        if let Some(c) =
                            geometry::aabb(b, &obj, ray.tmin as f64, ray.tmax as f64, rnd)
                        {
                            out.push(make(Geo::Box(c)));
                        }
                    }
                    Prims::Spheres {
                        centres,
                        radii,
                        single,
                    } => {
                        let (ka, kb) = at(centres.len());
                        let c = centres[ka][i];
                        let c2 = centres[kb][i];
                        let centre = [lerp(c[0], c2[0]), lerp(c[1], c2[1]), lerp(c[2], c2[2])];
                        let ri = if *single { 0 } else { i };
                        let (ra, rb) = at(radii.len());
                        let radius = lerp(radii[ra][ri], radii[rb][ri]);
                        if let Some(c) = geometry::sphere(centre, radius, &obj, rnd, true) {
                            out.push(make(Geo::Round(
                                c,
                                Some([centre[0], centre[1], centre[2], radius]),
                            )));
                        }
                    }
                    Prims::Curves {
                        points,
                        radii,
                        segments,
                    } => {
                        let (ka, kb) = at(points.len());
                        let s = segments[i] as usize;
                        let p = |j: usize| {
                            let (a, b) = (points[ka][j], points[kb][j]);
                            [lerp(a[0], b[0]), lerp(a[1], b[1]), lerp(a[2], b[2])]
                        };
                        let radius = lerp(radii[ka][s], radii[kb][s]);
                        if let Some(c) = geometry::capsule(p(s), p(s + 1), radius, &obj, rnd) {
                            out.push(make(Geo::Round(c, None)));
                        }
                    }
                }
            }
        }
    }

    /// `rt_trace`: the whole traversal of one ray, updating `payload`.
    #[allow(clippy::too_many_arguments)]
    pub fn trace(
        &self,
        st: &mut ExecState<'_>,
        handle: [u32; 2],
        ray: RayView,
        miss_index: u32,
        payload: &mut [u32],
    ) -> Flow {
        let max_depth = self.settings.max_trace_depth;
        if st.depth >= max_depth {
            if self.exception_enabled(exception::TRACE_DEPTH_EXCEEDED) {
                return Err(Unwind::Throw(exception::TRACE_DEPTH_EXCEEDED));
            }
            // Undefined without the exception enabled; the catalog never relies on it.
            return Ok(());
        }
        if ray_policy::check(ray.origin, ray.direction, ray.tmin, ray.tmax).is_err() {
            if self.exception_enabled(exception::INVALID_RAY) {
                return Err(Unwind::Throw(exception::INVALID_RAY));
            }
            return Ok(());
        }
        let ray = RayView {
            time: if self.settings.motion { ray.time } else { 0.0 },
            ..ray
        };
        let geometry = self.geometry_of(handle, &ray);
        let candidates = self.settle(st.chooser, &geometry);
        let mut tr = Traversal {
            ray,
            payload: payload.to_vec(),
            closest: None,
            tmax_cur: ray.tmax as f64,
            terminated: false,
            current: None,
        };
        st.depth += 1;
        let result = self.traverse(st, &mut tr, candidates);
        let result = result.and_then(|_| self.finish(st, &mut tr, miss_index));
        st.depth -= 1;
        if result.is_ok() {
            payload.copy_from_slice(&tr.payload[..payload.len()]);
        }
        result
    }

    /// Settles the ambiguities of this run: which ambiguous triangles of each contact
    /// cluster are hit, which round silhouettes, which boxes' intersection programs run.
    /// The geometry of a trace: its contacts and the admissible outcomes of each cluster of
    /// ambiguous triangles. The same ray meets the same geometry in every run of its launch
    /// index, so this is computed once per ray and kept.
    fn geometry_of(&self, handle: [u32; 2], ray: &RayView) -> Rc<TraceGeometry> {
        let key: Vec<u32> = [handle[0], handle[1]]
            .into_iter()
            .chain(ray.origin.map(f32::to_bits))
            .chain(ray.direction.map(f32::to_bits))
            .chain([
                ray.tmin.to_bits(),
                ray.tmax.to_bits(),
                ray.time.to_bits(),
                ray.mask,
            ])
            .collect();
        if let Some(g) = self.cache.borrow().get(&key) {
            return g.clone();
        }
        let mut contacts = Vec::new();
        if let Some(node) = node_of(handle, self.nodes.len()) {
            let root = Path {
                inst_id: 0,
                inst_index: 0,
                sbt_offset: 0,
                inst_flags: InstanceFlags::NONE,
                flip: false,
                w2o: IDENTITY,
                o2w: IDENTITY,
                instanced: false,
            };
            self.walk(
                node,
                &root,
                from_f32(ray.origin),
                from_f32(ray.direction),
                ray,
                &mut contacts,
            );
        }
        // Clusters: ambiguous triangles of one object space whose t bands overlap.
        let mut amb: Vec<usize> = (0..contacts.len())
            .filter(|&i| matches!(&contacts[i].geo, Geo::Tri(c, _) if c.status == geometry::Status::Ambiguous))
            .collect();
        amb.sort_by(|&a, &b| {
            let (ta, tb) = (tri_of(&contacts[a]).t, tri_of(&contacts[b]).t);
            contacts[a]
                .space
                .cmp(&contacts[b].space)
                .then(ta.total_cmp(&tb))
        });
        let mut groups: Vec<Vec<usize>> = Vec::new();
        for i in amb {
            let c = tri_of(&contacts[i]);
            let joins = groups.last().and_then(|g| g.last()).is_some_and(|&j| {
                let p = tri_of(&contacts[j]);
                contacts[j].space == contacts[i].space && c.t - p.t <= 4.0 * (c.dt + p.dt) + 1e-300
            });
            match groups.last_mut() {
                Some(g) if joins => g.push(i),
                _ => groups.push(vec![i]),
            }
        }
        let clusters = groups
            .into_iter()
            .map(|members| {
                let tris: Vec<&TriContact> =
                    members.iter().map(|&i| tri_of(&contacts[i])).collect();
                let outcomes = geometry::cluster_outcomes(&tris, contacts[members[0]].obj.d);
                let vertex = tris
                    .iter()
                    .any(|m| m.edges.iter().filter(|e| e.near).count() >= 2);
                Cluster {
                    members,
                    outcomes,
                    reason: if vertex { "vertex" } else { "edge" },
                }
            })
            .collect();
        let g = Rc::new(TraceGeometry { contacts, clusters });
        self.cache.borrow_mut().insert(key, g.clone());
        g
    }

    /// Settles the ambiguities of this run: which ambiguous triangles of each contact
    /// cluster are hit, which round silhouettes, which boxes' intersection programs run.
    fn settle(&self, chooser: &mut Chooser, g: &TraceGeometry) -> Vec<Contact> {
        let contacts = &g.contacts;
        let mut keep = vec![true; contacts.len()];
        for cl in &g.clusters {
            let pick = if cl.outcomes.is_empty() {
                vec![false; cl.members.len()]
            } else {
                cl.outcomes[chooser.choose(cl.outcomes.len(), cl.reason)].clone()
            };
            for (k, &i) in cl.members.iter().enumerate() {
                keep[i] = pick[k];
            }
        }
        for (i, c) in contacts.iter().enumerate() {
            match &c.geo {
                Geo::Round(r, _) if r.ambiguous => keep[i] = chooser.choose(2, "silhouette") == 0,
                Geo::Box(b) if b.ambiguous => keep[i] = chooser.choose(2, "box face") == 0,
                _ => {}
            }
        }
        let mut out: Vec<Contact> = contacts
            .iter()
            .zip(keep)
            .filter(|(_, k)| *k)
            .map(|(c, _)| c.clone())
            .collect();
        let key = |c: &Contact| match &c.geo {
            Geo::Tri(t, _) => t.t,
            Geo::Box(b) => b.t_enter,
            Geo::Round(r, _) => r.t,
        };
        out.sort_by(|a, b| {
            key(a)
                .partial_cmp(&key(b))
                .unwrap_or(std::cmp::Ordering::Equal)
        });
        if self.settings.order == Order::Descending {
            out.reverse();
        }
        out
    }

    /// Whether `t` (with band `dt`) is beyond the current closest hit or tmax: `true` when it
    /// is out. Ties within the bands are decided by the chooser.
    fn beyond(&self, chooser: &mut Chooser, tr: &Traversal, t: f64, dt: f64, closed: bool) -> bool {
        let (limit, band, reason) = match &tr.closest {
            Some(c) => (c.hit.t, dt.max(c.dt), "t tie"),
            None => (tr.tmax_cur, dt, "t at tmax"),
        };
        let exact_out = if closed { t > limit } else { t >= limit };
        if (t - limit).abs() <= band && band > 0.0 {
            let flip = chooser.choose(2, reason) == 1;
            return exact_out != flip;
        }
        exact_out
    }

    /// Whether `t` is before tmin (open interval for triangles).
    fn before(&self, chooser: &mut Chooser, tr: &Traversal, t: f64, dt: f64) -> bool {
        let tmin = tr.ray.tmin as f64;
        let exact_out = t <= tmin;
        if (t - tmin).abs() <= dt && dt > 0.0 {
            let flip = chooser.choose(2, "t at tmin") == 1;
            return exact_out != flip;
        }
        exact_out
    }

    fn hit_info(
        &self,
        c: &Contact,
        t: f64,
        hit_kind: u32,
        attributes: [u32; 8],
        record: Vec<u32>,
    ) -> HitInfo {
        let (verts, sphere, curve_u) = match &c.geo {
            Geo::Tri(_, v) => (Some(*v), None, 0.0),
            Geo::Round(r, s) => (None, *s, r.u),
            Geo::Box(_) => (None, None, 0.0),
        };
        HitInfo {
            t,
            prim: c.prim,
            gas_index: c.gas_index,
            inst_id: c.path.inst_id,
            inst_index: c.path.inst_index,
            hit_kind,
            attributes,
            obj: c.obj,
            o2w: c.path.o2w,
            w2o: c.path.w2o,
            verts,
            sphere,
            curve_u,
            record,
            geom_flags: c.geom_flags,
            inst_flags: c.path.inst_flags,
            micromap: c.micromap,
        }
    }

    fn traverse(
        &self,
        st: &mut ExecState<'_>,
        tr: &mut Traversal,
        candidates: Vec<Contact>,
    ) -> Flow {
        let flags = RayFlags(tr.ray.flags);
        for c in candidates {
            if tr.terminated {
                break;
            }
            let index = sbt_index::hit_record_index(
                c.path.sbt_offset,
                c.gas_index,
                tr.ray.sbt_offset,
                tr.ray.sbt_stride,
            );
            let Some(entry) = self.hit_entry(index).cloned() else {
                if self.exception_enabled(exception::INVALID_HIT_SBT) {
                    return Err(Unwind::Throw(exception::INVALID_HIT_SBT));
                }
                // Undefined without debug exceptions: a case must not rely on it.
                return Err(Unwind::Throw(UNDEFINED));
            };
            let group = self
                .case
                .pipeline
                .hit
                .get(entry.group)
                .cloned()
                .unwrap_or_default();
            match &c.geo {
                Geo::Box(b) => {
                    if self.beyond(st.chooser, tr, b.t_enter, 0.0, true) {
                        continue;
                    }
                    // A box's opacity is known from the flags alone, so culling happens before
                    // its intersection program runs (Vulkan's order: culling, then AABB
                    // candidates).
                    let fate = opacity::resolve(
                        c.geom_flags,
                        c.path.inst_flags,
                        RayFlags(tr.ray.flags),
                        None,
                    );
                    if fate == opacity::CandidateFate::Culled {
                        continue;
                    }
                    let Some(is) = group.intersection.clone() else {
                        continue;
                    };
                    let f = self.model(&is)?.clone();
                    let info = self.hit_info(&c, 0.0, 0, [0; 8], entry.data.clone());
                    tr.current = Some((info.clone(), entry.group));
                    let visible = match &tr.closest {
                        Some(cl) => cl.hit.t,
                        None => tr.tmax_cur,
                    };
                    let ray = tr.ray;
                    let r = {
                        let mut ctx =
                            Ctx::new(self, st, ProgramKind::Intersection, entry.data.clone());
                        ctx.hit = Some(info);
                        ctx.ray = Some(ray);
                        ctx.visible_tmax = visible;
                        ctx.traversal = Some(&mut *tr);
                        f(&mut ctx)
                    };
                    tr.current = None;
                    match r {
                        Ok(()) | Err(Unwind::Ignore) => {}
                        Err(Unwind::Terminate) => tr.terminated = true,
                        Err(e) => return Err(e),
                    }
                }
                Geo::Tri(tc, _) => {
                    let (t, dt) = (tc.t, tc.dt);
                    if self.before(st.chooser, tr, t, dt)
                        || self.beyond(st.chooser, tr, t, dt, false)
                    {
                        continue;
                    }
                    let front = facing::is_front_face(tc.n_dot_d, c.path.flip);
                    if opacity::triangle_face_culled(front, c.geom_flags, c.path.inst_flags, flags)
                    {
                        continue;
                    }
                    let bary = [
                        (tc.bary[0] as f32).to_bits(),
                        (tc.bary[1] as f32).to_bits(),
                        0,
                        0,
                        0,
                        0,
                        0,
                        0,
                    ];
                    let info = self.hit_info(
                        &c,
                        t,
                        facing::triangle_hit_kind(front),
                        bary,
                        entry.data.clone(),
                    );
                    self.candidate(st, tr, info, dt, entry.group)?;
                }
                Geo::Round(rc, _) => {
                    let (t, dt) = (rc.t, rc.dt);
                    if self.before(st.chooser, tr, t, dt)
                        || self.beyond(st.chooser, tr, t, dt, false)
                    {
                        continue;
                    }
                    // Built-in spheres and curves use the triangle hit kinds
                    // (docs/decisions.md); curves carry their parameter in attribute 0.
                    let kind = facing::triangle_hit_kind(rc.front);
                    let mut attrs = [0u32; 8];
                    if matches!(c.geo, Geo::Round(_, None)) {
                        attrs[0] = (rc.u as f32).to_bits();
                    }
                    let info = self.hit_info(&c, t, kind, attrs, entry.data.clone());
                    self.candidate(st, tr, info, dt, entry.group)?;
                }
            }
        }
        Ok(())
    }

    /// A candidate that passed the interval and facing tests: opacity, any-hit, commit.
    /// Returns whether it was committed.
    fn candidate(
        &self,
        st: &mut ExecState<'_>,
        tr: &mut Traversal,
        info: HitInfo,
        dt: f64,
        group: usize,
    ) -> Result<bool, Unwind> {
        let flags = RayFlags(tr.ray.flags);
        let fate = opacity::resolve(info.geom_flags, info.inst_flags, flags, info.micromap);
        if fate == opacity::CandidateFate::Culled {
            return Ok(false);
        }
        let any_hit = self
            .case
            .pipeline
            .hit
            .get(group)
            .and_then(|g| g.any_hit.clone());
        let mut terminate = false;
        if let (opacity::CandidateFate::NonOpaque, Some(ah)) = (fate, any_hit) {
            let f = self.model(&ah)?.clone();
            let ray = tr.ray;
            let (r, payload) = {
                let mut ctx = Ctx::new(self, st, ProgramKind::AnyHit, info.record.clone());
                ctx.payload = tr.payload.clone();
                ctx.visible_tmax = info.t;
                ctx.hit = Some(info.clone());
                ctx.ray = Some(ray);
                let r = f(&mut ctx);
                (r, std::mem::take(&mut ctx.payload))
            };
            // Payload writes before ignore or terminate stand (registers are written at once).
            tr.payload = payload;
            match r {
                Ok(()) => {}
                Err(Unwind::Ignore) => return Ok(false),
                Err(Unwind::Terminate) => terminate = true,
                Err(e) => return Err(e),
            }
        }
        tr.tmax_cur = info.t;
        tr.closest = Some(Committed {
            hit: info,
            dt,
            group,
        });
        if terminate || flags.contains(RayFlags::TERMINATE_ON_FIRST_HIT) {
            tr.terminated = true;
        }
        Ok(true)
    }

    fn finish(&self, st: &mut ExecState<'_>, tr: &mut Traversal, miss_index: u32) -> Flow {
        let flags = RayFlags(tr.ray.flags);
        let ray = tr.ray;
        if let Some(c) = tr.closest.clone() {
            if flags.contains(RayFlags::DISABLE_CLOSESTHIT) {
                return Ok(());
            }
            let Some(ch) = self
                .case
                .pipeline
                .hit
                .get(c.group)
                .and_then(|g| g.closest_hit.clone())
            else {
                return Ok(());
            };
            let f = self.model(&ch)?.clone();
            let (r, payload) = {
                let mut ctx = Ctx::new(self, st, ProgramKind::ClosestHit, c.hit.record.clone());
                ctx.payload = tr.payload.clone();
                ctx.visible_tmax = c.hit.t;
                ctx.hit = Some(c.hit);
                ctx.ray = Some(ray);
                let r = f(&mut ctx);
                (r, std::mem::take(&mut ctx.payload))
            };
            tr.payload = payload;
            return r;
        }
        let index = sbt_index::miss_record_index(miss_index) as usize;
        let Some(entry) = self.case.sbt.miss.get(index).cloned() else {
            if self.exception_enabled(exception::INVALID_MISS_SBT) {
                return Err(Unwind::Throw(exception::INVALID_MISS_SBT));
            }
            return Err(Unwind::Throw(UNDEFINED));
        };
        let Some(Some(ms)) = self.case.pipeline.miss.get(entry.group).cloned() else {
            return Ok(());
        };
        let f = self.model(&ms)?.clone();
        let (r, payload) = {
            let mut ctx = Ctx::new(self, st, ProgramKind::Miss, entry.data.clone());
            ctx.payload = tr.payload.clone();
            ctx.visible_tmax = ray.tmax as f64;
            ctx.ray = Some(ray);
            let r = f(&mut ctx);
            (r, std::mem::take(&mut ctx.payload))
        };
        tr.payload = payload;
        r
    }

    /// Reports an intersection from the running intersection program.
    fn report(
        &self,
        st: &mut ExecState<'_>,
        tr: &mut Traversal,
        t: f32,
        hit_kind: u32,
        attributes: [u32; 8],
    ) -> Result<bool, Unwind> {
        let Some((base, group)) = tr.current.clone() else {
            return Ok(false);
        };
        let t64 = t as f64;
        let limit = match &tr.closest {
            Some(c) => c.hit.t,
            None => tr.tmax_cur,
        };
        if !ray_policy::reported_t_accepted(t, tr.ray.tmin, tr.ray.tmax)
            || t64 > limit
            || t.is_nan()
        {
            return Ok(false);
        }
        let info = HitInfo {
            t: t64,
            hit_kind: facing::custom_hit_kind(hit_kind),
            attributes,
            ..base
        };
        let committed = self.candidate(st, tr, info, 0.0, group)?;
        if committed && tr.terminated {
            return Err(Unwind::Terminate);
        }
        Ok(committed)
    }
}

fn tri_of(c: &Contact) -> &TriContact {
    match &c.geo {
        Geo::Tri(t, _) => t,
        _ => unreachable!("only triangle contacts are clustered"),
    }
}

/// Wächter & Binder's spawn-point offset, bit for bit as the prelude's `rt_offset_ray`.
pub fn offset_ray(p: [f32; 3], n: [f32; 3]) -> [f32; 3] {
    std::array::from_fn(|i| {
        // WGSL's f32 → i32 conversion truncates and saturates, as Rust's `as` does.
        let of_i = (256.0 * n[i]) as i32;
        let bits = p[i].to_bits() as i32;
        let p_i = f32::from_bits(bits.wrapping_add(if p[i] < 0.0 { -of_i } else { of_i }) as u32);
        if p[i].abs() < 1.0 / 32.0 {
            p[i] + (1.0 / 65536.0) * n[i]
        } else {
            p_i
        }
    })
}

fn to_f32(v: V3) -> [f32; 3] {
    v.map(|c| c as f32)
}

fn m_to_f32(m: &M34) -> [f32; 12] {
    m.map(|c| c as f32)
}

impl<'a, 'b> Ctx<'a, 'b> {
    fn new(
        eng: &'a Engine<'a>,
        st: &'a mut ExecState<'b>,
        kind: ProgramKind,
        record: Vec<u32>,
    ) -> Self {
        Ctx {
            eng,
            st,
            kind,
            payload: vec![0; eng.settings.payload_len.max(1)],
            hit: None,
            ray: None,
            visible_tmax: 0.0,
            record,
            traversal: None,
            exception_code: 0,
        }
    }

    fn hit(&self) -> &HitInfo {
        self.hit
            .as_ref()
            .expect("a hit built-in was called outside a hit program (the front end forbids this)")
    }

    fn ray(&self) -> &RayView {
        self.ray.as_ref().expect(
            "a ray built-in was called outside a traversal program (the front end forbids this)",
        )
    }

    /// `rt_launch_index()`.
    pub fn launch_index(&self) -> [u32; 3] {
        self.st.index
    }

    /// `rt_launch_dimensions()`.
    pub fn launch_dimensions(&self) -> [u32; 3] {
        self.st.dims
    }

    /// The linear launch index `x + w·(y + h·z)`.
    pub fn linear_index(&self) -> u32 {
        let (i, d) = (self.st.index, self.st.dims);
        i[0] + d[0] * (i[1] + d[1] * i[2])
    }

    /// Word `i` of the launch parameters (handles as the oracle's handle words).
    pub fn param(&self, i: usize) -> u32 {
        self.st.params.get(i).copied().unwrap_or(0)
    }

    /// Word `i` of storage buffer `binding`.
    pub fn read(&mut self, binding: u32, i: usize) -> u32 {
        if let Some(v) = self.st.overlay.get(&(binding, i)) {
            return *v;
        }
        match self.st.buffers.get(&binding).and_then(|b| b.get(i)) {
            Some(v) => *v,
            None => {
                self.st
                    .bad_access
                    .get_or_insert(format!("read of word {i} of binding {binding}"));
                0
            }
        }
    }

    /// Word `i` of storage buffer `binding` as `f32`.
    pub fn read_f32(&mut self, binding: u32, i: usize) -> f32 {
        f32::from_bits(self.read(binding, i))
    }

    /// Writes word `i` of storage buffer `binding`.
    pub fn write(&mut self, binding: u32, i: usize, v: u32) {
        if self.st.buffers.get(&binding).is_none_or(|b| i >= b.len()) {
            self.st
                .bad_access
                .get_or_insert(format!("write of word {i} of binding {binding}"));
            return;
        }
        self.st.overlay.insert((binding, i), v);
    }

    /// `rt_trace(...)`.
    #[allow(clippy::too_many_arguments)]
    pub fn trace(
        &mut self,
        handle: [u32; 2],
        origin: [f32; 3],
        direction: [f32; 3],
        tmin: f32,
        tmax: f32,
        time: f32,
        mask: u32,
        flags: u32,
        sbt_offset: u32,
        sbt_stride: u32,
        miss_index: u32,
        payload: &mut [u32],
    ) -> Flow {
        let ray = RayView {
            origin,
            direction,
            tmin,
            tmax,
            time,
            flags,
            mask,
            sbt_offset,
            sbt_stride,
        };
        let eng = self.eng;
        eng.trace(self.st, handle, ray, miss_index, payload)
    }

    /// `rt_get_payload(i)` (argument registers in callables).
    pub fn get_payload(&self, i: u32) -> u32 {
        self.payload.get(i as usize).copied().unwrap_or(0)
    }

    /// `rt_set_payload(i, v)`.
    pub fn set_payload(&mut self, i: u32, v: u32) {
        if let Some(p) = self.payload.get_mut(i as usize) {
            *p = v;
        }
    }

    /// `rt_get_attribute(i)`.
    pub fn get_attribute(&self, i: u32) -> u32 {
        self.hit().attributes.get(i as usize).copied().unwrap_or(0)
    }

    /// `rt_report_intersection(t, hit_kind, attributes)`.
    pub fn report_intersection(
        &mut self,
        t: f32,
        hit_kind: u32,
        attributes: [u32; 8],
    ) -> Result<bool, Unwind> {
        let eng = self.eng;
        let tr = self
            .traversal
            .as_deref_mut()
            .expect("rt_report_intersection outside an intersection program");
        let r = eng.report(self.st, tr, t, hit_kind, attributes);
        self.visible_tmax = match &tr.closest {
            Some(c) => c.hit.t,
            None => tr.tmax_cur,
        };
        r
    }

    /// `rt_ignore_intersection()`: `return ctx.ignore_intersection();`.
    pub fn ignore_intersection(&self) -> Flow {
        Err(Unwind::Ignore)
    }

    /// `rt_terminate_ray()`: `return ctx.terminate_ray();`.
    pub fn terminate_ray(&self) -> Flow {
        Err(Unwind::Terminate)
    }

    /// `rt_world_ray_origin()`.
    pub fn world_ray_origin(&self) -> [f32; 3] {
        self.ray().origin
    }

    /// `rt_world_ray_direction()`.
    pub fn world_ray_direction(&self) -> [f32; 3] {
        self.ray().direction
    }

    /// `rt_object_ray_origin()`.
    pub fn object_ray_origin(&self) -> [f32; 3] {
        to_f32(self.hit().obj.o)
    }

    /// `rt_object_ray_direction()`.
    pub fn object_ray_direction(&self) -> [f32; 3] {
        to_f32(self.hit().obj.d)
    }

    /// `rt_ray_tmin()`.
    pub fn ray_tmin(&self) -> f32 {
        self.ray().tmin
    }

    /// `rt_ray_tmax()`: the hit's t in closest-hit, the candidate's in any-hit, the closest
    /// so far in intersection, the traced tmax in miss.
    pub fn ray_tmax(&self) -> f32 {
        self.visible_tmax as f32
    }

    /// `rt_ray_time()`.
    pub fn ray_time(&self) -> f32 {
        self.ray().time
    }

    /// `rt_ray_flags()`.
    pub fn ray_flags(&self) -> u32 {
        self.ray().flags
    }

    /// `rt_ray_mask()`.
    pub fn ray_mask(&self) -> u32 {
        self.ray().mask
    }

    /// `rt_primitive_index()`.
    pub fn primitive_index(&self) -> u32 {
        self.hit().prim
    }

    /// `rt_sbt_gas_index()`.
    pub fn sbt_gas_index(&self) -> u32 {
        self.hit().gas_index
    }

    /// `rt_instance_id()`.
    pub fn instance_id(&self) -> u32 {
        self.hit().inst_id
    }

    /// `rt_instance_index()`.
    pub fn instance_index(&self) -> u32 {
        self.hit().inst_index
    }

    /// `rt_hit_kind()`.
    pub fn hit_kind(&self) -> u32 {
        self.hit().hit_kind
    }

    /// `rt_is_front_face_hit()`.
    pub fn is_front_face_hit(&self) -> bool {
        facing::hit_kind_is_front(self.hit().hit_kind)
    }

    /// `rt_triangle_barycentrics()`.
    pub fn triangle_barycentrics(&self) -> [f32; 2] {
        let a = self.hit().attributes;
        [f32::from_bits(a[0]), f32::from_bits(a[1])]
    }

    /// `rt_triangle_vertices()` (object space).
    pub fn triangle_vertices(&self) -> [[f32; 3]; 3] {
        self.hit()
            .verts
            .map(|v| v.map(to_f32))
            .unwrap_or([[0.0; 3]; 3])
    }

    /// `rt_sphere()`: centre and radius.
    pub fn sphere(&self) -> [f32; 4] {
        self.hit()
            .sphere
            .map(|s| s.map(|c| c as f32))
            .unwrap_or([0.0; 4])
    }

    /// `rt_curve_parameter()`.
    pub fn curve_parameter(&self) -> f32 {
        self.hit().curve_u as f32
    }

    /// `rt_object_to_world()` as 3×4 row-major.
    pub fn object_to_world(&self) -> [f32; 12] {
        m_to_f32(&self.hit().o2w)
    }

    /// `rt_world_to_object()` as 3×4 row-major.
    pub fn world_to_object(&self) -> [f32; 12] {
        m_to_f32(&self.hit().w2o)
    }

    /// `rt_sbt_data_u32(i)`.
    pub fn sbt_data_u32(&self, i: u32) -> u32 {
        self.record.get(i as usize).copied().unwrap_or(0)
    }

    /// `rt_sbt_data_f32(i)`.
    pub fn sbt_data_f32(&self, i: u32) -> f32 {
        f32::from_bits(self.sbt_data_u32(i))
    }

    fn call(&mut self, index: u32, args: &mut [u32], continuation: bool) -> Flow {
        let eng = self.eng;
        let Some(entry) = eng.case.sbt.callables.get(index as usize).cloned() else {
            if eng.exception_enabled(exception::CALLABLE_INVALID_SBT) {
                return Err(Unwind::Throw(exception::CALLABLE_INVALID_SBT));
            }
            return Ok(());
        };
        let group = eng
            .case
            .pipeline
            .callables
            .get(entry.group)
            .cloned()
            .unwrap_or_default();
        let (name, kind) = if continuation {
            (group.continuation, ProgramKind::ContinuationCallable)
        } else {
            (group.direct, ProgramKind::DirectCallable)
        };
        let Some(name) = name else {
            if eng.exception_enabled(exception::CALLABLE_INVALID_SBT) {
                return Err(Unwind::Throw(exception::CALLABLE_INVALID_SBT));
            }
            return Ok(());
        };
        let f = eng.model(&name)?.clone();
        let (r, out) = {
            let mut ctx = Ctx::new(eng, self.st, kind, entry.data.clone());
            ctx.payload = args.to_vec();
            ctx.payload
                .resize(eng.settings.payload_len.max(args.len()).max(1), 0);
            ctx.hit = self.hit.clone();
            ctx.ray = self.ray;
            ctx.visible_tmax = self.visible_tmax;
            let r = f(&mut ctx);
            (r, std::mem::take(&mut ctx.payload))
        };
        args.copy_from_slice(&out[..args.len()]);
        r
    }

    /// `rt_direct_call(index, &args)`.
    pub fn direct_call(&mut self, index: u32, args: &mut [u32]) -> Flow {
        self.call(index, args, false)
    }

    /// `rt_continuation_call(index, &args)`.
    pub fn continuation_call(&mut self, index: u32, args: &mut [u32]) -> Flow {
        self.call(index, args, true)
    }

    /// `rt_throw_exception(code)`: `return ctx.throw_exception(code);`.
    pub fn throw_exception(&self, code: u32) -> Flow {
        Err(Unwind::Throw(exception::user_code(code)))
    }

    /// `rt_exception_code()`.
    pub fn exception_code(&self) -> i32 {
        self.exception_code
    }

    /// `rt_remaining_trace_depth()`.
    pub fn remaining_trace_depth(&self) -> u32 {
        self.eng
            .settings
            .max_trace_depth
            .saturating_sub(self.st.depth)
    }

    /// `rt_offset_ray(p, n)`.
    pub fn offset_ray(&self, p: [f32; 3], n: [f32; 3]) -> [f32; 3] {
        offset_ray(p, n)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offset_ray_moves_by_ulps_or_a_fixed_step_near_zero() {
        let p = offset_ray([1.0, -2.0, 0.01], [0.0, -1.0, 1.0]);
        assert_eq!(p[0], 1.0);
        // -2.0 moved 256 ulps away from zero along -y: more negative.
        assert_eq!(p[1].to_bits(), (-2.0f32).to_bits() + 256);
        assert_eq!(p[2], 0.01 + 1.0 / 65536.0);
    }
}
