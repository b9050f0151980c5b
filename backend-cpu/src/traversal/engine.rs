//! The traversal loop: graphs of instances and transforms down to geometry, BVH walks,
//! primitive tests, culling and flag resolution.

use super::ray::{PreparedRay, TriangleLanes, WideRay};
#[cfg(target_arch = "x86_64")]
use super::simd::F8;
use super::simd::{F4, Lanes};
use super::triangle::BlockHits;
use super::{Handler, Spec, curve, slab, sphere, triangle};
use crate::accel::curve_basis::BezierSegment;
#[cfg(target_arch = "x86_64")]
use crate::accel::wide::BLOCK_WIDTH;
use crate::accel::wide::{NODE_WIDTH, TriangleBlock, WideBvh, WideNode};
use crate::accel::{
    Aabb, Bvh, Gas, Geometry, Ias, InstanceRecord, MicromapRef, PrimitiveInfo, Resolved,
    SceneTable, Transform, Traversable,
};
use optik_api::semantics::motion::{self, KeyPosition};
use optik_api::semantics::opacity::{self, CandidateFate, MicromapState};
use optik_api::semantics::{affine, exception, facing, sbt_index};
use optik_api::{
    IDENTITY_3X4, InstanceFlags, Matrix3x4, PrimitiveTypeFlags, RayFlags, TraversableHandle,
};

/// A ray to trace, in world space, already checked valid (`semantics::ray::check`).
#[derive(Clone, Copy, Debug)]
pub struct TraceRay {
    /// Origin.
    pub origin: [f32; 3],
    /// Direction (not normalised; `t` is measured along it).
    pub direction: [f32; 3],
    /// Start of the interval.
    pub tmin: f32,
    /// End of the interval.
    pub tmax: f32,
    /// Time for motion.
    pub time: f32,
    /// Visibility mask.
    pub mask: u32,
    /// Ray flags.
    pub flags: RayFlags,
}

/// What the pipeline compiled that the traversal checks at run time.
#[derive(Clone, Copy, Debug)]
pub struct TraceConfig {
    /// Primitive types intersected; other geometry is skipped.
    pub primitive_types: PrimitiveTypeFlags,
    /// Whether intersection programs exist (custom primitives never hit without them).
    pub intersection: bool,
    /// Whether opacity micromaps are looked up.
    pub micromaps: bool,
    /// Whether debug exceptions are reported.
    pub debug_exceptions: bool,
    /// Deepest graph traversed (guards against cycles made by updates).
    pub max_graph_depth: u32,
}

/// The matrices of a path below at least one instance or transform.
#[derive(Clone, Copy, Debug)]
pub struct PathTransforms {
    /// Object-to-world of the whole path.
    pub object_to_world: Matrix3x4,
    /// World-to-object of the whole path.
    pub world_to_object: Matrix3x4,
}

/// The instances and transforms above a candidate.
#[derive(Clone, Copy, Debug)]
pub struct Path {
    /// The path's matrices; `None` at the root (identity), so that a trace without
    /// instances writes no matrices (24 floats a ray).
    pub transforms: Option<PathTransforms>,
    /// `rt_instance_id` of the innermost instance (0 without instances).
    pub instance_id: u32,
    /// `rt_instance_index` of the innermost instance (0 without instances).
    pub instance_index: u32,
    /// Sum of the SBT offsets of the instances on the path.
    pub sbt_offset: u32,
    /// Instance flags in force: any instance's culling and micromap flags, and the
    /// innermost any-hit override (`FLIP_TRIANGLE_FACING` is in `flip`).
    pub flags: InstanceFlags,
    /// Whether an odd number of instances flip facing.
    pub flip: bool,
    /// The ray's origin in object space.
    pub object_origin: [f32; 3],
    /// The ray's direction in object space.
    pub object_direction: [f32; 3],
}

impl Path {
    fn root(ray: &TraceRay) -> Path {
        Path {
            transforms: None,
            instance_id: 0,
            instance_index: 0,
            sbt_offset: 0,
            flags: InstanceFlags::NONE,
            flip: false,
            // Word by word (`traversal::words`): the caller stored the ray's scalars one
            // by one moments ago.
            object_origin: super::words(&ray.origin),
            object_direction: super::words(&ray.direction),
        }
    }

    /// Object-to-world of the whole path.
    pub fn object_to_world(&self) -> Matrix3x4 {
        self.transforms.map_or(IDENTITY_3X4, |t| t.object_to_world)
    }

    /// World-to-object of the whole path.
    pub fn world_to_object(&self) -> Matrix3x4 {
        self.transforms.map_or(IDENTITY_3X4, |t| t.world_to_object)
    }

    /// The path below a transform with these matrices; `None` when the object-space ray is
    /// not finite (the transform crushes or explodes it: nothing below can be hit).
    fn transformed(
        &self,
        object_to_world: &Matrix3x4,
        world_to_object: &Matrix3x4,
    ) -> Option<Path> {
        let origin = affine::transform_point(world_to_object, self.object_origin);
        let direction = affine::transform_vector(world_to_object, self.object_direction);
        if !origin.iter().chain(direction.iter()).all(|v| v.is_finite()) {
            return None;
        }
        // Composed with the identity at the root, as a path that kept its matrices would
        // (the product, not the matrix itself: it differs in the sign of zeros).
        Some(Path {
            transforms: Some(PathTransforms {
                object_to_world: affine::mul(&self.object_to_world(), object_to_world),
                world_to_object: affine::mul(world_to_object, &self.world_to_object()),
            }),
            object_origin: origin,
            object_direction: direction,
            ..*self
        })
    }

    fn instance(&self, inst: &InstanceRecord) -> Option<Path> {
        let mut p = self.transformed(&inst.object_to_world, &inst.world_to_object)?;
        let flags = InstanceFlags(inst.flags);
        let overrides = InstanceFlags::DISABLE_ANYHIT | InstanceFlags::ENFORCE_ANYHIT;
        let mut combined = InstanceFlags(
            self.flags.0 | (flags.0 & !overrides.0 & !InstanceFlags::FLIP_TRIANGLE_FACING.0),
        );
        if flags.intersects(overrides) {
            combined = InstanceFlags((combined.0 & !overrides.0) | (flags.0 & overrides.0));
        }
        p.flags = combined;
        p.flip = self.flip != facing::flips(flags);
        p.instance_id = inst.instance_id;
        p.instance_index = inst.instance_index;
        p.sbt_offset = self.sbt_offset.wrapping_add(inst.sbt_offset);
        Some(p)
    }
}

