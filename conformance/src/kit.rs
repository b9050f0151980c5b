//! The standard kit most cases use: a raygen that traces rays from a buffer, closest-hit,
//! miss, any-hit and intersection programs that write a hit record, their Rust models, and a
//! builder for cases made of a scene, rays and records.
//!
//! A record is 32 words per ray ([`rec`]). Programs OR their bit (`ProgramKind::bit`) into
//! `programs`: raygen 1, intersection 2, any-hit 4, closest-hit 8, miss 16. Payload register 0
//! carries the bits of any-hit, closest-hit and miss, register 1 the any-hit count, register 2
//! starts as the ray's `aux` word.

use crate::case::*;
use crate::image::ChannelKind;
use crate::oracle::exec::Ctx;
use crate::oracle::geometry::Rounding;
use crate::oracle::model::{Flow, Models};
use crate::scene::{NodeId, Scene};
use crate::tolerance::Tolerance;
use optik::{BuiltinIntersector, PipelineCompileOptions, PipelineLinkOptions, Setting};

/// Word offsets of the standard record.
pub mod rec {
    /// 1 when closest-hit ran, 0 when miss ran.
    pub const HIT: usize = 0;
    /// `rt_ray_tmax()` in closest-hit (f32 bits).
    pub const T: usize = 1;
    /// `rt_primitive_index()`.
    pub const PRIM: usize = 2;
    /// `rt_instance_id()`.
    pub const INST_ID: usize = 3;
    /// `rt_instance_index()`.
    pub const INST_INDEX: usize = 4;
    /// `rt_sbt_gas_index()`.
    pub const GAS_INDEX: usize = 5;
    /// `rt_hit_kind()`.
    pub const HIT_KIND: usize = 6;
    /// First of eight attribute words (barycentrics for triangles).
    pub const ATTR0: usize = 7;
    /// Word 0 of the SBT record that ran (hit or miss record data).
    pub const SBT_INDEX: usize = 15;
    /// Bit mask of the programs that ran.
    pub const PROGRAMS: usize = 16;
    /// Any-hit invocations (payload register 1).
    pub const AH_COUNT: usize = 17;
    /// Intersection invocations.
    pub const IS_COUNT: usize = 18;
    /// Case-specific word (report return values of `intersection__fixed`).
    pub const AUX: usize = 19;
    /// First of eight payload words after the trace.
    pub const PAYLOAD0: usize = 20;
    /// Words per record.
    pub const STRIDE: usize = 32;
}

/// Any-hit actions, in word 1 of a hit record's data. Hit record data: word 0 is the record's
/// index (recorded as `sbt_index`), 1 the action, 2 and 3 its bounds (f32), 4 the number of
/// reports of `intersection__fixed` and 5.. their t values (f32).
pub mod action {
    /// Accept.
    pub const ACCEPT: u32 = 0;
    /// `rt_ignore_intersection()`.
    pub const IGNORE: u32 = 1;
    /// `rt_terminate_ray()`.
    pub const TERMINATE: u32 = 2;
    /// Ignore when `data[2] < t < data[3]` (f32 bits).
    pub const IGNORE_IN_RANGE: u32 = 3;
    /// Ignore primitives with odd index.
    pub const IGNORE_ODD: u32 = 4;
}

/// The standard module's WGSL.
pub const STD_WGSL: &str = r#"// optik conformance: the standard kit (conformance/src/kit.rs).
struct Params { handle: vec2<u32>, num_rays: u32, pad: u32 }
@group(0) @binding(0) var<uniform> params: Params;
struct Ray {
    origin: vec3<f32>, tmin: f32, dir: vec3<f32>, tmax: f32,
    time: f32, mask: u32, flags: u32, sbt_offset: u32, sbt_stride: u32, miss_index: u32, aux: u32, pad: u32,
}
@group(0) @binding(1) var<storage, read> rays: array<Ray>;
@group(0) @binding(2) var<storage, read_write> out: array<u32>;
@group(0) @binding(3) var<storage, read> prims: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read> extra: array<vec4<f32>>;

fn ray_id() -> u32 {
    let i = rt_launch_index();
    let d = rt_launch_dimensions();
    return i.x + d.x * (i.y + d.y * i.z);
}

fn slot(k: u32) -> u32 {
    return ray_id() * 32u + k;
}

fn trace_and_record(r: Ray, origin: vec3<f32>) {
    var p: RtPayload;
    p[2] = r.aux;
    rt_trace(params.handle, origin, r.dir, r.tmin, r.tmax, r.time, r.mask, r.flags, r.sbt_offset, r.sbt_stride, r.miss_index, &p);
    out[slot(16u)] = out[slot(16u)] | p[0] | 1u;
    out[slot(17u)] = p[1];
    out[slot(20u)] = p[0];
    out[slot(21u)] = p[1];
    out[slot(22u)] = p[2];
    out[slot(23u)] = p[3];
    out[slot(24u)] = p[4];
    out[slot(25u)] = p[5];
    out[slot(26u)] = p[6];
    out[slot(27u)] = p[7];
}

fn raygen__rays() {
    let id = ray_id();
    if id >= params.num_rays {
        return;
    }
    let r = rays[id];
    trace_and_record(r, r.origin);
}

// Spawns each ray from rt_offset_ray(origin, normal), the normal in `extra[ray]`.
fn raygen__offset() {
    let id = ray_id();
    if id >= params.num_rays {
        return;
    }
    let r = rays[id];
    trace_and_record(r, rt_offset_ray(r.origin, extra[id].xyz));
}

fn record_hit() {
    out[slot(0u)] = 1u;
    out[slot(1u)] = bitcast<u32>(rt_ray_tmax());
    out[slot(2u)] = rt_primitive_index();
    out[slot(3u)] = rt_instance_id();
    out[slot(4u)] = rt_instance_index();
    out[slot(5u)] = rt_sbt_gas_index();
    out[slot(6u)] = rt_hit_kind();
    out[slot(15u)] = rt_sbt_data_u32(0u);
    rt_set_payload(0u, rt_get_payload(0u) | 8u);
}

fn closesthit__record() {
    record_hit();
    let b = rt_triangle_barycentrics();
    out[slot(7u)] = bitcast<u32>(b.x);
    out[slot(8u)] = bitcast<u32>(b.y);
}

fn closesthit__record_attrs() {
    record_hit();
    for (var i = 0u; i < 8u; i++) {
        out[slot(7u + i)] = rt_get_attribute(i);
    }
}

fn closesthit__record_plain() {
    record_hit();
}

fn miss__record() {
    out[slot(0u)] = 0u;
    out[slot(15u)] = rt_sbt_data_u32(0u);
    rt_set_payload(0u, rt_get_payload(0u) | 16u);
}

fn anyhit__std() {
    rt_set_payload(0u, rt_get_payload(0u) | 4u);
    rt_set_payload(1u, rt_get_payload(1u) + 1u);
    let action = rt_sbt_data_u32(1u);
    if action == 1u {
        rt_ignore_intersection();
    }
    if action == 2u {
        rt_terminate_ray();
    }
    if action == 3u {
        let t = rt_ray_tmax();
        if t > rt_sbt_data_f32(2u) && t < rt_sbt_data_f32(3u) {
            rt_ignore_intersection();
        }
    }
    if action == 4u {
        if (rt_primitive_index() & 1u) == 1u {
            rt_ignore_intersection();
        }
    }
}

fn intersection__sphere() {
    out[slot(18u)] = out[slot(18u)] + 1u;
    out[slot(16u)] = out[slot(16u)] | 2u;
    let s = prims[rt_primitive_index()];
    let o = rt_object_ray_origin();
    let d = rt_object_ray_direction();
    let f = o - s.xyz;
    let a = dot(d, d);
    let b = dot(f, d);
    let c = dot(f, f) - s.w * s.w;
    let disc = b * b - a * c;
    if disc < 0.0 {
        return;
    }
    let q = sqrt(disc);
    var attrs: RtAttributes;
    attrs[0] = rt_primitive_index();
    let t0 = (-b - q) / a;
    if t0 >= rt_ray_tmin() {
        let accepted = rt_report_intersection(t0, 1u, attrs);
        return;
    }
    let t1 = (-b + q) / a;
    let accepted = rt_report_intersection(t1, 2u, attrs);
}

fn intersection__fixed() {
    out[slot(18u)] = out[slot(18u)] + 1u;
    out[slot(16u)] = out[slot(16u)] | 2u;
    let n = rt_sbt_data_u32(4u);
    for (var k = 0u; k < n; k++) {
        var attrs: RtAttributes;
        for (var i = 0u; i < 8u; i++) {
            attrs[i] = 1u + ray_id() + i;
        }
        let accepted = rt_report_intersection(rt_sbt_data_f32(5u + k), k, attrs);
        out[slot(19u)] = out[slot(19u)] | (select(0u, 1u, accepted) << k) | (1u << (k + 8u));
    }
}
"#;

/// Names of the standard programs.
pub mod prog {
    /// Standard raygen.
    pub const RAYGEN: &str = "raygen__rays";
    /// Standard raygen spawning from `rt_offset_ray(origin, extra[ray].xyz)`.
    pub const RAYGEN_OFFSET: &str = "raygen__offset";
    /// Closest-hit recording barycentrics (triangles).
    pub const CH: &str = "closesthit__record";
    /// Closest-hit recording the eight attribute registers (custom primitives).
    pub const CH_ATTRS: &str = "closesthit__record_attrs";
    /// Closest-hit recording no attributes (spheres, curves).
    pub const CH_PLAIN: &str = "closesthit__record_plain";
    /// Miss.
    pub const MS: &str = "miss__record";
    /// Any-hit with the actions of [`super::action`].
    pub const AH: &str = "anyhit__std";
    /// Analytic sphere intersection (`prims` binding 3: centre and radius).
    pub const IS_SPHERE: &str = "intersection__sphere";
    /// Reports the t values listed in the hit record's data (count in word 4, values from 5).
    pub const IS_FIXED: &str = "intersection__fixed";
}

fn slot(ctx: &Ctx<'_, '_>, k: usize) -> usize {
    ctx.linear_index() as usize * rec::STRIDE + k
}

fn or_word(ctx: &mut Ctx<'_, '_>, k: usize, bits: u32) {
    let s = slot(ctx, k);
    let v = ctx.read(2, s);
    ctx.write(2, s, v | bits);
}

fn record_hit(ctx: &mut Ctx<'_, '_>) {
    let s = slot(ctx, 0);
    let words = [
        (rec::HIT, 1),
        (rec::T, ctx.ray_tmax().to_bits()),
        (rec::PRIM, ctx.primitive_index()),
        (rec::INST_ID, ctx.instance_id()),
        (rec::INST_INDEX, ctx.instance_index()),
        (rec::GAS_INDEX, ctx.sbt_gas_index()),
        (rec::HIT_KIND, ctx.hit_kind()),
        (rec::SBT_INDEX, ctx.sbt_data_u32(0)),
    ];
    for (k, v) in words {
        ctx.write(2, s + k, v);
    }
    let p = ctx.get_payload(0);
    ctx.set_payload(0, p | 8);
}