/// Geometry of a built-in primitive hit, as programs query it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum HitData {
    /// A triangle: its object-space vertices (interpolated at the ray's time) and the hit's
    /// barycentrics.
    Triangle {
        /// The vertices.
        vertices: TriangleVertices,
        /// Weights of vertices 1 and 2.
        barycentrics: [f32; 2],
    },
    /// A sphere: centre and radius in object space.
    Sphere {
        /// `(centre.xyz, radius)`.
        sphere: [f32; 4],
    },
    /// A curve: the hit's curve parameter.
    Curve {
        /// In [0, 1].
        u: f32,
    },
}

/// Where a triangle hit's object-space vertices are: a copy (moving triangles, interpolated
/// at the ray's time), or a lane of the triangle block the test read, gathered only when a
/// program asks for them. Every candidate and committed hit carries its vertices, and few
/// programs read them: copying the nine words out of the block's lanes cost ~35 instructions
/// a hit (docs/cpu-backend.md §8).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriangleVertices(VertexSource);

#[derive(Clone, Copy, Debug, PartialEq)]
enum VertexSource {
    Copied([[f32; 3]; 3]),
    /// Lane `lane` of `block`, a block of the structure walked.
    Lane {
        block: *const TriangleBlock,
        lane: usize,
    },
}

impl TriangleVertices {
    /// The vertices themselves.
    pub fn copied(vertices: [[f32; 3]; 3]) -> TriangleVertices {
        TriangleVertices(VertexSource::Copied(vertices))
    }

    /// Lane `lane` of `block`, read when asked.
    fn of_lane(block: &TriangleBlock, lane: usize) -> TriangleVertices {
        TriangleVertices(VertexSource::Lane { block, lane })
    }

    /// The vertices.
    ///
    /// # Safety
    /// The structure whose walk reported this hit is alive (as it is while the trace, or
    /// the launch, that walked it runs).
    pub unsafe fn get(&self) -> [[f32; 3]; 3] {
        match self.0 {
            VertexSource::Copied(v) => v,
            VertexSource::Lane { block, lane } => {
                // SAFETY: `block` is a block of the structure walked (`of_lane`), alive as
                // the caller promises.
                let block = unsafe { &*block };
                std::array::from_fn(|v| std::array::from_fn(|a| block.vertices[v][a][lane]))
            }
        }
    }
}

/// A built-in primitive hit found by the traversal.
#[derive(Clone, Copy, Debug)]
pub struct Candidate<'a> {
    /// Distance along the ray.
    pub t: f32,
    /// The primitive.
    pub info: &'a PrimitiveInfo,
    /// The hit kind (`0xFE` front, `0xFF` back).
    pub hit_kind: u32,
    /// Primitive-specific data.
    pub data: HitData,
}

/// A custom primitive the ray reaches.
#[derive(Clone, Copy, Debug)]
pub struct CustomPrimitive<'a> {
    /// The primitive.
    pub info: &'a PrimitiveInfo,
    /// Its box at the ray's time.
    pub aabb: Aabb,
}

/// Traces `ray` against the traversable `root` of `scene`, reporting candidates to `handler`.
pub fn trace<S: Spec, H: Handler>(
    scene: &SceneTable,
    root: TraversableHandle,
    ray: &TraceRay,
    config: &TraceConfig,
    handler: &mut H,
) {
    let walker = Walker::<S>::new(scene, ray, config);
    match scene.resolve(root) {
        Resolved::Null => {}
        Resolved::Invalid => walker.invalid_traversable(handler),
        Resolved::Live(t) => match &**t {
            // A geometry root (every trace without instancing) is walked here: `visit` is a
            // call, a depth check and a match more per ray (level 1 is within any limit).
            Traversable::Geometry(g) => walker.gas(g, &Path::root(ray), handler),
            _ => walker.visit(t, &Path::root(ray), 1, handler),
        },
    }
}

/// The static triangle structure at `root` when a trace from it walks the triangle blocks
/// straight away (a geometry root of triangles this pipeline traces, without motion keys it
/// interpolates): [`trace_blocks`] then traces it as [`trace`] would. `None` for any other
/// root (or an empty one). The scene does not change during a launch, so a launch looks this
/// up once per root.
pub fn blocks_root<'s, S: Spec>(
    scene: &'s SceneTable,
    root: TraversableHandle,
    config: &TraceConfig,
) -> Option<&'s Gas> {
    let Resolved::Live(t) = scene.resolve(root) else {
        return None;
    };
    let Traversable::Geometry(g) = &**t else {
        return None;
    };
    // The conditions under which `Walker::gas` walks the triangle blocks from this node.
    if !config.primitive_types.contains(g.geometry.primitive_type())
        || (S::MOTION && g.motion.is_some())
        || !walks_triangle_blocks(g)
    {
        return None;
    }
    Some(g)
}

/// [`trace`] from a root that [`blocks_root`] gave `g` for: the same walk, without looking
/// the root up again.
pub fn trace_blocks<S: Spec, H: Handler>(
    scene: &SceneTable,
    g: &Gas,
    ray: &TraceRay,
    config: &TraceConfig,
    handler: &mut H,
) {
    let walker = Walker::<S>::new(scene, ray, config);
    walker.triangle_blocks(g, &Path::root(ray), handler)
}

/// Whether a walk of `g` runs over its triangle blocks (static triangles packed four to a
/// block), not per primitive.
#[inline(always)]
fn walks_triangle_blocks(g: &Gas) -> bool {
    matches!(g.geometry, Geometry::Triangles(_)) && !g.encoding.blocks.is_empty()
}