/// The models of the standard programs.
pub fn std_models() -> Models {
    let mut m = Models::new();
    m.add(prog::RAYGEN, |ctx| raygen_std(ctx, false));
    m.add(prog::RAYGEN_OFFSET, |ctx| raygen_std(ctx, true));
    m.add(prog::CH, |ctx| {
        record_hit(ctx);
        let b = ctx.triangle_barycentrics();
        let s = slot(ctx, rec::ATTR0);
        ctx.write(2, s, b[0].to_bits());
        ctx.write(2, s + 1, b[1].to_bits());
        Ok(())
    });
    m.add(prog::CH_ATTRS, |ctx| {
        record_hit(ctx);
        let s = slot(ctx, rec::ATTR0);
        for i in 0..8 {
            let a = ctx.get_attribute(i as u32);
            ctx.write(2, s + i, a);
        }
        Ok(())
    });
    m.add(prog::CH_PLAIN, |ctx| {
        record_hit(ctx);
        Ok(())
    });
    m.add(prog::MS, |ctx| {
        let s = slot(ctx, 0);
        ctx.write(2, s + rec::HIT, 0);
        let d = ctx.sbt_data_u32(0);
        ctx.write(2, s + rec::SBT_INDEX, d);
        let p = ctx.get_payload(0);
        ctx.set_payload(0, p | 16);
        Ok(())
    });
    m.add(prog::AH, anyhit_std);
    m.add(prog::IS_SPHERE, |ctx| {
        let s = slot(ctx, 0);
        let c = ctx.read(2, s + rec::IS_COUNT);
        ctx.write(2, s + rec::IS_COUNT, c + 1);
        or_word(ctx, rec::PROGRAMS, 2);
        let prim = ctx.primitive_index() as usize;
        let sp: [f32; 4] = std::array::from_fn(|k| ctx.read_f32(3, prim * 4 + k));
        let o = ctx.object_ray_origin();
        let d = ctx.object_ray_direction();
        let f = [o[0] - sp[0], o[1] - sp[1], o[2] - sp[2]];
        let dot = |a: [f32; 3], b: [f32; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        let a = dot(d, d);
        let b = dot(f, d);
        let c = dot(f, f) - sp[3] * sp[3];
        let disc = b * b - a * c;
        if disc < 0.0 {
            return Ok(());
        }
        let q = disc.sqrt();
        let mut attrs = [0u32; 8];
        attrs[0] = ctx.primitive_index();
        let t0 = (-b - q) / a;
        if t0 >= ctx.ray_tmin() {
            ctx.report_intersection(t0, 1, attrs)?;
            return Ok(());
        }
        let t1 = (-b + q) / a;
        ctx.report_intersection(t1, 2, attrs)?;
        Ok(())
    });
    m.add(prog::IS_FIXED, |ctx| {
        let s = slot(ctx, 0);
        let c = ctx.read(2, s + rec::IS_COUNT);
        ctx.write(2, s + rec::IS_COUNT, c + 1);
        or_word(ctx, rec::PROGRAMS, 2);
        let n = ctx.sbt_data_u32(4);
        for k in 0..n {
            let id = ctx.linear_index();
            let attrs: [u32; 8] = std::array::from_fn(|i| 1 + id + i as u32);
            let t = ctx.sbt_data_f32(5 + k);
            let accepted = ctx.report_intersection(t, k, attrs)?;
            or_word(ctx, rec::AUX, ((accepted as u32) << k) | (1 << (k + 8)));
        }
        Ok(())
    });
    m
}

fn raygen_std(ctx: &mut Ctx<'_, '_>, offset: bool) -> Flow {
    let id = ctx.linear_index();
    if id >= ctx.param(2) {
        return Ok(());
    }
    let base = id as usize * 16;
    let w: Vec<u32> = (0..16).map(|k| ctx.read(1, base + k)).collect();
    let f = |k: usize| f32::from_bits(w[k]);
    let mut origin = [f(0), f(1), f(2)];
    if offset {
        let n: [f32; 3] = std::array::from_fn(|k| ctx.read_f32(4, id as usize * 4 + k));
        origin = ctx.offset_ray(origin, n);
    }
    let mut p = [0u32; 32];
    p[2] = w[14];
    trace_words_from(ctx, origin, &w, &mut p)?;
    or_word(ctx, rec::PROGRAMS, p[0] | 1);
    let s = slot(ctx, 0);
    ctx.write(2, s + rec::AH_COUNT, p[1]);
    for (k, v) in p.iter().take(8).enumerate() {
        ctx.write(2, s + rec::PAYLOAD0 + k, *v);
    }
    Ok(())
}

fn anyhit_std(ctx: &mut Ctx<'_, '_>) -> Flow {
    let p0 = ctx.get_payload(0);
    ctx.set_payload(0, p0 | 4);
    let p1 = ctx.get_payload(1);
    ctx.set_payload(1, p1 + 1);
    let action = ctx.sbt_data_u32(1);
    if action == action::IGNORE {
        return ctx.ignore_intersection();
    }
    if action == action::TERMINATE {
        return ctx.terminate_ray();
    }
    if action == action::IGNORE_IN_RANGE {
        let t = ctx.ray_tmax();
        if t > ctx.sbt_data_f32(2) && t < ctx.sbt_data_f32(3) {
            return ctx.ignore_intersection();
        }
    }
    if action == action::IGNORE_ODD && ctx.primitive_index() & 1 == 1 {
        return ctx.ignore_intersection();
    }
    Ok(())
}

/// A ray of the standard raygen's buffer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    /// Origin.
    pub origin: [f32; 3],
    /// tmin.
    pub tmin: f32,
    /// Direction.
    pub dir: [f32; 3],
    /// tmax.
    pub tmax: f32,
    /// Time.
    pub time: f32,
    /// Visibility mask.
    pub mask: u32,
    /// Ray flags.
    pub flags: u32,
    /// SBT offset.
    pub sbt_offset: u32,
    /// SBT stride.
    pub sbt_stride: u32,
    /// Miss index.
    pub miss_index: u32,
    /// Initial value of payload register 2.
    pub aux: u32,
}

impl Ray {
    /// A ray from `origin` along `dir`, t in [0, 1e30], mask 0xFF, no flags, SBT stride 1.
    pub fn new(origin: [f32; 3], dir: [f32; 3]) -> Self {
        Ray {
            origin,
            tmin: 0.0,
            dir,
            tmax: 1e30,
            time: 0.0,
            mask: 0xFF,
            flags: 0,
            sbt_offset: 0,
            sbt_stride: 1,
            miss_index: 0,
            aux: 0,
        }
    }

    /// The same ray with ray flags.
    pub fn flags(mut self, flags: u32) -> Self {
        self.flags = flags;
        self
    }

    /// The same ray with a t interval.
    pub fn interval(mut self, tmin: f32, tmax: f32) -> Self {
        self.tmin = tmin;
        self.tmax = tmax;
        self
    }

    /// The same ray at a time.
    pub fn at_time(mut self, time: f32) -> Self {
        self.time = time;
        self
    }

    /// The 16 words of the buffer layout.
    pub fn words(&self) -> [u32; 16] {
        let f = |v: f32| v.to_bits();
        [
            f(self.origin[0]),
            f(self.origin[1]),
            f(self.origin[2]),
            f(self.tmin),
            f(self.dir[0]),
            f(self.dir[1]),
            f(self.dir[2]),
            f(self.tmax),
            f(self.time),
            self.mask,
            self.flags,
            self.sbt_offset,
            self.sbt_stride,
            self.miss_index,
            self.aux,
            0,
        ]
    }
}

/// Channel specs of the standard record.
pub mod ch {
    use super::rec;
    use crate::case::ChannelSpec;
    use crate::image::ChannelKind;
    use crate::tolerance::Tolerance;

    fn spec(name: &str, word: usize, kind: ChannelKind, tolerance: Tolerance) -> ChannelSpec {
        ChannelSpec {
            name: name.into(),
            word,
            kind,
            tolerance,
        }
    }

    /// `hit`, exact.
    pub fn hit() -> ChannelSpec {
        spec("hit", rec::HIT, ChannelKind::Uint, Tolerance::Exact)
    }
    /// `t` with a tolerance.
    pub fn t(tolerance: Tolerance) -> ChannelSpec {
        spec("t", rec::T, ChannelKind::Float, tolerance)
    }
    /// `prim`, exact.
    pub fn prim() -> ChannelSpec {
        spec("prim", rec::PRIM, ChannelKind::Uint, Tolerance::Exact)
    }
    /// `inst_id`, exact.
    pub fn inst_id() -> ChannelSpec {
        spec("inst_id", rec::INST_ID, ChannelKind::Uint, Tolerance::Exact)
    }
    /// `inst_index`, exact.
    pub fn inst_index() -> ChannelSpec {
        spec(
            "inst_index",
            rec::INST_INDEX,
            ChannelKind::Uint,
            Tolerance::Exact,
        )
    }
    /// `gas_index`, exact.
    pub fn gas_index() -> ChannelSpec {
        spec(
            "gas_index",
            rec::GAS_INDEX,
            ChannelKind::Uint,
            Tolerance::Exact,
        )
    }
    /// `hit_kind`, exact.
    pub fn hit_kind() -> ChannelSpec {
        spec(
            "hit_kind",
            rec::HIT_KIND,
            ChannelKind::Uint,
            Tolerance::Exact,
        )
    }
    /// `attr<i>` as a float with a tolerance (barycentrics).
    pub fn attr_f(i: usize, tolerance: Tolerance) -> ChannelSpec {
        spec(
            &format!("attr{i}"),
            rec::ATTR0 + i,
            ChannelKind::Float,
            tolerance,
        )
    }
    /// `attr<i>` as an integer, exact.
    pub fn attr_u(i: usize) -> ChannelSpec {
        spec(
            &format!("attr{i}"),
            rec::ATTR0 + i,
            ChannelKind::Uint,
            Tolerance::Exact,
        )
    }
    /// `sbt_index`, exact.
    pub fn sbt_index() -> ChannelSpec {
        spec(
            "sbt_index",
            rec::SBT_INDEX,
            ChannelKind::Uint,
            Tolerance::Exact,
        )
    }
    /// `programs`, exact.
    pub fn programs() -> ChannelSpec {
        spec(
            "programs",
            rec::PROGRAMS,
            ChannelKind::Uint,
            Tolerance::Exact,
        )
    }
    /// `ah_count`, exact.
    pub fn ah_count() -> ChannelSpec {
        spec(
            "ah_count",
            rec::AH_COUNT,
            ChannelKind::Uint,
            Tolerance::Exact,
        )
    }
    /// `is_count`, exact.
    pub fn is_count() -> ChannelSpec {
        spec(
            "is_count",
            rec::IS_COUNT,
            ChannelKind::Uint,
            Tolerance::Exact,
        )
    }
    /// `aux`, exact.
    pub fn aux() -> ChannelSpec {
        spec("aux", rec::AUX, ChannelKind::Uint, Tolerance::Exact)
    }
    /// `payload<i>`, exact bits.
    pub fn payload(i: usize) -> ChannelSpec {
        spec(
            &format!("payload{i}"),
            rec::PAYLOAD0 + i,
            ChannelKind::Uint,
            Tolerance::Exact,
        )
    }
}

/// A hit group of the standard kit.
pub fn hit_group(
    closest_hit: Option<&str>,
    any_hit: Option<&str>,
    intersection: Option<&str>,
) -> HitGroupDesc {
    HitGroupDesc {
        closest_hit: closest_hit.map(String::from),
        any_hit: any_hit.map(String::from),
        intersection: intersection.map(String::from),
        builtin: None,
    }
}

/// A case made of a scene, rays and the standard programs.
pub struct StdCase {
    /// `group.case`.
    pub name: String,
    /// Group.
    pub group: Group,
    /// What it checks.
    pub summary: String,
    /// Rules guarded.
    pub guards: Vec<Rule>,
    /// The scene.
    pub scene: Scene,
    /// The node traced against (`None`: the null handle).
    pub root: Option<NodeId>,
    /// Hit groups.
    pub hit_groups: Vec<HitGroupDesc>,
    /// Hit records.
    pub hit_records: Vec<SbtEntry>,
    /// Miss groups (default: one `miss__record`).
    pub miss_groups: Vec<Option<String>>,
    /// Miss records (default: one, data `[0]`).
    pub miss_records: Vec<SbtEntry>,
    /// Launches: dimensions, one ray per launch index, and the node traced against.
    pub launches: Vec<([u32; 3], Vec<Ray>, Option<NodeId>)>,
    /// Channels recorded.
    pub channels: Vec<ChannelSpec>,
    /// Sphere data for `intersection__sphere` (binding 3).
    pub prims: Vec<[f32; 4]>,
    /// Per-ray data (binding 4): normals for `raygen__offset`.
    pub extra: Vec<[f32; 4]>,
    /// The raygen program.
    pub raygen: &'static str,
    /// Ambiguity bands.
    pub rounding: Rounding,
    /// Pipeline compile options.
    pub compile: PipelineCompileOptions,
    /// Link options.
    pub link: PipelineLinkOptions,
    /// WGSL appended to the standard module, with the models of its programs.
    pub more_wgsl: Option<(String, Models)>,
    /// Per-backend references allowed, with reasons.
    pub backend_specific: Vec<(optik::BackendKind, String)>,
    /// Judgement (default per record).
    pub judgement: Judgement,
}