/// Whether a ray certainly enters none of the root's children whose union is `bounds`
/// (`WideBvh::root_bounds` of a [`blocks_root`]), so that a trace from that root finds
/// nothing.
///
/// The root node's test (`slab::entry_wide`, its lanes' arithmetic) on the union box: the
/// same canonical direction and reciprocal, near and far planes by direction sign, NaN
/// distances ignored, the same exit widening and interval. Each distance is a rounded
/// difference times a reciprocal, monotone in the plane, so the union's entry is at most and
/// its exit at least every child's: a ray the union test rejects, the node test rejects in
/// every lane.
///
/// The three axes' preparation and distances run in three lanes of one `F4` (each lane the
/// scalar operation, so the same bits as `entry_wide`, which the tests hold it to), near and
/// far selected without a branch: one division instead of three (a check ~85 → ~70
/// instructions with its root look-up).
#[inline(always)]
pub fn misses_bounds<S: Spec>(
    bounds: &[[f32; 3]; 2],
    origin: [f32; 3],
    direction: [f32; 3],
    tmin: f32,
    tmax: f32,
) -> bool {
    let lanes = |v: &[f32; 3]| F4::load(&[v[0], v[1], v[2], 0.0]);
    let zero = F4::splat(0.0);
    // Canonical (`-0` made `+0`), as `WideRay::new`.
    let dir = lanes(&direction) + zero;
    let axes = 0b111;
    if dir.eq(zero).bits() & axes == axes {
        // No built-in primitive is hit by a ray without direction (as the walk decides).
        return true;
    }
    let inv = F4::splat(1.0) / dir;
    // As `ray::far_reciprocal`, lane by lane.
    let inv_far = inv * F4::splat(super::ray::exit_scale(S::CONSERVATIVE));
    let o = lanes(&origin);
    let [lo, hi] = bounds;
    let (lo, hi) = (lanes(lo) - o, lanes(hi) - o);
    // Near and far by direction sign, selected without a branch (signs vary across a view).
    let negative = dir.lt(zero);
    let near = (F4::select(negative, hi, lo) * inv).to_array();
    let far = (F4::select(negative, lo, hi) * inv_far).to_array();
    let mut t0 = tmin;
    let mut t1 = tmax;
    for a in 0..3 {
        let (tn, tf) = (near[a], far[a]);
        // `x > t0` is false for NaN: a NaN distance does not constrain the interval.
        t0 = if tn > t0 { tn } else { t0 };
        t1 = if tf < t1 { tf } else { t1 };
    }
    // Neither is NaN (each is a number or replaced only by a number), so this is the
    // node test's `!(t0 <= t1)`.
    t0 > t1
}

/// What the leaf calls of one walk share, handed to each by one pointer: the walk keeps one
/// word for them instead of five, and a call passes four arguments in registers instead of
/// eight, two of them on the stack (Breakfast Room rays 1–3 % faster, docs/cpu-backend.md).
struct LeafContext<'w, 'a, S: Spec> {
    /// The trace's walker.
    walker: &'w Walker<'a, S>,
    /// The structure walked.
    g: &'w Gas,
    /// The path to it from the trace's root.
    path: &'w Path,
    /// The ray in the structure's space.
    wr: &'w WideRay,
    /// The triangle tests' constants, made at the first leaf.
    lanes_of_ray: Option<TriangleLanes>,
}

impl<S: Spec> LeafContext<'_, '_, S> {
    /// [`Walker::leaf_blocks`] with this walk's shared values.
    #[inline(always)]
    fn leaf_blocks<H: Handler, const PAIRS: bool>(&mut self, h: &mut H, first: u32, count: u32) {
        let (g, path, wr) = (self.g, self.path, self.wr);
        self.walker
            .leaf_blocks::<H, PAIRS>(g, path, wr, &mut self.lanes_of_ray, h, first, count)
    }
}

struct Walker<'a, S: Spec> {
    scene: &'a SceneTable,
    ray: &'a TraceRay,
    config: &'a TraceConfig,
    _spec: std::marker::PhantomData<S>,
}

/// Entries of the BVH walk's stack: a node and the distance where the ray enters it.
const INLINE_STACK: usize = 64;

impl<'a, S: Spec> Walker<'a, S> {
    fn new(scene: &'a SceneTable, ray: &'a TraceRay, config: &'a TraceConfig) -> Walker<'a, S> {
        Walker {
            scene,
            ray,
            config,
            _spec: std::marker::PhantomData,
        }
    }
}

impl<S: Spec> Walker<'_, S> {
    fn invalid_traversable<H: Handler>(&self, h: &mut H) {
        if self.config.debug_exceptions {
            h.traversal_exception(exception::INVALID_TRAVERSABLE);
        }
    }

    fn visit<H: Handler>(&self, t: &Traversable, path: &Path, level: u32, h: &mut H) {
        if level > self.config.max_graph_depth {
            return;
        }
        match t {
            Traversable::Geometry(g) => self.gas(g, path, h),
            Traversable::Instances(ias) => {
                if S::INSTANCING {
                    self.ias(ias, path, level, h);
                } else {
                    self.invalid_traversable(h);
                }
            }
            Traversable::Transform(tr) => {
                if S::INSTANCING {
                    self.transform(tr, path, level, h);
                } else {
                    self.invalid_traversable(h);
                }
            }
        }
    }

    fn child<H: Handler>(&self, handle: TraversableHandle, path: &Path, level: u32, h: &mut H) {
        match self.scene.resolve(handle) {
            Resolved::Null => {}
            Resolved::Invalid => self.invalid_traversable(h),
            Resolved::Live(c) => self.visit(c, path, level + 1, h),
        }
    }

    fn transform<H: Handler>(&self, tr: &Transform, path: &Path, level: u32, h: &mut H) {
        let Some(o2w) = tr.object_to_world_at(self.ray.time, S::MOTION) else {
            return;
        };
        let w2o = match &tr.kind {
            crate::accel::TransformKind::Static {
                world_to_object, ..
            } => *world_to_object,
            _ => match affine::inverse(&o2w) {
                Some(m) => m,
                None => return,
            },
        };
        if let Some(p) = path.transformed(&o2w, &w2o) {
            self.child(tr.child, &p, level, h);
        }
    }

    fn ias<H: Handler>(&self, ias: &Ias, path: &Path, level: u32, h: &mut H) {
        let pr = PreparedRay::new(path.object_origin, path.object_direction, S::CONSERVATIVE);
        walk(&ias.bvh, &pr, self.ray.tmin, h, |h, first, count| {
            for inst in &ias.instances[first as usize..(first + count) as usize] {
                if !sbt_index::instance_visible(inst.mask, self.ray.mask) {
                    continue;
                }
                if let Some(p) = path.instance(inst) {
                    self.child(TraversableHandle(inst.child), &p, level, h);
                }
                if h.done() {
                    return;
                }
            }
        });
    }