impl StdCase {
    /// A case with one triangle hit group (`closesthit__record`, record data `[0, 0]`), one miss
    /// record and no rays yet.
    pub fn new(
        group: Group,
        name: &str,
        summary: &str,
        guards: &[Rule],
        scene: Scene,
        root: Option<NodeId>,
    ) -> Self {
        StdCase {
            name: format!("{}.{name}", group.name()),
            group,
            summary: summary.into(),
            guards: guards.to_vec(),
            scene,
            root,
            hit_groups: vec![hit_group(Some(prog::CH), None, None)],
            hit_records: vec![SbtEntry::new(0, vec![0, action::ACCEPT])],
            miss_groups: vec![Some(prog::MS.into())],
            miss_records: vec![SbtEntry::new(0, vec![0])],
            launches: Vec::new(),
            channels: Vec::new(),
            prims: Vec::new(),
            extra: Vec::new(),
            raygen: prog::RAYGEN,
            rounding: Rounding::F32,
            compile: PipelineCompileOptions::default(),
            link: PipelineLinkOptions::default(),
            more_wgsl: None,
            backend_specific: Vec::new(),
            judgement: Judgement::PerRecord,
        }
    }

    /// Adds a launch of `rays` against the case's root, laid out as `width` × (rays / width).
    pub fn launch(self, width: u32, rays: Vec<Ray>) -> Self {
        let root = self.root;
        self.launch_on(root, width, rays)
    }

    /// Adds a launch of `rays` against `root`.
    pub fn launch_on(mut self, root: Option<NodeId>, width: u32, rays: Vec<Ray>) -> Self {
        let n = rays.len() as u32;
        let height = n.div_ceil(width.max(1)).max(1);
        let mut rays = rays;
        // Pad to a full rectangle with rays far from any geometry and an empty interval.
        while (rays.len() as u32) < width * height {
            rays.push(Ray::new([3e38; 3], [0.0, 0.0, 1.0]).interval(0.0, 0.0));
        }
        self.launches.push(([width, height, 1], rays, root));
        self
    }

    /// Sets the recorded channels.
    pub fn record(mut self, channels: Vec<ChannelSpec>) -> Self {
        self.channels = channels;
        self
    }

    /// Sets hit groups and records.
    pub fn hits(mut self, groups: Vec<HitGroupDesc>, records: Vec<SbtEntry>) -> Self {
        self.hit_groups = groups;
        self.hit_records = records;
        self
    }

    /// Uses the exact rounding bands (the scene is exactly computable in f32).
    pub fn exact(mut self) -> Self {
        self.rounding = Rounding::EXACT;
        self
    }

    /// Builds the case.
    pub fn build(self) -> Case {
        let mut models = std_models();
        let mut wgsl = STD_WGSL.to_string();
        if let Some((src, m)) = &self.more_wgsl {
            wgsl.push('\n');
            wgsl.push_str(src);
            models.extend(m);
        }
        let flat = |v: &[[f32; 4]]| -> Vec<u32> {
            if v.is_empty() {
                vec![0; 4]
            } else {
                v.iter().flat_map(|p| p.map(f32::to_bits)).collect()
            }
        };
        let (prims, extra) = (flat(&self.prims), flat(&self.extra));
        let launches = self
            .launches
            .iter()
            .map(|(dims, rays, root)| Launch {
                dims: *dims,
                params: {
                    let mut p = ParamWord::handle(*root).to_vec();
                    p.push(ParamWord::U32(rays.len() as u32));
                    p.push(ParamWord::U32(0));
                    p
                },
                buffers: vec![
                    BufferInit {
                        binding: 1,
                        words: rays.iter().flat_map(|r| r.words()).collect(),
                    },
                    BufferInit {
                        binding: 2,
                        words: vec![0; rays.len().max(1) * rec::STRIDE],
                    },
                    BufferInit {
                        binding: 3,
                        words: prims.clone(),
                    },
                    BufferInit {
                        binding: 4,
                        words: extra.clone(),
                    },
                ],
            })
            .collect();
        let compile = PipelineCompileOptions {
            num_payload_values: match self.compile.num_payload_values {
                Setting::Auto => Setting::Value(8),
                v => v,
            },
            ..self.compile
        };
        Case {
            name: self.name,
            group: self.group,
            summary: self.summary,
            guards: self.guards,
            scene: self.scene,
            pipeline: PipelineDesc {
                wgsl,
                raygen: self.raygen.into(),
                miss: self.miss_groups,
                hit: self.hit_groups,
                callables: Vec::new(),
                exception: None,
                compile,
                link: self.link,
            },
            models,
            sbt: SbtLayout {
                miss: self.miss_records,
                hit: self.hit_records,
                ..Default::default()
            },
            launches,
            record: RecordSpec {
                binding: 2,
                layout: RecordLayout::PerIndex {
                    stride: rec::STRIDE,
                },
                channels: self.channels,
                judgement: self.judgement,
            },
            rounding: self.rounding,
            backend_specific: self.backend_specific,
        }
    }
}

/// The channels most geometry cases record: hit, t, prim, hit kind, barycentrics.
pub fn geometry_channels(t: Tolerance, bary: Option<Tolerance>) -> Vec<ChannelSpec> {
    let mut v = vec![ch::hit(), ch::t(t), ch::prim(), ch::hit_kind()];
    if let Some(b) = bary {
        v.push(ch::attr_f(0, b));
        v.push(ch::attr_f(1, b));
    }
    v
}

/// A built-in sphere hit group of the standard kit.
pub fn sphere_group() -> HitGroupDesc {
    HitGroupDesc {
        builtin: Some(BuiltinIntersector::Sphere),
        ..hit_group(Some(prog::CH_PLAIN), None, None)
    }
}

/// A float channel over a custom word (for cases with their own programs).
pub fn float_channel(name: &str, word: usize, tolerance: Tolerance) -> ChannelSpec {
    ChannelSpec {
        name: name.into(),
        word,
        kind: ChannelKind::Float,
        tolerance,
    }
}

/// An integer channel over a custom word, compared exactly.
pub fn uint_channel(name: &str, word: usize) -> ChannelSpec {
    ChannelSpec {
        name: name.into(),
        word,
        kind: ChannelKind::Uint,
        tolerance: Tolerance::Exact,
    }
}

/// Traces the ray of [`Ray::words`] `w` (launch parameters 0 and 1 hold the handle) with
/// `payload`, as the kit's raygen programs do.
pub fn trace_words(ctx: &mut Ctx<'_, '_>, w: &[u32], payload: &mut [u32]) -> Flow {
    let origin = [0, 1, 2].map(|k| f32::from_bits(w[k]));
    trace_words_from(ctx, origin, w, payload)
}

/// [`trace_words`] from another origin.
pub fn trace_words_from(
    ctx: &mut Ctx<'_, '_>,
    origin: [f32; 3],
    w: &[u32],
    payload: &mut [u32],
) -> Flow {
    let f = |k: usize| f32::from_bits(w[k]);
    let handle = [ctx.param(0), ctx.param(1)];
    ctx.trace(
        handle,
        origin,
        [f(4), f(5), f(6)],
        f(3),
        f(7),
        f(8),
        w[9],
        w[10],
        w[11],
        w[12],
        w[13],
        payload,
    )
}

/// A host-side rig for the rules that hold on every backend and are checked by hand rather
/// than by a catalog case (`tests/rules/`): a fresh device of every backend, buffers from
/// values, structures, pipelines and shader binding tables in a few lines, and [`RAY_LIST`],
/// a raygen that traces a ray buffer and records what the hit and miss programs saw.
///
/// Everything here panics on an error: it is for tests, where a panic names the failing call.
///
/// [`RAY_LIST`]: rig::RAY_LIST
pub mod rig {
    use optik::*;
    use std::panic::AssertUnwindSafe;

    /// Runs `test` on a fresh device of each backend. A backend that cannot open here is
    /// skipped and named on stderr; a panic in `test` or any driver diagnostic
    /// (`Device::take_diagnostics`, the validation layer's messages under
    /// `OPTIK_VALIDATION=1`) fails the rule, naming every backend that failed.
    pub fn on_every_backend(rule: &str, test: impl Fn(BackendKind, &dyn Device)) {
        let mut failures = Vec::new();
        let mut ran = 0;
        for kind in BackendKind::ALL {
            let dev = match open_backend(kind) {
                Ok(d) => d,
                Err(e) => {
                    eprintln!("{rule}: {kind} skipped (it cannot run here: {e})");
                    continue;
                }
            };
            ran += 1;
            let result = std::panic::catch_unwind(AssertUnwindSafe(|| test(kind, dev.as_ref())));
            if let Err(panic) = result {
                let message = panic
                    .downcast_ref::<String>()
                    .cloned()
                    .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
                    .unwrap_or_else(|| "a panic".into());
                failures.push(format!("{kind}: {message}"));
            }
            let diagnostics = dev.take_diagnostics();
            if !diagnostics.is_empty() {
                failures.push(format!("{kind}: the driver reported {diagnostics:?}"));
            }
        }
        assert!(ran > 0, "{rule}: no backend could run");
        assert!(failures.is_empty(), "{rule}:\n{}", failures.join("\n"));
    }

    /// A buffer holding `data`.
    pub fn buffer<T: bytemuck::Pod>(dev: &dyn Device, data: &[T]) -> Buffer {
        let bytes: &[u8] = bytemuck::cast_slice(data);
        let b = dev.create_buffer(bytes.len().max(4) as u64).unwrap();
        dev.write_buffer(b, 0, bytes).unwrap();
        b
    }

    /// Reads a whole buffer as `T`s.
    pub fn read<T: bytemuck::Pod>(dev: &dyn Device, b: Buffer) -> Vec<T> {
        let mut out = vec![0u8; dev.buffer_size(b).unwrap() as usize];
        dev.read_buffer(b, 0, &mut out).unwrap();
        bytemuck::pod_collect_to_vec(&out)
    }

    /// A GAS of unindexed triangles with one SBT record.
    pub fn triangles(dev: &dyn Device, vertices: &[[f32; 3]], flags: GeometryFlags) -> Accel {
        let vb = buffer(dev, vertices);
        let input = BuildInput::Triangles(TriangleArray::new(
            BufferView::new(vb),
            vertices.len() as u32,
            flags,
        ));
        dev.accel_build(&AccelBuildOptions::default(), &[input])
            .unwrap()
    }

    /// A quad (two triangles) in the plane z = `z` over [x0, x1] × [y0, y1], facing +z.
    pub fn quad(x0: f32, x1: f32, y0: f32, y1: f32, z: f32) -> Vec<[f32; 3]> {
        vec![
            [x0, y0, z],
            [x1, y0, z],
            [x1, y1, z],
            [x0, y0, z],
            [x1, y1, z],
            [x0, y1, z],
        ]
    }

    /// Compiles `src` as module "test.wgsl".
    pub fn module(dev: &dyn Device, src: &str) -> Module {
        dev.create_module(
            &ModuleCompileOptions::default(),
            &PipelineCompileOptions::default(),
            &ProgramSource::new("test.wgsl", src),
        )
        .unwrap_or_else(|e| panic!("{e}"))
        .0
    }

    /// The program groups of a pipeline, by role.
    pub struct Groups {
        pub raygen: ProgramGroup,
        pub miss: Vec<ProgramGroup>,
        pub hit: Vec<ProgramGroup>,
        pub callables: Vec<ProgramGroup>,
        pub exception: Option<ProgramGroup>,
    }

    impl Groups {
        pub fn all(&self) -> Vec<ProgramGroup> {
            let mut v = vec![self.raygen];
            v.extend(&self.miss);
            v.extend(&self.hit);
            v.extend(&self.callables);
            v.extend(self.exception);
            v
        }
    }

    /// Creates groups from descriptions (raygen first, then the rest by their region).
    pub fn groups(dev: &dyn Device, descs: &[ProgramGroupDesc]) -> Groups {
        let handles = dev
            .create_program_groups(descs)
            .unwrap_or_else(|e| panic!("{e}"));
        let mut g = Groups {
            raygen: handles[0],
            miss: vec![],
            hit: vec![],
            callables: vec![],
            exception: None,
        };
        for (d, h) in descs.iter().zip(&handles).skip(1) {
            match d.region() {
                GroupRegion::Miss => g.miss.push(*h),
                GroupRegion::HitGroup => g.hit.push(*h),
                GroupRegion::Callables => g.callables.push(*h),
                GroupRegion::Exception => g.exception = Some(*h),
                GroupRegion::Raygen => panic!("one raygen group"),
            }
        }
        g
    }