    // Inlined into `visit`: a call less per ray (+6 % on bunny camera rays).
    #[inline(always)]
    fn gas<H: Handler>(&self, g: &Gas, path: &Path, h: &mut H) {
        if !self
            .config
            .primitive_types
            .contains(g.geometry.primitive_type())
        {
            if self.config.debug_exceptions && !g.bvh.nodes().is_empty() {
                h.traversal_exception(exception::UNSUPPORTED_PRIMITIVE_TYPE);
            }
            return;
        }
        let at = match (S::MOTION, &g.motion) {
            (true, Some(m)) => match motion::resolve_key(m, self.ray.time) {
                Some(at) => at,
                None => return,
            },
            _ => KeyPosition { key: 0, t: 0.0 },
        };
        let tmin = self.ray.tmin;
        let wide = &g.encoding;
        if walks_triangle_blocks(g) {
            return self.triangle_blocks(g, path, h);
        }
        let pr = PreparedRay::new(path.object_origin, path.object_direction, S::CONSERVATIVE);
        let wr = WideRay::of(&pr);
        match &g.geometry {
            Geometry::Triangles(tris) => self.walk(wide, &wr, tmin, h, |h, first, count| {
                for s in first as usize..(first + count) as usize {
                    let tri = lerp_key(&tris.keys, at, s, |a, b, f| {
                        std::array::from_fn(|v| lerp3(a[v], b[v], f))
                    });
                    let hit = if S::WATERTIGHT {
                        triangle::watertight(&pr, &tri, tmin, h.t_max())
                    } else {
                        triangle::moller_trumbore(&pr, &tri, tmin, h.t_max())
                    };
                    let Some(hit) = hit else { continue };
                    let tri = TriangleVertices::copied(tri);
                    self.triangle_hit_at(g, s, &g.primitives[s], tri, hit, path, h);
                    if h.done() {
                        return;
                    }
                }
            }),
            Geometry::Custom(custom) => {
                if !self.config.intersection {
                    return;
                }
                self.walk(wide, &wr, tmin, h, |h, first, count| {
                    for s in first as usize..(first + count) as usize {
                        let aabb = lerp_key(&custom.keys, at, s, |a, b, f| Aabb {
                            min: lerp3(a.min, b.min, f),
                            max: lerp3(a.max, b.max, f),
                        });
                        if slab::entry(&pr, &aabb.min, &aabb.max, tmin, h.t_max()).is_none() {
                            continue;
                        }
                        let info = &g.primitives[s];
                        let fate = self.fate(info, path, None);
                        if fate == CandidateFate::Culled {
                            continue;
                        }
                        h.custom::<S>(&CustomPrimitive { info, aabb }, path, fate);
                        if h.done() {
                            return;
                        }
                    }
                })
            }
            Geometry::Spheres(spheres) => self.walk(wide, &wr, tmin, h, |h, first, count| {
                for s in first as usize..(first + count) as usize {
                    let sp = lerp_key(&spheres.keys, at, s, |a, b, f| {
                        std::array::from_fn(|k| lerp(a[k], b[k], f))
                    });
                    let Some(hit) = sphere::intersect(pr.origin, pr.dir, sp, tmin, h.t_max())
                    else {
                        continue;
                    };
                    let info = &g.primitives[s];
                    let fate = self.fate(info, path, None);
                    if fate == CandidateFate::Culled {
                        continue;
                    }
                    let data = HitData::Sphere { sphere: sp };
                    h.candidate::<S>(
                        &Candidate {
                            t: hit.t,
                            info,
                            hit_kind: facing::triangle_hit_kind(hit.front),
                            data,
                        },
                        path,
                        fate,
                    );
                    if h.done() {
                        return;
                    }
                }
            }),
            Geometry::Curves(curves) => self.walk(wide, &wr, tmin, h, |h, first, count| {
                for s in first as usize..(first + count) as usize {
                    let cp = lerp_key(&curves.keys, at, s, |a, b, f| {
                        std::array::from_fn(|i| std::array::from_fn(|k| lerp(a[i][k], b[i][k], f)))
                    });
                    let seg = BezierSegment::from_basis(curves.curve_type, &cp);
                    let Some(hit) =
                        curve::intersect(pr.origin, pr.dir, &seg, curves.caps[s], tmin, h.t_max())
                    else {
                        continue;
                    };
                    let info = &g.primitives[s];
                    let fate = self.fate(info, path, None);
                    if fate == CandidateFate::Culled {
                        continue;
                    }
                    let data = HitData::Curve { u: hit.u };
                    h.candidate::<S>(
                        &Candidate {
                            t: hit.t,
                            info,
                            hit_kind: facing::triangle_hit_kind(true),
                            data,
                        },
                        path,
                        fate,
                    );
                    if h.done() {
                        return;
                    }
                }
            }),
        }
    }
}

impl<S: Spec> Walker<'_, S> {
    /// Walks a wide BVH front to back: at each node the children the ray enters are
    /// visited nearest first (the others wait on a stack with their entry distances), and
    /// `leaf(handler, first, count)` is called for every leaf entered before the handler's
    /// current `t_max`, until the handler is done. The node test is AVX's where the CPU has
    /// it, else two 4-lane halves: the same bits either way, so the same walk; both use this
    /// pipeline's box test (`S::CONSERVATIVE`).
    #[inline(always)]
    fn walk<H: Handler>(
        &self,
        wide: &WideBvh,
        ray: &WideRay,
        tmin: f32,
        h: &mut H,
        leaf: impl FnMut(&mut H, u32, u32),
    ) {
        #[cfg(target_arch = "x86_64")]
        if walks_with_avx() {
            let [[ox, oy, oz], [ix, iy, iz]] = ray.box_constants();
            // SAFETY: the CPU has AVX and the bit-counting instructions `walk_wide_avx`
            // enables.
            return unsafe {
                walk_wide_avx::<S, H>(wide, ray, ox, oy, oz, ix, iy, iz, tmin, h, leaf)
            };
        }
        let test = slab::Halves::new(ray, tmin, S::CONSERVATIVE);
        walk_wide_on(wide, test, h, leaf)
    }

    /// The triangle blocks of a static triangle structure. Only the box test's
    /// constants are prepared up front; the triangle tests' (the watertight shear, two
    /// divisions) wait for the first leaf the ray reaches.
    #[inline(always)]
    fn triangle_blocks<H: Handler>(&self, g: &Gas, path: &Path, h: &mut H) {
        // The origin a component at a time from registers (`traversal::in_register`): a
        // root's path was built from the ray moments ago in the caller that inlines this
        // (`trace_blocks`), whose registers still hold it. Read back word by word it waited
        // on the path's stores (~2 % of a ray on AMD Zen 4), and read plainly LLVM copied it
        // into the prepared ray as an 8-byte and a 4-byte word, the first spanning two of
        // those stores (which stalls; docs/cpu-backend.md, "the root path's origin from
        // registers"). The direction goes into arithmetic at once, so LLVM keeps it in
        // registers without help.
        let o = &path.object_origin;
        let wr = WideRay::new(
            [
                super::in_register(o[0]),
                super::in_register(o[1]),
                super::in_register(o[2]),
            ],
            path.object_direction,
        );
        // A zero direction hits no triangle (the scalar tests say so per triangle).
        if !wr.moves() {
            return;
        }
        let tmin = self.ray.tmin;
        let wide = &g.encoding;
        let mut context = LeafContext {
            walker: self,
            g,
            path,
            wr: &wr,
            lanes_of_ray: None,
        };
        // The walk and the leaves compiled for AVX where the CPU has it, chosen once.
        #[cfg(target_arch = "x86_64")]
        if walks_with_avx() {
            let leaf = |h: &mut H, first, count| {
                // SAFETY: the CPU has AVX and the bit-counting instructions (checked above).
                unsafe { Self::leaf_blocks_avx(&mut context, h, first, count) }
            };
            let ([ox, oy, oz], [ix, iy, iz]) = (wr.origin1, wr.inv1);
            // SAFETY: as above.
            return unsafe {
                walk_wide_avx::<S, H>(wide, &wr, ox, oy, oz, ix, iy, iz, tmin, h, leaf)
            };
        }
        self.walk(wide, &wr, tmin, h, |h, first, count| {
            context.leaf_blocks::<H, false>(h, first, count)
        })
    }

    /// [`Walker::leaf_blocks`] compiled for AVX: a leaf's blocks two at a time in eight
    /// lanes (`PAIRS`; an odd last block in four), the 4-lane operations VEX-encoded (three
    /// operands, without the register copies two-operand SSE needs: Breakfast Room camera
    /// rays 2155 → 2097 instructions each). No fused multiply-add is enabled, so every lane
    /// computes what the SSE form does, bit for bit. Not inlined into the walk
    /// (which has the same features): the walk's loop is faster without a leaf's registers
    /// in it (the leaf inlined into the walk measured 3–15 % slower, docs/cpu-backend.md).
    ///
    /// # Safety
    /// The CPU has AVX, popcnt, lzcnt and bmi1 (`slab::has_avx`).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx,popcnt,lzcnt,bmi1")]
    #[inline(never)]
    unsafe fn leaf_blocks_avx<H: Handler>(
        context: &mut LeafContext<'_, '_, S>,
        h: &mut H,
        first: u32,
        count: u32,
    ) {
        context.leaf_blocks::<H, true>(h, first, count)
    }

    /// The leaf of `count` triangles from block `first`: its blocks tested four lanes at a
    /// time, or with `PAIRS` (only where the CPU has AVX) two blocks at a time in eight
    /// lanes, their hits reported in lane order (block by block, as one at a time would).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn leaf_blocks<H: Handler, const PAIRS: bool>(
        &self,
        g: &Gas,
        path: &Path,
        wr: &WideRay,
        lanes_of_ray: &mut Option<TriangleLanes>,
        h: &mut H,
        first: u32,
        count: u32,
    ) {
        let tmin = self.ray.tmin;
        let wide = &g.encoding;
        // The triangle constants, once the ray reaches its first leaf.
        let lanes_of_ray = lanes_of_ray.get_or_insert_with(|| {
            if S::WATERTIGHT {
                TriangleLanes::new(wr)
            } else {
                TriangleLanes::for_moller_trumbore(wr)
            }
        });
        let blocks = TriangleBlock::blocks_of(count);
        if blocks == 1 {
            // Most leaves (all but a few of the bunny's, two thirds of the Breakfast Room's):
            // one test and no loop, so the hit path's loads stay in the hit path instead of
            // being hoisted out of a loop to the entry of every leaf (bunny incoherent rays
            // 1342 → 1298 instructions each, Breakfast Room camera 1841 → 1800).
            let block = &wide.blocks[first as usize];
            let hits = Self::block_test(lanes_of_ray, block, count, 0, tmin, h.t_max());
            self.report_block_hits(g, path, h, &hits, |lane| (block, lane));
            return;
        }
        let mut k = 0;
        #[cfg(target_arch = "x86_64")]
        if PAIRS && blocks >= 2 {
            // SAFETY: `PAIRS` only from `leaf_blocks_avx`, whose callers checked for AVX.
            let lanes_of_ray = unsafe { lanes_of_ray.widen() };
            while k + 2 <= blocks {
                let pair = [
                    &wide.blocks[(first + k) as usize],
                    &wide.blocks[(first + k + 1) as usize],
                ];
                // A hit of the second block that the first block's commits moved beyond
                // the interval is dropped in `report_block_hits`, as testing the second
                // block after them would have: the same hits, bit for bit.
                let hits = Self::pair_test(&lanes_of_ray, pair, count, k, tmin, h.t_max());
                if hits.mask != 0 && self.report_pair_hits(g, path, h, &hits, pair) {
                    return;
                }
                k += 2;
            }
        }
        while k < blocks {
            let block = &wide.blocks[(first + k) as usize];
            let hits = Self::block_test(lanes_of_ray, block, count, k, tmin, h.t_max());
            if self.report_block_hits(g, path, h, &hits, |lane| (block, lane)) {
                return;
            }
            k += 1;
        }
    }

    /// The pipeline's triangle test on block `k` (`block`) of a leaf of `count` triangles,
    /// its four lanes at once (bit for bit as the scalar test).
    #[inline(always)]
    fn block_test(
        lanes_of_ray: &TriangleLanes,
        block: &TriangleBlock,
        count: u32,
        k: u32,
        tmin: f32,
        tmax: f32,
    ) -> BlockHits {
        let lanes = TriangleBlock::lane_mask(count, k);
        if S::WATERTIGHT {
            triangle::watertight4(lanes_of_ray, block, lanes, tmin, tmax)
        } else {
            triangle::moller_trumbore4(lanes_of_ray, block, lanes, tmin, tmax)
        }
    }

    /// [`Walker::block_test`] on blocks `k` and `k + 1` (`pair`) of a leaf of `count`
    /// triangles, in eight lanes (the first block's in lanes 0–3).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn pair_test(
        lanes_of_ray: &TriangleLanes<F8>,
        pair: [&TriangleBlock; 2],
        count: u32,
        k: u32,
        tmin: f32,
        tmax: f32,
    ) -> BlockHits<F8> {
        let lanes = TriangleBlock::lane_mask(count, k)
            | TriangleBlock::lane_mask(count, k + 1) << BLOCK_WIDTH;
        if S::WATERTIGHT {
            triangle::watertight8(lanes_of_ray, pair, lanes, tmin, tmax)
        } else {
            triangle::moller_trumbore8(lanes_of_ray, pair, lanes, tmin, tmax)
        }
    }

    /// Hands a block test's hits to the handler in lane order (`in_block(lane)`: the block
    /// and the lane within it); whether the handler is done.
    #[inline(always)]
    fn report_block_hits<'b, H: Handler, L: Lanes>(
        &self,
        g: &Gas,
        path: &Path,
        h: &mut H,
        hits: &BlockHits<L>,
        in_block: impl Fn(usize) -> (&'b TriangleBlock, usize),
    ) -> bool {
        let mut mask = hits.mask;
        while mask != 0 {
            let lane = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            let hit = hits.lane(lane);
            // A hit an earlier lane's commit moved beyond the interval is one the scalar
            // order would not have found (`t` of a hit is a number, so `>=` is `!<`).
            if hit.t >= h.t_max() {
                continue;
            }
            let (block, lane) = in_block(lane);
            let s = block.slot(lane) as usize;
            // The block holds the vertices key 0 holds (bit for bit), in lines already
            // loaded: reading the slot's key-0 copy cost a cache miss per candidate.
            let tri = TriangleVertices::of_lane(block, lane);
            let info = block.info(lane, &g.encoding.classes, &g.primitives);
            self.triangle_hit_at(g, s, &info, tri, hit, path, h);
            if h.done() {
                return true;
            }
        }
        false
    }

    /// [`Walker::report_block_hits`] for a pair of blocks. Not inlined: the hit handling
    /// inlined into the pair loop too crowded the leaf with its loads and spills (Breakfast
    /// Room camera rays: 1900 instructions each with it inlined in both loops, 1867 with it
    /// in neither); single blocks, most leaves, keep it inlined (a call per candidate there
    /// measured +16 to +51 instructions a ray).
    #[cfg(target_arch = "x86_64")]
    #[inline(never)]
    fn report_pair_hits<H: Handler>(
        &self,
        g: &Gas,
        path: &Path,
        h: &mut H,
        hits: &BlockHits<F8>,
        pair: [&TriangleBlock; 2],
    ) -> bool {
        let in_block = |lane: usize| (pair[lane / BLOCK_WIDTH], lane % BLOCK_WIDTH);
        self.report_block_hits(g, path, h, hits, in_block)
    }

    /// The fate of a candidate of `info` below `path` (`micromap`: the opacity micromap
    /// state at the hit, where one applies): `semantics::opacity::resolve`, except that a
    /// pipeline without any-hit programs accepts opaque and non-opaque candidates alike, so
    /// when the ray culls neither kind and no micromap applies there is nothing to resolve
    /// (every such candidate is accepted, as `Opaque`).
    #[inline(always)]
    fn fate(
        &self,
        info: &PrimitiveInfo,
        path: &Path,
        micromap: Option<MicromapState>,
    ) -> CandidateFate {
        let flags = self.ray.flags;
        let culls = RayFlags::CULL_DISABLED_ANYHIT | RayFlags::CULL_ENFORCED_ANYHIT;
        if !S::ANY_HIT && micromap.is_none() && !flags.intersects(culls) {
            return CandidateFate::Opaque;
        }
        opacity::resolve(info.flags(), path.flags, flags, micromap)
    }

    /// A triangle's hit (with the slot's record and the vertices it was tested with):
    /// facing, culling, micromap and flag resolution, then the handler's candidate.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn triangle_hit_at<H: Handler>(
        &self,
        g: &Gas,
        s: usize,
        info: &PrimitiveInfo,
        tri: TriangleVertices,
        hit: triangle::TriangleHit,
        path: &Path,
        h: &mut H,
    ) {
        let Geometry::Triangles(tris) = &g.geometry else {
            return;
        };
        let flags = self.ray.flags;
        // The test's facing is decided in object space; instances may flip it.
        let front = facing::is_front_face(if hit.front { -1.0 } else { 1.0 }, path.flip);
        if opacity::triangle_face_culled(front, info.flags(), path.flags, flags) {
            return;
        }
        let micromap = match (&tris.micromaps, self.config.micromaps) {
            (Some(m), true) => match m.refs[s] {
                MicromapRef { array, index } if array != MicromapRef::NONE.array => {
                    Some(m.arrays[array as usize].state(index, hit.u, hit.v))
                }
                _ => None,
            },
            _ => None,
        };
        let fate = self.fate(info, path, micromap);
        if fate == CandidateFate::Culled {
            return;
        }
        let data = HitData::Triangle {
            vertices: tri,
            barycentrics: [hit.u, hit.v],
        };
        h.candidate::<S>(
            &Candidate {
                t: hit.t,
                info,
                hit_kind: facing::triangle_hit_kind(front),
                data,
            },
            path,
            fate,
        );
    }
}