    /// Builds an SBT: records of [`STRIDE`] bytes, each header followed by its data words.
    #[derive(Default)]
    pub struct SbtBuilder {
        bytes: Vec<u8>,
    }

    pub const STRIDE: u32 = 64;

    impl SbtBuilder {
        pub fn new() -> Self {
            SbtBuilder { bytes: Vec::new() }
        }

        /// Appends a record; returns its offset.
        pub fn record(&mut self, dev: &dyn Device, group: ProgramGroup, data: &[u32]) -> u64 {
            let at = self.bytes.len() as u64;
            self.bytes
                .extend_from_slice(&dev.sbt_record_pack_header(group).unwrap());
            let mut d: Vec<u8> = bytemuck::cast_slice(data).to_vec();
            d.resize((STRIDE - 32) as usize, 0);
            self.bytes.extend_from_slice(&d);
            at
        }

        pub fn finish(self, dev: &dyn Device) -> Buffer {
            buffer(dev, &self.bytes)
        }
    }

    /// A table with one record per group: raygen, misses, hits (with data), callables.
    pub fn sbt(dev: &dyn Device, g: &Groups, hit_data: &[Vec<u32>]) -> ShaderBindingTable {
        sbt_with(dev, g, |region, i| match region {
            GroupRegion::HitGroup => hit_data.get(i).cloned().unwrap_or_default(),
            _ => Vec::new(),
        })
    }

    /// A table with one record per group, in the order raygen, misses, hits, callables,
    /// exception; `data(region, i)` is the data of the region's `i`-th record.
    fn sbt_with(
        dev: &dyn Device,
        g: &Groups,
        data: impl Fn(GroupRegion, usize) -> Vec<u32>,
    ) -> ShaderBindingTable {
        let mut b = SbtBuilder::new();
        let raygen = b.record(dev, g.raygen, &data(GroupRegion::Raygen, 0));
        let mut region_of = |groups: &[ProgramGroup], region: GroupRegion| {
            let offset = b.bytes.len() as u64;
            for (i, h) in groups.iter().enumerate() {
                b.record(dev, *h, &data(region, i));
            }
            (offset, groups.len())
        };
        let miss = region_of(&g.miss, GroupRegion::Miss);
        let hit = region_of(&g.hit, GroupRegion::HitGroup);
        let call = region_of(&g.callables, GroupRegion::Callables);
        let exc = g
            .exception
            .map(|e| b.record(dev, e, &data(GroupRegion::Exception, 0)));
        let buf = b.finish(dev);
        let region = |(offset, count): (u64, usize)| {
            (count > 0).then_some(SbtRegion {
                buffer: buf,
                offset,
                stride: STRIDE,
                count: count as u32,
            })
        };
        ShaderBindingTable {
            raygen: SbtRecord {
                buffer: buf,
                offset: raygen,
            },
            exception: exc.map(|offset| SbtRecord {
                buffer: buf,
                offset,
            }),
            miss: region(miss),
            hitgroup: region(hit),
            callables: region(call),
        }
    }

    /// Launch parameters: a handle and up to six more words.
    pub fn params(handle: TraversableHandle, extra: &[u32]) -> Vec<u8> {
        let mut words = handle.to_words().to_vec();
        words.extend_from_slice(extra);
        words.resize(8, 0);
        bytemuck::cast_slice(&words).to_vec()
    }

    /// The parameter struct matching [`params`] (binding 0) and an output buffer (binding 1).
    pub const HEADER: &str = r#"
    struct Params { handle: vec2<u32>, a: u32, b: u32, c: u32, d: u32, e: u32, f: u32 }
    @group(0) @binding(0) var<uniform> params: Params;
    @group(0) @binding(1) var<storage, read_write> out: array<u32>;
    "#;

    /// Launches `width × height` with `params` and an output buffer of `words` u32s; returns it.
    pub fn run(
        dev: &dyn Device,
        pipeline: Pipeline,
        table: &ShaderBindingTable,
        params: &[u8],
        width: u32,
        height: u32,
        words: usize,
    ) -> Vec<u32> {
        let out = dev.create_buffer((words * 4) as u64).unwrap();
        dev.launch(
            pipeline,
            params,
            &[Resource::buffer(1, out)],
            table,
            LaunchSize::new(width, height, 1),
        )
        .unwrap_or_else(|e| panic!("{e}"));
        read(dev, out)
    }

    /// A pipeline with default options over `g`.
    pub fn pipeline(dev: &dyn Device, g: &Groups, max_trace_depth: u32) -> Pipeline {
        dev.create_pipeline(
            &PipelineCompileOptions::default(),
            &PipelineLinkOptions {
                max_trace_depth,
                ..Default::default()
            },
            &g.all(),
        )
        .unwrap_or_else(|e| panic!("{e}"))
    }

    pub fn raygen(m: Module, entry: &str) -> ProgramGroupDesc {
        ProgramGroupDesc::Raygen(ProgramRef::new(m, entry))
    }

    pub fn miss(m: Module, entry: &str) -> ProgramGroupDesc {
        ProgramGroupDesc::Miss(Some(ProgramRef::new(m, entry)))
    }

    pub fn closest_hit(m: Module, entry: &str) -> ProgramGroupDesc {
        ProgramGroupDesc::closest_hit(ProgramRef::new(m, entry))
    }

    /// One test ray: origin, tmin, direction, tmax.
    #[derive(Clone, Copy, Debug)]
    pub struct Ray {
        pub origin: [f32; 3],
        pub tmin: f32,
        pub direction: [f32; 3],
        pub tmax: f32,
    }

    impl Ray {
        pub fn new(origin: [f32; 3], direction: [f32; 3]) -> Ray {
            Ray {
                origin,
                tmin: 0.0,
                direction,
                tmax: 1e30,
            }
        }

        pub fn interval(self, tmin: f32, tmax: f32) -> Ray {
            Ray { tmin, tmax, ..self }
        }
    }

    /// Per-trace settings of [`RAY_LIST`] launches.
    #[derive(Clone, Copy, Debug)]
    pub struct TraceArgs {
        pub flags: u32,
        pub sbt_offset: u32,
        pub sbt_stride: u32,
        pub miss_index: u32,
        pub mask: u32,
        pub time: f32,
    }