fn lerp(a: f32, b: f32, f: f32) -> f32 {
    a * (1.0 - f) + b * f
}

fn lerp3(a: [f32; 3], b: [f32; 3], f: f32) -> [f32; 3] {
    [
        lerp(a[0], b[0], f),
        lerp(a[1], b[1], f),
        lerp(a[2], b[2], f),
    ]
}

/// Slot `s` of the keys at a key position: key `at.key` alone when `at.t == 0` (always for
/// static structures), else interpolated towards the next key.
#[inline(always)]
fn lerp_key<T: Copy>(
    keys: &[Vec<T>],
    at: KeyPosition,
    s: usize,
    mix: impl Fn(&T, &T, f32) -> T,
) -> T {
    let a = &keys[at.key][s];
    if at.t == 0.0 || at.key + 1 >= keys.len() {
        *a
    } else {
        mix(a, &keys[at.key + 1][s], at.t)
    }
}

/// Walks a BVH front to back, calling `leaf(handler, first_slot, count)` for every leaf the
/// ray reaches before the handler's current `t_max`, until the handler is done.
#[inline(always)]
fn walk<H: Handler>(
    bvh: &Bvh,
    ray: &PreparedRay,
    tmin: f32,
    h: &mut H,
    mut leaf: impl FnMut(&mut H, u32, u32),
) {
    let nodes = bvh.nodes();
    let Some(root) = nodes.first() else { return };
    if slab::entry(ray, &root.min, &root.max, tmin, h.t_max()).is_none() {
        return;
    }
    let mut inline = [(0u32, 0.0f32); INLINE_STACK];
    let mut len = 0usize;
    let mut spill: Vec<(u32, f32)> = Vec::new();
    let mut node = 0u32;
    loop {
        let n = &nodes[node as usize];
        let mut next = None;
        if n.is_leaf() {
            leaf(h, n.first, n.count);
            if h.done() {
                return;
            }
        } else {
            let tmax = h.t_max();
            let (a, b) = (n.first, n.first + 1);
            let (na, nb) = (&nodes[a as usize], &nodes[b as usize]);
            let ea = slab::entry(ray, &na.min, &na.max, tmin, tmax);
            let eb = slab::entry(ray, &nb.min, &nb.max, tmin, tmax);
            match (ea, eb) {
                (Some(ta), Some(tb)) => {
                    let (near, far, tfar) = if tb < ta { (b, a, ta) } else { (a, b, tb) };
                    if len < INLINE_STACK {
                        inline[len] = (far, tfar);
                        len += 1;
                    } else {
                        spill.push((far, tfar));
                    }
                    next = Some(near);
                }
                (Some(_), None) => next = Some(a),
                (None, Some(_)) => next = Some(b),
                (None, None) => {}
            }
        }
        node = match next {
            Some(c) => c,
            None => loop {
                let popped = if let Some(e) = spill.pop() {
                    e
                } else if len > 0 {
                    len -= 1;
                    inline[len]
                } else {
                    return;
                };
                // A node entered beyond the closest hit found since it was pushed can hold
                // nothing nearer.
                if popped.1 <= h.t_max() {
                    break popped.0;
                }
            },
        };
    }
}

/// A stack entry of the wide walk: a child (inner: `count == 0`, `first` its node; leaf:
/// `first`, `count` as the node stores them) and the distance where the ray enters it.
#[derive(Clone, Copy)]
struct Pending {
    first: u32,
    count: u32,
    entry: f32,
}

/// Entries kept on the native stack: trees up to 27 levels deep (a node pushes at most
/// seven); deeper ones get a heap stack for the walk.
const WIDE_STACK: usize = 190;

/// [`Walker::walk`] with the AVX node test: compiled for AVX as a whole, so the test's
/// intrinsics inline into the loop (a `target_feature` function inlines only into callers
/// with the feature).
///
/// The ray's box constants (`WideRay::box_constants`: origin `o*`, then reciprocal `i*`)
/// come as six scalar arguments, which the calling convention passes in vector registers
/// (arrays would be passed through memory), rather than read back from `ray`: its caller
/// has just computed them, and reading the prepared ray it stored moments before put a
/// store's forwarding on the way to the root's test (~1 % of a ray on AMD Zen 4,
/// docs/cpu-backend.md, "the root path's origin from registers"). `ray` gives the
/// direction signs.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx,popcnt,lzcnt,bmi1")]
#[allow(clippy::too_many_arguments)]
fn walk_wide_avx<S: Spec, H: Handler>(
    wide: &WideBvh,
    ray: &WideRay,
    ox: f32,
    oy: f32,
    oz: f32,
    ix: f32,
    iy: f32,
    iz: f32,
    tmin: f32,
    h: &mut H,
    leaf: impl FnMut(&mut H, u32, u32),
) {
    // SAFETY: this function runs only on CPUs with AVX (its `target_feature`s, all checked
    // by `slab::has_avx`).
    let constants = [[ox, oy, oz], [ix, iy, iz]];
    let test = unsafe { slab::Avx::new(ray, constants, tmin, S::CONSERVATIVE) };
    walk_wide_on(wide, test, h, leaf)
}

/// Whether walks (and their triangle leaves) run compiled for AVX: the CPU has it, and no
/// test asked for the 4-lane halves.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn walks_with_avx() -> bool {
    slab::has_avx() && !tests_want_halves()
}