    impl Default for TraceArgs {
        fn default() -> Self {
            TraceArgs {
                flags: 0,
                sbt_offset: 0,
                sbt_stride: 1,
                miss_index: 0,
                mask: 0xFF,
                time: 0.0,
            }
        }
    }

    /// A raygen tracing one ray per launch index from a ray buffer (binding 2) and writing the
    /// 8 payload words to `out` (binding 1). Payload on entry: 0xAAAAAAAA in every word.
    /// Closest-hit `closesthit__rec` records: 1, t, primitive, hit kind, instance id, SBT GAS
    /// index, the record's first data word, packed barycentrics; `miss__rec`: 2 and its record's
    /// first data word.
    pub const RAY_LIST: &str = r#"
    struct Params { handle: vec2<u32>, flags: u32, sbt_offset: u32, sbt_stride: u32, miss_index: u32, mask: u32, time_bits: u32 }
    @group(0) @binding(0) var<uniform> params: Params;
    @group(0) @binding(1) var<storage, read_write> out: array<u32>;
    @group(0) @binding(2) var<storage, read> rays: array<vec4<f32>>;

    fn raygen__rays() {
        let i = rt_launch_index().x;
        let o = rays[2u * i];
        let d = rays[2u * i + 1u];
        var p: RtPayload;
        for (var k = 0u; k < 8u; k = k + 1u) {
            p[k] = 0xAAAAAAAAu;
        }
        rt_trace(params.handle, o.xyz, d.xyz, o.w, d.w, bitcast<f32>(params.time_bits), params.mask, params.flags, params.sbt_offset, params.sbt_stride, params.miss_index, &p);
        for (var k = 0u; k < 8u; k = k + 1u) {
            out[8u * i + k] = p[k];
        }
    }

    fn closesthit__rec() {
        rt_set_payload(0u, 1u);
        rt_set_payload(1u, bitcast<u32>(rt_ray_tmax()));
        rt_set_payload(2u, rt_primitive_index());
        rt_set_payload(3u, rt_hit_kind());
        rt_set_payload(4u, rt_instance_id());
        rt_set_payload(5u, rt_sbt_gas_index());
        rt_set_payload(6u, rt_sbt_data_u32(0u));
        rt_set_payload(7u, pack2x16unorm(rt_triangle_barycentrics()));
    }

    fn miss__rec() {
        rt_set_payload(0u, 2u);
        rt_set_payload(6u, rt_sbt_data_u32(0u));
    }
    "#;

    /// What [`RAY_LIST`] recorded for one ray.
    #[derive(Clone, Copy, Debug, PartialEq)]
    pub struct Rec {
        pub words: [u32; 8],
    }

    impl Rec {
        pub fn hit(&self) -> bool {
            self.words[0] == 1
        }
        pub fn missed(&self) -> bool {
            self.words[0] == 2
        }
        /// Neither program ran (an invalid ray).
        pub fn untouched(&self) -> bool {
            self.words.iter().all(|&w| w == 0xAAAAAAAA)
        }
        pub fn t(&self) -> f32 {
            f32::from_bits(self.words[1])
        }
        pub fn prim(&self) -> u32 {
            self.words[2]
        }
        pub fn hit_kind(&self) -> u32 {
            self.words[3]
        }
        pub fn instance_id(&self) -> u32 {
            self.words[4]
        }
        pub fn gas_index(&self) -> u32 {
            self.words[5]
        }
        pub fn data(&self) -> u32 {
            self.words[6]
        }
        pub fn barycentrics(&self) -> [f32; 2] {
            let w = self.words[7];
            [(w & 0xFFFF) as f32 / 65535.0, (w >> 16) as f32 / 65535.0]
        }
    }

    /// Traces `rays` through a [`RAY_LIST`] pipeline.
    pub fn trace_rays(
        dev: &dyn Device,
        pipeline: Pipeline,
        table: &ShaderBindingTable,
        handle: TraversableHandle,
        rays: &[Ray],
        args: TraceArgs,
    ) -> Vec<Rec> {
        let ray_words: Vec<[f32; 4]> = rays
            .iter()
            .flat_map(|r| {
                [
                    [r.origin[0], r.origin[1], r.origin[2], r.tmin],
                    [r.direction[0], r.direction[1], r.direction[2], r.tmax],
                ]
            })
            .collect();
        let ray_buffer = buffer(dev, &ray_words);
        let out = dev.create_buffer((rays.len() * 32) as u64).unwrap();
        let mut words = handle.to_words().to_vec();
        words.extend_from_slice(&[
            args.flags,
            args.sbt_offset,
            args.sbt_stride,
            args.miss_index,
            args.mask,
            args.time.to_bits(),
        ]);
        dev.launch(
            pipeline,
            bytemuck::cast_slice(&words),
            &[Resource::buffer(1, out), Resource::buffer(2, ray_buffer)],
            table,
            LaunchSize::new(rays.len() as u32, 1, 1),
        )
        .unwrap_or_else(|e| panic!("{e}"));
        read::<u32>(dev, out)
            .chunks_exact(8)
            .map(|c| Rec {
                words: c.try_into().unwrap(),
            })
            .collect()
    }

    /// Groups for [`RAY_LIST`] with one miss group and `hits` closest-hit groups, plus `extra`.
    pub fn ray_list_groups(
        dev: &dyn Device,
        m: Module,
        hits: usize,
        extra: &[ProgramGroupDesc],
    ) -> Groups {
        let mut descs = vec![raygen(m, "raygen__rays"), miss(m, "miss__rec")];
        for _ in 0..hits {
            descs.push(closest_hit(m, "closesthit__rec"));
        }
        descs.extend_from_slice(extra);
        groups(dev, &descs)
    }

    /// An SBT whose records carry their index in the first data word (miss records 100 + i).
    pub fn numbered_sbt(dev: &dyn Device, g: &Groups) -> ShaderBindingTable {
        sbt_with(dev, g, |region, i| match region {
            GroupRegion::Raygen => Vec::new(),
            GroupRegion::Miss => vec![100 + i as u32],
            GroupRegion::HitGroup => vec![i as u32],
            GroupRegion::Callables => vec![200 + i as u32],
            GroupRegion::Exception => vec![300],
        })
    }
}