#[cfg(test)]
thread_local! {
    /// Set by tests that walk with [`slab::Halves`] on a CPU with AVX.
    pub(super) static HALVES_ONLY: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

#[cfg(all(test, target_arch = "x86_64"))]
fn tests_want_halves() -> bool {
    HALVES_ONLY.with(|c| c.get())
}

#[cfg(all(not(test), target_arch = "x86_64"))]
#[inline(always)]
fn tests_want_halves() -> bool {
    false
}

/// [`Walker::walk`] with a node test and a stack of enough entries (`7 * depth + 1`: pending
/// children are siblings of the nodes on the path from the root, at most seven per level).
#[inline(always)]
pub(super) fn walk_wide_on<H: Handler, T: slab::NodeTest>(
    wide: &WideBvh,
    test: T,
    h: &mut H,
    leaf: impl FnMut(&mut H, u32, u32),
) {
    let Some(root) = wide.nodes.first() else {
        return;
    };
    // The root's children first: a ray that misses them all (most of a camera's around a
    // small model) leaves before the walk sets up its stack.
    let children = test.entry(root, h.t_max());
    if children.0 == 0 {
        return;
    }
    let needed = (NODE_WIDTH - 1) * wide.depth as usize + 1;
    if needed <= WIDE_STACK {
        let mut stack = [const { std::mem::MaybeUninit::<Pending>::uninit() }; WIDE_STACK];
        walk_wide_with(wide, test, h, leaf, children, &mut stack);
    } else {
        let mut heap: Vec<Pending> = Vec::with_capacity(needed);
        walk_wide_with(wide, test, h, leaf, children, heap.spare_capacity_mut());
    }
}

/// The walk of [`Walker::walk`] from the root, whose children `children` (mask and entry
/// distances) are already tested (`stack` holds `7 * depth + 1` entries).
#[inline(always)]
fn walk_wide_with<H: Handler, T: slab::NodeTest>(
    wide: &WideBvh,
    test: T,
    h: &mut H,
    mut leaf: impl FnMut(&mut H, u32, u32),
    children: (u32, [f32; NODE_WIDTH]),
    stack: &mut [std::mem::MaybeUninit<Pending>],
) {
    let nodes = wide.nodes.as_slice();
    let mut len = 0usize;
    let mut node = &nodes[0];
    let (mut mask, mut entry) = children;
    // Pops the nearest pending child that may still hold something nearer than the
    // closest hit found since it was pushed; returns from the walk when none is left (a
    // macro, not a closure, for the `return`). The walk holds each next child as a plain
    // value, not an `Option`: bunny incoherent rays 5–7 % faster (docs/cpu-backend.md,
    // "the walk's next child as a value").
    macro_rules! pop_or_return {
        () => {
            loop {
                if len == 0 {
                    return;
                }
                len -= 1;
                // SAFETY: entries below `len` were written by a push.
                let popped = unsafe { stack[len].assume_init() };
                if popped.entry <= h.t_max() {
                    break popped;
                }
            }
        };
    }
    loop {
        // The children of `node` the ray enters (`mask`, at `entry`): the nearest next,
        // the others onto the stack.
        let child = |lane: u32| Pending {
            first: node.first[lane as usize],
            count: node.count[lane as usize],
            entry: entry[lane as usize],
        };
        prefetch_lowest(wide, node, mask);
        let mut next = match mask.count_ones() {
            0 => pop_or_return!(),
            // One or two, as one case without a data-dependent branch: the nearer next, the
            // farther waits (ties keep child order). With one, the lowest and highest lanes
            // are that child, which goes next; its copy written above the stack's top is
            // not counted. Which of the two cases a node falls in is mispredicted often on
            // incoherent rays, and the walk then waited for the branch's recovery before
            // the next node's loads: one case made the bunny's incoherent rays 2–3 %
            // faster and camera rays 1–2.5 % slower on an AMD Zen 3 (docs/cpu-backend.md,
            // "one or two children as one case").
            entered @ (1 | 2) => {
                let a = child(mask.trailing_zeros());
                let b = child(31 - mask.leading_zeros());
                let (near, far) = if b.entry < a.entry { (b, a) } else { (a, b) };
                prefetch_child(wide, far.first, far.count);
                // (Room for the write: a node `k` levels deep is reached with at most
                // `7 * k` entries pending, below the `7 * depth + 1` the stack holds.)
                stack[len].write(far);
                len += (entered == 2) as usize;
                near
            }
            _ => {
                // Three to eight, sorted into the top of the stack as they come, the
                // nearest on top (insertion; ties keep child order, the lower lane
                // nearer the top, so the walk is deterministic); the top goes next.
                let base = len;
                let mut bits = mask;
                while bits != 0 {
                    let c = child(bits.trailing_zeros());
                    bits &= bits - 1;
                    prefetch_child(wide, c.first, c.count);
                    let mut i = len;
                    // SAFETY: entries from `base` to `len` were written above.
                    while i > base && unsafe { stack[i - 1].assume_init() }.entry <= c.entry {
                        stack[i] = stack[i - 1];
                        i -= 1;
                    }
                    stack[i].write(c);
                    len += 1;
                }
                len -= 1;
                // SAFETY: written by the loop above (three or more entries).
                unsafe { stack[len].assume_init() }
            }
        };
        // Leaves on the way are run; the next inner node is tested.
        while next.count != 0 {
            leaf(h, next.first, next.count);
            if h.done() {
                return;
            }
            next = pop_or_return!();
        }
        // `next` is an inner node.
        node = &nodes[next.first as usize];
        // The children's indices sit in the node's fourth cache line, which the box test
        // does not read: asked for now, it arrives while the test runs instead of after.
        prefetch_at(&node.first, 0);
        (mask, entry) = test.entry(node, h.t_max());
    }
}

/// Asks for the lines of a child the walk pushes (it may pop it later, after other work):
/// an inner node's six box rows (bytes 0–191 of a 64-byte-aligned node, three lines), or a
/// triangle leaf's first block's vertices (bytes 0–143 of a 16-byte-aligned block, three
/// lines at most). A hint: no effect on results. Popped children waited on these loads
/// (the hottest instructions of the walk and of the leaf on incoherent rays); asked for at
/// the push, bunny incoherent rays run 5–10 % faster, the Breakfast Room's 3–4 %
/// (docs/cpu-backend.md).
#[inline(always)]
fn prefetch_child(wide: &WideBvh, first: u32, count: u32) {
    if count == 0 {
        if let Some(node) = wide.nodes.get(first as usize) {
            prefetch_span(node, 191);
        }
    } else if let Some(block) = wide.blocks.get(first as usize) {
        // (A walk whose leaves are not blocks has no blocks: nothing asked for.)
        prefetch_span(block, 143);
    }
}

/// Asks for the first two lines of the lowest child of `node` that `mask` enters (an inner
/// node's first box rows, a leaf's first block's first vertices), or for `node`'s first line
/// when it enters none (a line in cache already), before the walk branches on how many it
/// enters. That branch is often mispredicted on incoherent rays; the next child's loads
/// then wait for the core to recover, and with the lowest child asked for before it (the
/// next child whenever one is entered, and in half the cases of two) its lines are on their
/// way meanwhile. The address is chosen without a branch. A hint: no effect on results.
/// On one thread of an AMD Zen 4: the bunny's incoherent rays 3–6 % faster (those that hit
/// 4–5 %), the Breakfast Room's 1–6 %, camera rays up to 4 % slower (docs/cpu-backend.md,
/// "the lowest child asked for early").
#[inline(always)]
fn prefetch_lowest(wide: &WideBvh, node: &WideNode, mask: u32) {
    let lane = (mask.trailing_zeros() & (NODE_WIDTH as u32 - 1)) as usize;
    let (first, count) = (node.first[lane] as usize, node.count[lane]);
    let inner = wide
        .nodes
        .as_ptr()
        .cast::<u8>()
        .wrapping_add(first * std::mem::size_of::<WideNode>());
    let leaf = wide
        .blocks
        .as_ptr()
        .cast::<u8>()
        .wrapping_add(first * std::mem::size_of::<TriangleBlock>());
    let own = std::ptr::from_ref(node).cast::<u8>();
    // A walk whose leaves are not triangle blocks (spheres, curves, custom primitives) has no
    // blocks: its leaves ask for the node's own line rather than an address past an empty
    // array.
    let leaf = if wide.blocks.is_empty() { own } else { leaf };
    let at = if count == 0 { inner } else { leaf };
    let at = if mask == 0 { own } else { at };
    prefetch_byte(at);
    prefetch_byte(at.wrapping_add(64));
}

/// Asks for the cache line holding `at` (a hint: no effect on results, and never a fault,
/// whatever the address).
#[inline(always)]
fn prefetch_byte(at: *const u8) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch reads nothing into the program and faults on no address.
    unsafe {
        use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
        _mm_prefetch::<_MM_HINT_T0>(at.cast::<i8>());
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = at;
}

/// Asks for the lines holding bytes `0..=last` of `value` (a hint), with three prefetches
/// (bytes 0, 64 and `last`): enough when the span touches at most three lines, as it does
/// for `last` up to 143 at any 16-byte alignment and up to 191 at a 64-byte one.
#[inline(always)]
fn prefetch_span<T>(value: &T, last: usize) {
    debug_assert!((value as *const T as usize % 64) + last < 192);
    prefetch_at(value, 0);
    prefetch_at(value, 64);
    prefetch_at(value, last);
}

/// Asks for the cache line holding byte `offset` of `value` (a hint: no effect on results).
#[inline(always)]
fn prefetch_at<T>(value: &T, offset: usize) {
    debug_assert!(offset < std::mem::size_of::<T>());
    // (`wrapping_add`: no in-bounds requirement; callers keep it within `value`, as the debug
    // assertion checks, but nothing unsafe depends on it.)
    prefetch_byte(std::ptr::from_ref(value).cast::<u8>().wrapping_add(offset));
}
