//! The device API: one [`Invocation`] per launch index answers the calls of the programs it
//! runs (payload registers, attributes, the ray and hit getters, traces and callables), decides
//! the fate of the candidates its traces find (`candidates`: any-hit and intersection
//! programs) and raises exceptions (`exceptions`).
//!
//! Semantics kept here (DESIGN.md §4, written down in docs/cpu-backend.md):
//! - Payload registers are copied in at `rt_trace` and out when it returns; callables get
//!   their argument array the same way. Registers past the caller's array read 0. Compiled
//!   programs' traces (`trace_entry`) use the caller's array in place instead, which no one
//!   can tell apart (`Invocation::trace_ray`).
//! - An invalid ray misses without running any program and leaves the payload alone; with
//!   `ExceptionFlags::DEBUG` the exception program runs (`INVALID_RAY`).
//! - `rt_trace` beyond `max_trace_depth` does nothing, or raises `TRACE_DEPTH_EXCEEDED` when
//!   the pipeline checks `TRACE_DEPTH`. Callables nested beyond the link options' depths do
//!   nothing, or raise `STACK_OVERFLOW`.
//! - An exception runs the exception program (when the SBT has one) and ends the launch
//!   index: every program on the stack returns (see `DeviceCalls::unwinding`) and further
//!   device calls do nothing.
//! - A hit whose SBT record index lies past the hit group records is a hit without programs
//!   (as the Vulkan backend's null records), or raises `INVALID_HIT_SBT` under debug
//!   exceptions; a miss index past the miss records runs nothing (or raises
//!   `INVALID_MISS_SBT`).
//!
//! Cost: nothing here allocates. What a running program sees (its [`View`] and the
//! [`DeviceState`] compiled programs read instead of calling getters) and what a trace keeps
//! ([`TraceState`], the payload registers) live in the stack frames of the calls that run
//! programs and trace; the invocation points at the innermost ones, and views point at the
//! hit and the instance path they show, so nesting copies little more than the payload
//! words in use.

mod candidates;
mod exceptions;
mod lean;

use crate::accel::Gas;
use crate::launch::LaunchShared;
use crate::launch::next_index;
use crate::pipeline::{Callable, RepeatedCallable};
use crate::program::abi::{self, DeviceCalls, DeviceState};
use crate::sbt::Record;
use crate::traversal::{self, Candidate, HitData, Path, Spec, TraceRay};
use optik_api::semantics::exception as code;
use optik_api::semantics::opacity::CandidateFate;
use optik_api::semantics::{self, facing, sbt_index};
use optik_api::{ExceptionFlags, IDENTITY_3X4, ProgramKind, RayFlags, TraversableHandle};
use std::sync::atomic::AtomicU32;

/// Traces that find nothing before the root check is armed again, once it let a ray into
/// the root's box (`Invocation::trace_ray`).
const ROOT_CHECK_PAUSE: u32 = 32;

/// Most payload (and callable argument) registers.
const MAX_PAYLOAD: usize = abi::MAX_PAYLOAD as usize;

/// The closest-hit program a compiled caller of `rt_trace` inlined after the call, and the
/// state its code reads ([`abi::TraceEntry`]); null for callers without one.
#[derive(Clone, Copy)]
struct Inlined {
    closest_hit: *const u8,
    state: *mut DeviceState,
}

impl Inlined {
    const NONE: Inlined = Inlined {
        closest_hit: std::ptr::null(),
        state: std::ptr::null_mut(),
    };

    /// Whether `program` is the caller's inlined closest hit.
    #[inline(always)]
    fn is(&self, program: Callable<'_>) -> bool {
        !self.closest_hit.is_null() && program.entry_address() == self.closest_hit
    }
}

/// The closest-hit program that runs for a hit of `world` whose record is `record`: none
/// under `RayFlags::DISABLE_CLOSESTHIT`, for a record without one, or for one that does
/// nothing.
#[inline(always)]
fn closest_hit_program<'l>(world: &TraceRay, record: &'l Record<'l>) -> Option<Callable<'l>> {
    if world.flags.contains(RayFlags::DISABLE_CLOSESTHIT) {
        return None;
    }
    record.programs.main.filter(|ch| !ch.does_nothing())
}

/// The ray of programs that trace no ray (raygen, callables of raygen): every getter reads 0.
static NO_RAY: TraceRay = TraceRay {
    origin: [0.0; 3],
    direction: [0.0; 3],
    tmin: 0.0,
    tmax: 0.0,
    time: 0.0,
    mask: 0,
    flags: RayFlags(0),
};

/// The primitive a program sees (the instances above it are its [`Path`]).
#[derive(Clone, Copy, Debug)]
struct HitState {
    t: f32,
    primitive_index: u32,
    sbt_gas_index: u32,
    hit_kind: u32,
    attributes: [u32; 8],
    data: Option<HitData>,
}

impl HitState {
    fn at(info: &crate::accel::PrimitiveInfo) -> HitState {
        HitState {
            t: 0.0,
            primitive_index: info.primitive_index,
            sbt_gas_index: info.sbt_gas_index,
            hit_kind: 0,
            attributes: [0; 8],
            data: None,
        }
    }

    /// A built-in primitive's hit.
    #[inline(always)]
    fn of(c: &Candidate<'_>) -> HitState {
        HitState {
            t: c.t,
            primitive_index: c.info.primitive_index,
            sbt_gas_index: c.info.sbt_gas_index,
            hit_kind: c.hit_kind,
            attributes: HitState::attributes_of(Some(c.data)),
            data: Some(c.data),
        }
    }

    /// The attribute registers of a built-in primitive's hit with `data`: its parameters (a
    /// triangle's barycentrics, a curve's `u`), the rest 0.
    #[inline(always)]
    fn attributes_of(data: Option<HitData>) -> [u32; 8] {
        let mut attributes = [0; 8];
        match data {
            Some(HitData::Triangle { barycentrics, .. }) => {
                attributes[0] = barycentrics[0].to_bits();
                attributes[1] = barycentrics[1].to_bits();
            }
            Some(HitData::Curve { u }) => attributes[0] = u.to_bits(),
            Some(HitData::Sphere { .. }) | None => {}
        }
        attributes
    }
}

/// What the running program sees.
#[derive(Clone, Copy)]
struct View<'l> {
    kind: ProgramKind,
    record: Option<&'l Record<'l>>,
    /// The traced ray (in the frame of the trace that runs the program, or [`NO_RAY`]):
    /// pointed to, not copied, since most views never read it.
    ray: *const TraceRay,
    /// The end of the ray's interval the program sees: the committed (or candidate)
    /// distance in hit programs (the traced ray's own `tmax` is not it).
    tmax: f32,
    /// The primitive, or null: a hit kept by a caller of the program's `run` (the committed
    /// hit of the trace, the candidate of an any-hit, the primitive of an intersection), so
    /// views stay small to copy.
    hit: *const HitState,
    /// The instances above `hit`, kept the same way; null when there are none (pipelines
    /// without instancing): identity transforms, instance id and index 0, the object-space
    /// ray is the ray.
    path: *const Path,
    exception_code: i32,
}

impl<'v> View<'v> {
    /// The view of a closest-hit program for the hit `hit` below `path` (null: no
    /// instances) of `world`, whose record is `record`.
    #[inline(always)]
    fn closest_hit(
        world: &TraceRay,
        record: &'v Record<'v>,
        hit: &HitState,
        path: *const Path,
    ) -> View<'v> {
        View {
            kind: ProgramKind::ClosestHit,
            record: Some(record),
            ray: world,
            tmax: hit.t,
            hit,
            path,
            exception_code: 0,
        }
    }
}

impl View<'_> {
    const EMPTY: View<'static> = View {
        kind: ProgramKind::Raygen,
        record: None,
        ray: &NO_RAY,
        tmax: 0.0,
        hit: std::ptr::null(),
        path: std::ptr::null(),
        exception_code: 0,
    };
}

/// What programs query, from the view alone (the `DeviceCalls` getters and the state
/// `fill_state` writes both read these).
impl View<'_> {
    #[inline(always)]
    fn ray(&self) -> &TraceRay {
        // SAFETY: a view's ray is `NO_RAY` or the ray of the trace that runs the program,
        // in the frame of `trace_ray`, which outlives the program.
        unsafe { &*self.ray }
    }

    #[inline(always)]
    fn hit(&self) -> Option<&HitState> {
        // SAFETY: a view's hit is kept alive by the caller of the program's `run` for as
        // long as the program runs (see `View::hit`).
        unsafe { self.hit.as_ref() }
    }

    /// The instances above the hit, if any.
    #[inline(always)]
    fn path(&self) -> Option<&Path> {
        // SAFETY: as for the hit (see `View::path`).
        unsafe { self.path.as_ref() }
    }

    #[inline(always)]
    fn object_ray(&self) -> ([f32; 3], [f32; 3]) {
        match self.path() {
            Some(p) => (p.object_origin, p.object_direction),
            None => (self.ray().origin, self.ray().direction),
        }
    }

    #[inline(always)]
    fn primitive_index(&self) -> u32 {
        self.hit().map_or(0, |h| h.primitive_index)
    }

    #[inline(always)]
    fn sbt_gas_index(&self) -> u32 {
        self.hit().map_or(0, |h| h.sbt_gas_index)
    }

    #[inline(always)]
    fn instance_id(&self) -> u32 {
        self.path().map_or(0, |p| p.instance_id)
    }

    #[inline(always)]
    fn instance_index(&self) -> u32 {
        self.path().map_or(0, |p| p.instance_index)
    }

    #[inline(always)]
    fn hit_kind(&self) -> u32 {
        self.hit().map_or(0, |h| h.hit_kind)
    }

    #[inline(always)]
    fn triangle_barycentrics(&self) -> [f32; 2] {
        match self.hit().and_then(|h| h.data) {
            Some(HitData::Triangle { barycentrics, .. }) => barycentrics,
            _ => [0.0; 2],
        }
    }

    #[inline(always)]
    fn object_to_world(&self) -> [f32; 12] {
        self.path().map_or(IDENTITY_3X4, |p| p.object_to_world())
    }

    #[inline(always)]
    fn world_to_object(&self) -> [f32; 12] {
        self.path().map_or(IDENTITY_3X4, |p| p.world_to_object())
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum AnyHitOutcome {
    Accept,
    Ignore,
    Terminate,
}

/// An intersection program's candidate.
#[derive(Clone, Copy)]
struct IntersectionContext<'l> {
    base: HitState,
    /// As `View::path`; points into the traversal's stack for the program's run.
    path: *const Path,
    record: &'l Record<'l>,
    fate: CandidateFate,
}

/// The state of one `rt_trace`, in the stack frame of [`Invocation::trace_ray`].
///
/// `repr(C)`, with the fields every trace writes first and the ones written only with a
/// hit last: in Rust's order the uninitialised hit sat between written fields, and LLVM
/// zeroed the whole ~170 bytes to write them as one block.
#[repr(C)]
struct TraceState<'l> {
    /// The traced ray, in the same frame (its copies cost more than the pointer: most
    /// traces read only `tmax`, below).
    ray: *const TraceRay,
    /// The committed hit's record; `None` while there is no hit.
    committed_record: Option<&'l Record<'l>>,
    /// The running intersection program's candidate (in the frame of `Handler::custom`),
    /// or null.
    intersection: *const IntersectionContext<'l>,
    /// The end of the interval now: the ray's `tmax`, then the committed distance.
    tmax: f32,
    sbt_offset: u32,
    sbt_stride: u32,
    committed_has_path: bool,
    terminated: bool,
    any_hit: AnyHitOutcome,
    /// The running intersection program must return.
    intersection_exit: bool,
    /// The committed hit: written with `committed_record`, only read when that is `Some`.
    committed_hit: std::mem::MaybeUninit<HitState>,
    /// The instances above the committed hit, when the pipeline has instancing (else the
    /// committed hit has none). Only read when `committed_has_path`.
    committed_path: std::mem::MaybeUninit<Path>,
}

/// One launch index: the device API for its programs, and the candidate handler of its
/// traces.
pub(crate) struct Invocation<'l> {
    shared: &'l LaunchShared<'l>,
    /// The launch index, but while a compiled launch loop runs indices
    /// (`RepeatedCall::run_indices`), which steps it in the ray generation program's state:
    /// then `index_at` points there ([`Invocation::current_index`]).
    index: [u32; 3],
    index_at: *const [u32; 3],
    /// While a compiled launch loop runs: the word it reads after each index, set with
    /// `ending` (null otherwise).
    index_ended: *mut u32,
    /// Traces in progress.
    depth: u32,
    direct_depth: u32,
    continuation_depth: u32,
    /// An exception ended this launch index.
    ending: bool,
    /// What the innermost running program sees (null before the raygen starts); in the
    /// stack frame of its `run`.
    view: *mut View<'l>,
    /// Its values as memory (only the fields of `present` are written); next to `view`.
    state: *mut DeviceState,
    /// The innermost trace (null outside traces).
    trace: *mut TraceState<'l>,
    /// The payload registers of the innermost trace or callable call (null outside them).
    payload: *mut u32,
    payload_len: usize,
    /// The next trace is first checked against the root's boxes (`Invocation::trace_ray`):
    /// armed by a trace that found nothing, disarmed by one that found something.
    root_check_armed: bool,
    /// Traces that find nothing before the check is armed again, after it let a ray in.
    root_check_rearm_in: u32,
    /// The root last traced from, and its structure when traces from it walk triangle
    /// blocks straight away (`traversal::blocks_root`): looked up at the first trace from it
    /// (the scene does not change during a launch).
    root: Option<([u32; 2], Option<&'l Gas>)>,
}

/// Traces for a pipeline compiled as `S`: from a root of triangle blocks (every trace
/// without instancing), straight into its walk (`traversal::trace_blocks`: the root's look-up
/// and checks were made at the first trace from it).
pub(crate) fn trace_with<S: Spec>(
    inv: &mut Invocation<'_>,
    ray: &TraceRay,
    root: TraversableHandle,
) {
    let shared = inv.shared;
    match inv.blocks_root::<S>(root.to_words()) {
        Some(g) => traversal::trace_blocks::<S, _>(shared.scene, g, ray, &shared.config, inv),
        None => traversal::trace::<S, _>(shared.scene, root, ray, &shared.config, inv),
    }
}

/// `rt_trace` of compiled programs for a pipeline compiled as `S` (an
/// [`abi::TraceEntry`](crate::program::abi::TraceEntry)): the whole trace in one
/// monomorphic function, the walk called directly. With `LEAN` (pipelines without any-hit
/// programs, instancing or debug exceptions, `pipeline::trace_fn`), a trace from a root of
/// triangle blocks takes `Invocation::trace_lean` and any other the whole trace out of line;
/// without it the whole `Invocation::trace_ray` is inlined here.
///
/// # Safety
/// `calls` is the invocation that called the running program with this entry
/// (`Invocation::run_program`), and `payload` holds `payload_len` registers of the caller.
#[allow(clippy::too_many_arguments)]
pub(crate) unsafe extern "C-unwind" fn trace_entry<S: Spec, const LEAN: bool>(
    calls: *mut (),
    handle_lo: u32,
    handle_hi: u32,
    ox: f32,
    oy: f32,
    oz: f32,
    dx: f32,
    dy: f32,
    dz: f32,
    tmin: f32,
    tmax: f32,
    time: f32,
    mask: u32,
    flags: u32,
    sbt_offset: u32,
    sbt_stride: u32,
    miss_index: u32,
    payload: *mut u32,
    payload_len: u32,
    inlined_closest_hit: *const u8,
    inlined_state: *mut DeviceState,
) -> u32 {
    // SAFETY: `run_program` hands this entry to programs it calls with the invocation as
    // their `DeviceCalls`, whose data pointer `calls` is; the invocation outlives the call.
    let inv = unsafe { &mut *calls.cast::<Invocation<'_>>() };
    let inlined = Inlined {
        closest_hit: inlined_closest_hit,
        state: inlined_state,
    };
    let handle = [handle_lo, handle_hi];
    // The words are written out in each arm: one array for all of them is stored to the
    // stack before the branch, five stores every lean trace pays for the other arms.
    let lean_root = if LEAN {
        inv.blocks_root::<S>(handle)
    } else {
        None
    };
    let run_inlined = if let Some(g) = lean_root {
        // SAFETY: the caller's registers, as the contract says.
        unsafe {
            inv.trace_lean::<S>(
                g,
                handle,
                [ox, oy, oz],
                [dx, dy, dz],
                [tmin, tmax, time],
                [mask, flags, sbt_offset, sbt_stride, miss_index],
                payload,
                payload_len as usize,
                inlined,
            )
        }
    } else if LEAN {
        // SAFETY: as above.
        unsafe {
            trace_full_out_of_line::<S>(
                inv,
                handle,
                [ox, oy, oz],
                [dx, dy, dz],
                [tmin, tmax, time],
                [mask, flags, sbt_offset, sbt_stride, miss_index],
                payload,
                payload_len,
                inlined,
            )
        }
    } else {
        // SAFETY: as above.
        unsafe {
            trace_full::<S>(
                inv,
                handle,
                [ox, oy, oz],
                [dx, dy, dz],
                [tmin, tmax, time],
                [mask, flags, sbt_offset, sbt_stride, miss_index],
                payload,
                payload_len,
                inlined,
            )
        }
    };
    // `DeviceCalls::unwinding` is `ending` here: its other case is an intersection program
    // that ended its trace, and compiled intersection programs cannot trace (the front end
    // allows `rt_trace` in ray generation, closest-hit, miss and continuation callable
    // programs only), so the program that called this entry is none.
    debug_assert!(inv.view().kind != ProgramKind::Intersection);
    if inv.ending {
        abi::TRACE_RETURN
    } else if run_inlined {
        abi::TRACE_RUN_INLINED
    } else {
        abi::TRACE_GO_ON
    }
}

/// The whole `Invocation::trace_ray` of a compiled program's trace (payload in place).
///
/// # Safety
/// As [`trace_entry`]'s.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
unsafe fn trace_full<S: Spec>(
    inv: &mut Invocation<'_>,
    handle: [u32; 2],
    origin: [f32; 3],
    direction: [f32; 3],
    [tmin, tmax, time]: [f32; 3],
    words: [u32; 5],
    payload: *mut u32,
    payload_len: u32,
    inlined: Inlined,
) -> bool {
    // SAFETY: the caller's registers, as the contract says.
    unsafe {
        inv.trace_ray(
            handle,
            origin,
            direction,
            [tmin, tmax, time],
            words,
            payload,
            payload_len as usize,
            true,
            inlined,
            trace_with::<S>,
            misses_root_with::<S>,
        )
    }
}

/// [`trace_full`] out of the lean trace's way (roots that are not triangle blocks).
///
/// # Safety
/// As [`trace_entry`]'s.
#[allow(clippy::too_many_arguments)]
#[inline(never)]
unsafe fn trace_full_out_of_line<S: Spec>(
    inv: &mut Invocation<'_>,
    handle: [u32; 2],
    origin: [f32; 3],
    direction: [f32; 3],
    times: [f32; 3],
    words: [u32; 5],
    payload: *mut u32,
    payload_len: u32,
    inlined: Inlined,
) -> bool {
    // SAFETY: as the caller's contract says.
    unsafe {
        trace_full::<S>(
            inv,
            handle,
            origin,
            direction,
            times,
            words,
            payload,
            payload_len,
            inlined,
        )
    }
}

/// Whether a trace from the root `handle` certainly finds nothing, for a pipeline compiled
/// as `S`: the ray misses the box around the root's children (`WideBvh::root_bounds` of a
/// root of triangle blocks, `Invocation::blocks_root`, and `traversal::misses_bounds`). Not
/// inlined: most traces do not ask, and inlined it slowed those that do not (the Breakfast
/// Room's rays by 2 %).
#[inline(never)]
fn misses_root_with<S: Spec>(inv: &mut Invocation<'_>, handle: [u32; 2], ray: &TraceRay) -> bool {
    let bounds = inv
        .blocks_root::<S>(handle)
        .and_then(|g| g.encoding.root_bounds);
    bounds.is_some_and(|b| {
        // Word by word (`traversal::words`): the ray was stored one scalar at a time.
        let (origin, direction) = (
            traversal::words(&ray.origin),
            traversal::words(&ray.direction),
        );
        traversal::misses_bounds::<S>(&b, origin, direction, ray.tmin, ray.tmax)
    })
}

impl<'l> Invocation<'l> {
    /// Runs `count` launch indices from `index` (a launch task's, stepped by `next`): the
    /// ray generation program `raygen` for each, and everything that calls, until the
    /// launch's stop flag is raised.
    ///
    /// The program's view, state and call context are built once for the task (they are
    /// the same for every index but the index, written per run): every run leaves the
    /// invocation as it found it (depths, the innermost view, trace and payload are
    /// restored on the way out) but for `ending`, reset per index.
    pub(crate) fn run_raygens(
        &mut self,
        raygen: Callable<'l>,
        mut index: [u32; 3],
        count: usize,
        [width, height]: [u32; 2],
    ) {
        let shared = self.shared;
        if raygen.does_nothing() {
            return;
        }
        let mut view = View {
            kind: ProgramKind::Raygen,
            record: Some(&shared.sbt.raygen),
            ..View::EMPTY
        };
        // Compiled code reads the state through a raw pointer: only written fields are read.
        let mut state = std::mem::MaybeUninit::<DeviceState>::uninit();
        self.view = &mut view;
        self.state = state.as_mut_ptr();
        let bits = raygen.state_bits();
        let stop = shared.stop;
        // The state's mutable pointer: the launch loop (`run_rows`) writes its index.
        let state_ptr = self.state.cast_const();
        let mut call = raygen.repeated(shared.bindings, self, state_ptr, stop, shared.trace.entry);
        // Everything in the state but the launch index is the same for the whole task.
        self.index = index;
        self.fill_state(self.state, bits, &view);
        if call.has_launch_loop() {
            self.run_rows(&mut call, index, count, [width, height]);
        } else {
            for _ in 0..count {
                if stop.load(std::sync::atomic::Ordering::Relaxed) != 0 {
                    break;
                }
                // Word by word (`traversal::words`): `next_index` stored the index one word
                // at a time (an 8-byte read across two of those stores stalls every launch
                // index). Both copies are written from that one read, not the state's read
                // back from the invocation's (one store-to-load forwarding less on the way
                // from the index to the program's first loads).
                let current = traversal::words(&index);
                self.index = current;
                self.ending = false;
                if bits & DeviceState::LAUNCH_INDEX != 0 {
                    // SAFETY: `state` is the program's state (set above).
                    unsafe { (*self.state).launch_index = current };
                }
                call.call(self);
                index = next_index(index, width, height);
            }
        }
        self.view = std::ptr::null_mut();
        self.state = std::ptr::null_mut();
    }

    /// [`Invocation::run_raygens`]'s indices run by the program's compiled launch loop, a
    /// row (or what is left of it) per call: the loop steps the index along x in the
    /// program's state, where every reader of the launch index finds it meanwhile
    /// (`index_at`), and stops after an index that an exception ended, which is cleared
    /// here before the loop goes on.
    fn run_rows(
        &mut self,
        call: &mut RepeatedCallable<'l>,
        mut index: [u32; 3],
        mut count: usize,
        [width, height]: [u32; 2],
    ) {
        let stop = self.shared.stop;
        // The word the loop reads after each index; only used through this pointer.
        let mut ended_word = 0u32;
        let ended = std::ptr::addr_of_mut!(ended_word);
        // SAFETY: `state` is the program's state (`run_raygens`), written here before the
        // program reads it; the launch index is written whatever its bits (the loop steps it).
        let at = unsafe { std::ptr::addr_of_mut!((*self.state).launch_index) };
        self.index_at = at;
        self.index_ended = ended;
        while count > 0 && stop.load(std::sync::atomic::Ordering::Relaxed) == 0 {
            let row = count.min((width - index[0]) as usize);
            self.ending = false;
            // SAFETY: `at` and `ended` are live for this call (above); nothing else reads
            // or writes them while the loop runs but the loop and this invocation.
            let ran = unsafe {
                at.write(index);
                ended.write(0);
                call.run_indices(self, row, stop, ended)
            };
            let Some(ran) = ran else {
                debug_assert!(false, "run_raygens comes here only with a launch loop");
                break;
            };
            count -= ran;
            index[0] += ran as u32;
            if index[0] == width {
                index = next_index([width - 1, index[1], index[2]], width, height);
            }
        }
        self.index_at = std::ptr::null();
        self.index_ended = std::ptr::null_mut();
    }

    /// The launch index of the running programs: `index`, or where a compiled launch loop
    /// steps it (`index_at`).
    #[inline]
    fn current_index(&self) -> [u32; 3] {
        if self.index_at.is_null() {
            traversal::words(&self.index)
        } else {
            // SAFETY: `index_at` points into the ray generation program's state while its
            // launch loop runs (`run_rows`), and is null otherwise.
            unsafe { traversal::words(&*self.index_at) }
        }
    }

    /// An invocation for the launch indices of one task ([`Invocation::run_raygens`]).
    pub(crate) fn new(shared: &'l LaunchShared<'l>) -> Invocation<'l> {
        Invocation {
            shared,
            index: [0; 3],
            index_at: std::ptr::null(),
            index_ended: std::ptr::null_mut(),
            depth: 0,
            direct_depth: 0,
            continuation_depth: 0,
            ending: false,
            view: std::ptr::null_mut(),
            state: std::ptr::null_mut(),
            trace: std::ptr::null_mut(),
            payload: std::ptr::null_mut(),
            payload_len: 0,
            root_check_armed: false,
            root_check_rearm_in: 0,
            root: None,
        }
    }

    fn exceptions(&self) -> ExceptionFlags {
        self.shared.features.exceptions
    }

    /// The structure at the root `handle` when traces from it walk triangle blocks straight
    /// away (`traversal::blocks_root`), looked up at the first trace from it and kept while
    /// traces come from the same root.
    #[inline]
    fn blocks_root<S: Spec>(&mut self, handle: [u32; 2]) -> Option<&'l Gas> {
        match self.root {
            Some((cached, gas)) if cached == handle => gas,
            _ => {
                let shared = self.shared;
                let gas = traversal::blocks_root::<S>(
                    shared.scene,
                    TraversableHandle::from_words(handle),
                    &shared.config,
                );
                self.root = Some((handle, gas));
                gas
            }
        }
    }

    /// What the running program sees.
    #[inline]
    fn view(&self) -> &View<'l> {
        if self.view.is_null() {
            &View::EMPTY
        } else {
            // SAFETY: `view` points into the stack frame of the `run` call of the running
            // program, which outlives every device call the program makes.
            unsafe { &*self.view }
        }
    }

    /// The ray the running program sees.
    #[inline]
    fn ray(&self) -> &TraceRay {
        self.view().ray()
    }

    /// The innermost trace's ray.
    #[inline]
    fn traced_ray(&self) -> &TraceRay {
        // SAFETY: as in `ray`: the trace in progress keeps it.
        unsafe { &*self.tr().ray }
    }

    /// The innermost trace. Only called while one runs (from the traversal's handler
    /// calls, or from programs it runs).
    #[inline]
    fn tr(&self) -> &TraceState<'l> {
        debug_assert!(!self.trace.is_null());
        // SAFETY: `trace` points into the stack frame of the `trace` call in progress.
        unsafe { &*self.trace }
    }

    #[inline]
    fn tr_mut(&mut self) -> &mut TraceState<'l> {
        debug_assert!(!self.trace.is_null());
        // SAFETY: as in `tr`; `&mut self` makes this the only reference.
        unsafe { &mut *self.trace }
    }

    /// Runs a program with `view`; the caller's view comes back after.
    #[inline]
    fn run(&mut self, program: Callable<'l>, view: View<'l>) {
        // An empty program (a miss program that leaves the payload alone) has no effect.
        if !program.does_nothing() {
            self.run_program(program, view);
        }
    }

    fn run_program(&mut self, program: Callable<'l>, view: View<'l>) {
        self.run_program_inline(program, view);
    }

    /// [`Invocation::run_program`] in its caller, which then writes the state's values
    /// from the view it has just built (held in registers) instead of reading it back
    /// through `self.view` (the closest-hit path: 0.5–1.9 % faster traces,
    /// docs/cpu-backend.md §8).
    #[inline(always)]
    fn run_program_inline(&mut self, program: Callable<'l>, mut view: View<'l>) {
        // Compiled code reads the state through a raw pointer: only written fields are read.
        let mut state = std::mem::MaybeUninit::<DeviceState>::uninit();
        let shown = view;
        let saved = (
            std::mem::replace(&mut self.view, &mut view),
            std::mem::replace(&mut self.state, state.as_mut_ptr()),
        );
        self.fill_state(self.state, program.state_bits(), &shown);
        let bindings = self.shared.bindings;
        let state = self.state;
        let trace = self.shared.trace.entry;
        program.call(bindings, self, state, trace);
        (self.view, self.state) = saved;
    }

    /// Writes the values of `bits` for a program that runs with `view` into its
    /// `DeviceState` `s` (the running program's, or an inlined closest hit's): the same
    /// answers the `DeviceCalls` methods give, read as memory by compiled code.
    #[inline(always)]
    fn fill_state(&mut self, s: *mut DeviceState, bits: u32, view: &View<'l>) {
        type S = DeviceState;
        // SAFETY (every write below): `s` is the program's state; nothing else refers to
        // it, and the fields are plain data written through the pointer (never read before
        // they are written).
        unsafe { (*s).present = bits & !S::PAYLOAD };
        if bits & S::LAUNCH_INDEX != 0 {
            // The launch loop has just written the index as three 4-byte words; copying it
            // as one 12-byte value reads 8 bytes across two of those stores, which the CPU
            // cannot forward (a stall on every launch index).
            unsafe { (*s).launch_index = self.current_index() };
        }
        if bits & S::LAUNCH_DIMENSIONS != 0 {
            unsafe { (*s).launch_dimensions = self.launch_dimensions() };
        }
        // Ray generation programs read none of the rest: one test instead of seven.
        const TRACE_VALUES: u32 = S::WORLD_RAY
            | S::OBJECT_RAY
            | S::RAY
            | S::PRIMITIVE
            | S::HIT
            | S::TRANSFORMS
            | S::TRACE_DEPTH;
        if bits & TRACE_VALUES != 0 {
            self.fill_trace_values(s, bits, view);
        }
        // Writes in place are right only while they are not dropped (before an exception
        // ends the index; no program starts after that).
        if bits & S::PAYLOAD != 0 && !self.payload.is_null() && !self.ending {
            unsafe {
                (*s).present |= S::PAYLOAD;
                (*s).payload = self.payload;
                (*s).payload_len = self.payload_len as u32;
            }
        }
    }

    /// `fill_state`'s values of the trace that runs the program.
    #[inline(always)]
    fn fill_trace_values(&mut self, s: *mut DeviceState, bits: u32, view: &View<'l>) {
        type S = DeviceState;
        // SAFETY (every write below): as in `fill_state`.
        // A copy of the caller's view (not `self.view`, which points to its stack copy):
        // the writes below go through a raw pointer the compiler cannot tell from the view,
        // so reading through a pointer between them repeats its loads (and null checks)
        // after every write (~50 instructions a closest hit).
        let view = *view;
        if bits & S::WORLD_RAY != 0 {
            // The ray's words were stored one by one by the trace (as the launch index).
            unsafe {
                (*s).world_ray_origin = traversal::words(&view.ray().origin);
                (*s).world_ray_direction = traversal::words(&view.ray().direction);
            }
        }
        if bits & S::OBJECT_RAY != 0 {
            let (origin, direction) = match view.path() {
                Some(p) => (p.object_origin, p.object_direction),
                None => (
                    traversal::words(&view.ray().origin),
                    traversal::words(&view.ray().direction),
                ),
            };
            unsafe {
                (*s).object_ray_origin = origin;
                (*s).object_ray_direction = direction;
            }
        }
        if bits & S::RAY != 0 {
            Self::write_ray_values(s, &view);
        }
        if bits & S::PRIMITIVE != 0 {
            Self::write_primitive_values(s, &view);
        }
        if bits & S::HIT != 0 {
            Self::write_hit_values(s, &view);
        }
        if bits & S::TRANSFORMS != 0 {
            let (o2w, w2o) = (view.object_to_world(), view.world_to_object());
            unsafe {
                (*s).object_to_world = o2w;
                (*s).world_to_object = w2o;
            }
        }
        if bits & S::TRACE_DEPTH != 0 {
            unsafe { (*s).remaining_trace_depth = self.remaining_trace_depth() };
        }
    }

    /// `fill_state` for the state of a closest hit the caller inlined (`inlined.state`),
    /// whose code never reads `present` (`TRACE_RUN_INLINED`): the ray's, the primitive's
    /// and the hit's values, what closest hits read most, are written whether its `bits`
    /// ask for them or not (a dozen stores instead of a test each); the rest as
    /// `fill_state` writes them. Not the payload, which the inlined code addresses in place.
    #[inline(always)]
    fn fill_inlined_state(&mut self, s: *mut DeviceState, bits: u32, view: &View<'l>) {
        type S = DeviceState;
        // A copy, for the reason `fill_trace_values` gives.
        let view = *view;
        Self::write_ray_values(s, &view);
        Self::write_primitive_values(s, &view);
        Self::write_hit_values(s, &view);
        let rest = bits & !(S::RAY | S::PRIMITIVE | S::HIT | S::PAYLOAD);
        if rest != 0 {
            self.fill_state(s, rest, &view);
        }
    }

    /// The state's `RAY` values (`fill_trace_values`).
    #[inline(always)]
    fn write_ray_values(s: *mut DeviceState, view: &View<'l>) {
        let ray = view.ray();
        let (tmin, time, flags, mask) = (ray.tmin, ray.time, ray.flags.0, ray.mask);
        // SAFETY: as in `fill_state`.
        unsafe {
            (*s).ray_tmin = tmin;
            (*s).ray_tmax = view.tmax;
            (*s).ray_time = time;
            (*s).ray_flags = flags;
            (*s).ray_mask = mask;
        }
    }

    /// The state's `PRIMITIVE` values (`fill_trace_values`).
    #[inline(always)]
    fn write_primitive_values(s: *mut DeviceState, view: &View<'l>) {
        let values = (
            view.primitive_index(),
            view.sbt_gas_index(),
            view.instance_id(),
            view.instance_index(),
        );
        // SAFETY: as in `fill_state`.
        unsafe {
            (*s).primitive_index = values.0;
            (*s).sbt_gas_index = values.1;
            (*s).instance_id = values.2;
            (*s).instance_index = values.3;
        }
    }

    /// The state's `HIT` values (`fill_trace_values`).
    #[inline(always)]
    fn write_hit_values(s: *mut DeviceState, view: &View<'l>) {
        let (kind, barycentrics) = (view.hit_kind(), view.triangle_barycentrics());
        // SAFETY: as in `fill_state`.
        unsafe {
            (*s).hit_kind = kind;
            (*s).triangle_barycentrics = barycentrics;
        }
    }

    /// After traversal: the closest-hit or miss program. Inlined into the trace: most rays
    /// of a camera miss, and their usual miss program (one that keeps the payload) does
    /// nothing, which costs a record lookup here instead of a call.
    #[inline(always)]
    fn finish_trace(&mut self, world: &TraceRay, miss_index: u32, inlined: Inlined) -> bool {
        if self.tr().committed_record.is_some() {
            self.root_check_armed = false;
            return self.closest_hit(world, inlined);
        }
        self.found_nothing();
        match self.miss_record(miss_index) {
            Some(record) => {
                if record.main_runs {
                    self.miss(record, world);
                }
            }
            None => {
                if self.exceptions().contains(ExceptionFlags::DEBUG) {
                    self.raise(code::INVALID_MISS_SBT);
                }
            }
        }
        false
    }

    /// A trace found nothing: the root check is armed for the next, unless it is resting
    /// after letting a ray in (`Invocation::root_check_ends`).
    #[inline(always)]
    fn found_nothing(&mut self) {
        if self.root_check_rearm_in > 0 {
            self.root_check_rearm_in -= 1;
        } else {
            self.root_check_armed = true;
        }
    }

    /// Whether a miss with `miss_index` runs no program and raises nothing: its record
    /// exists and its program (if any) does nothing.
    #[inline(always)]
    fn miss_runs_nothing(&self, miss_index: u32) -> bool {
        self.miss_record(miss_index)
            .is_some_and(|record| !record.main_runs)
    }

    /// The miss record `miss_index` selects, if the table has it.
    #[inline(always)]
    fn miss_record(&self, miss_index: u32) -> Option<&'l Record<'l>> {
        let shared = self.shared;
        shared
            .sbt
            .miss
            .get(sbt_index::miss_record_index(miss_index) as usize)
    }

    /// Runs the closest-hit program of the trace's committed hit (there is one), or, when
    /// it is the program the caller inlined (`inlined`), writes that code's state and
    /// returns true: the caller runs it.
    #[inline(never)]
    fn closest_hit(&mut self, world: &TraceRay, inlined: Inlined) -> bool {
        let tr = self.tr();
        let Some(record) = tr.committed_record else {
            return false;
        };
        // Held by pointer: the trace state lives in `trace_ray`'s frame, not in `self`.
        let hit = tr.committed_hit.as_ptr();
        let path: *const Path = if tr.committed_has_path {
            tr.committed_path.as_ptr()
        } else {
            std::ptr::null()
        };
        // SAFETY: written with the record (`commit`); the frame outlives this call.
        self.closest_hit_of(world, record, unsafe { &*hit }, path, inlined)
    }

    /// [`Invocation::closest_hit`] of the hit `hit` below `path` (null: no instances),
    /// whose record is `record`: runs its closest-hit program, or writes the state of the
    /// caller's inlined copy of it and returns true. The trace's payload and depth are the
    /// invocation's (the program runs inside the trace).
    #[inline(always)]
    fn closest_hit_of(
        &mut self,
        world: &TraceRay,
        record: &'l Record<'l>,
        hit: &HitState,
        path: *const Path,
        inlined: Inlined,
    ) -> bool {
        let Some(ch) = closest_hit_program(world, record) else {
            return false;
        };
        self.run_closest_hit(world, record, ch, hit, path, inlined)
    }

    /// Runs `ch`, the closest-hit program of `record` for the hit `hit` below `path`
    /// ([`closest_hit_program`]), or, when it is the caller's inlined copy, writes that
    /// code's state and returns true.
    #[inline(always)]
    fn run_closest_hit(
        &mut self,
        world: &TraceRay,
        record: &'l Record<'l>,
        ch: Callable<'l>,
        hit: &HitState,
        path: *const Path,
        inlined: Inlined,
    ) -> bool {
        let view = View::closest_hit(world, record, hit, path);
        if inlined.is(ch) {
            // What `run_program` would write for the program, in the caller's memory.
            self.fill_inlined_state(inlined.state, ch.state_bits(), &view);
            return true;
        }
        self.run_program_inline(ch, view);
        false
    }

    /// Runs the miss program of `record` (one that does something).
    #[inline(never)]
    fn miss(&mut self, record: &'l Record<'l>, world: &TraceRay) {
        let Some(program) = record.programs.main else {
            return;
        };
        self.run_program(
            program,
            View {
                kind: ProgramKind::Miss,
                record: Some(record),
                ray: world,
                tmax: world.tmax,
                hit: std::ptr::null(),
                path: std::ptr::null(),
                exception_code: 0,
            },
        );
    }

    /// `rt_direct_call` and `rt_continuation_call`.
    fn call_callable(&mut self, index: u32, args: &mut [u32], continuation: bool) {
        if self.ending {
            return;
        }
        let shared = self.shared;
        let record = shared.sbt.callables.get(index as usize);
        let program = record.and_then(|r| {
            if continuation {
                r.programs.continuation
            } else {
                r.programs.direct
            }
        });
        let (Some(record), Some(program)) = (record, program) else {
            if self.exceptions().contains(ExceptionFlags::DEBUG) {
                self.raise(code::CALLABLE_INVALID_SBT);
            }
            return;
        };
        let (depth, limit) = if continuation {
            (
                self.continuation_depth,
                shared.link.max_continuation_callable_depth,
            )
        } else {
            (self.direct_depth, shared.link.max_direct_callable_depth)
        };
        if depth >= limit {
            if self.exceptions().contains(ExceptionFlags::STACK_OVERFLOW) {
                self.raise(code::STACK_OVERFLOW);
            }
            return;
        }
        let n = args.len().min(MAX_PAYLOAD);
        let mut registers = [0u32; MAX_PAYLOAD];
        registers[..n].copy_from_slice(&args[..n]);
        let saved = (self.payload, self.payload_len);
        (self.payload, self.payload_len) = (registers.as_mut_ptr(), n);
        let kind = if continuation {
            ProgramKind::ContinuationCallable
        } else {
            ProgramKind::DirectCallable
        };
        if continuation {
            self.continuation_depth += 1;
        } else {
            self.direct_depth += 1;
        }
        let view = View {
            kind,
            record: Some(record),
            ..*self.view()
        };
        self.run(program, view);
        if continuation {
            self.continuation_depth -= 1;
        } else {
            self.direct_depth -= 1;
        }
        (self.payload, self.payload_len) = saved;
        if !self.ending {
            args[..n].copy_from_slice(&registers[..n]);
        }
    }

    #[inline]
    fn hit(&self) -> Option<&HitState> {
        self.view().hit()
    }

    /// The checks every trace starts with, in order: an ending index, the depth, the ray's
    /// validity, each raising what the pipeline checks. True when the trace ends there, with
    /// no effect but the exception raised.
    #[inline(always)]
    fn trace_refused(
        &mut self,
        origin: [f32; 3],
        direction: [f32; 3],
        tmin: f32,
        tmax: f32,
    ) -> bool {
        if self.ending {
            return true;
        }
        let features = self.shared.features;
        if self.depth >= features.max_trace_depth {
            if features.exceptions.contains(ExceptionFlags::TRACE_DEPTH) {
                self.raise(code::TRACE_DEPTH_EXCEEDED);
            }
            return true;
        }
        if !semantics::ray::is_valid(origin, direction, tmin, tmax) {
            if features.exceptions.contains(ExceptionFlags::DEBUG) {
                self.raise(code::INVALID_RAY);
            }
            return true;
        }
        false
    }

    /// The ray a trace walks and its programs see: the caller's values, its time kept only
    /// in pipelines with motion (else 0).
    #[inline(always)]
    fn world_ray(
        &self,
        origin: [f32; 3],
        direction: [f32; 3],
        [tmin, tmax, time]: [f32; 3],
        mask: u32,
        flags: u32,
    ) -> TraceRay {
        TraceRay {
            origin,
            direction,
            tmin,
            tmax,
            time: if self.shared.features.motion {
                time
            } else {
                0.0
            },
            mask,
            flags: RayFlags(flags),
        }
    }

    /// After a trace that found nothing, the next (a camera's neighbour, often as empty) is
    /// first tested against the root's boxes (`misses_root`): when it misses them all and a
    /// miss runs no program, the trace has no effect and ends here (true), before its state
    /// is set up. The state that arms the test is kept on the hit and miss paths only
    /// (`Invocation::found_nothing`), and the test rests after letting a ray in: rays that
    /// enter the root and find nothing (from inside a model, or around a large one) would
    /// pay for it twice at every trace.
    #[inline(always)]
    fn root_check_ends(
        &mut self,
        handle: [u32; 2],
        world: &TraceRay,
        miss_index: u32,
        misses_root: impl FnOnce(&mut Self, [u32; 2], &TraceRay) -> bool,
    ) -> bool {
        if self.root_check_armed && self.miss_runs_nothing(miss_index) {
            if misses_root(self, handle, world) {
                return true;
            }
            self.root_check_armed = false;
            self.root_check_rearm_in = ROOT_CHECK_PAUSE;
        }
        false
    }

    /// `rt_trace` (`DeviceCalls::trace`, and compiled programs' entry), with `walk` the
    /// pipeline's traversal. Inlined into each caller, so the compiled programs' entry
    /// keeps its arguments in registers and calls the walk directly.
    ///
    /// `in_place`: the trace's programs use the caller's registers themselves instead of a
    /// copy made here and copied back when the trace returns without an exception. Only
    /// for callers that read nothing of their payload once the index ends (compiled
    /// programs return at once when `unwinding`), so no one sees the difference.
    ///
    /// `inlined`: the caller's inlined closest hit. Returns true when the committed hit's
    /// program is that one: its state is then written to `inlined.state` (everything it
    /// reads, as `run_program` would write it; the payload in place) instead of the program
    /// running here, and the caller runs it. It asks nothing of the runtime (see
    /// `lower::inlinable_closest_hit`), so no one sees that it ran after the trace.
    ///
    /// # Safety
    /// `payload` points to `payload_len` registers, valid and unaliased for the call;
    /// a non-null `inlined.state` is valid for writes of a `DeviceState`.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    unsafe fn trace_ray(
        &mut self,
        handle: [u32; 2],
        origin: [f32; 3],
        direction: [f32; 3],
        [tmin, tmax, time]: [f32; 3],
        [mask, flags, sbt_offset, sbt_stride, miss_index]: [u32; 5],
        payload: *mut u32,
        payload_len: usize,
        in_place: bool,
        inlined: Inlined,
        walk: impl FnOnce(&mut Self, &TraceRay, TraversableHandle),
        misses_root: impl FnOnce(&mut Self, [u32; 2], &TraceRay) -> bool,
    ) -> bool {
        if self.trace_refused(origin, direction, tmin, tmax) {
            return false;
        }
        let world = self.world_ray(origin, direction, [tmin, tmax, time], mask, flags);
        if self.root_check_ends(handle, &world, miss_index, misses_root) {
            return false;
        }
        let n = payload_len.min(MAX_PAYLOAD);
        // Registers past `n` are never read (accesses check `payload_len`), so only the
        // caller's words are copied in.
        let mut registers = [const { std::mem::MaybeUninit::<u32>::uninit() }; MAX_PAYLOAD];
        let registers_at = if in_place {
            payload
        } else {
            for (i, r) in registers[..n].iter_mut().enumerate() {
                // SAFETY: `i < n <= payload_len` (the caller's contract).
                r.write(unsafe { *payload.add(i) });
            }
            registers.as_mut_ptr().cast::<u32>()
        };
        // Only what every trace reads is written; the committed hit and the intersection
        // context are written when there are some (their `Option`s cost a few hundred
        // bytes of stores per trace).
        let mut state = TraceState {
            ray: &world,
            tmax,
            sbt_offset,
            sbt_stride,
            committed_record: None,
            committed_hit: std::mem::MaybeUninit::uninit(),
            committed_path: std::mem::MaybeUninit::uninit(),
            committed_has_path: false,
            terminated: false,
            any_hit: AnyHitOutcome::Accept,
            intersection: std::ptr::null(),
            intersection_exit: false,
        };
        let saved_trace = std::mem::replace(&mut self.trace, &mut state);
        let saved_payload = (self.payload, self.payload_len);
        (self.payload, self.payload_len) = (registers_at, n);
        self.depth += 1;
        walk(self, &world, TraversableHandle::from_words(handle));
        let run_inlined = !self.ending && self.finish_trace(&world, miss_index, inlined);
        self.depth -= 1;
        self.trace = saved_trace;
        (self.payload, self.payload_len) = saved_payload;
        if !in_place && !self.ending {
            for (i, r) in registers[..n].iter().enumerate() {
                // SAFETY: the first `n` registers were written above (and maybe by
                // programs); `i < payload_len` as above.
                unsafe { *payload.add(i) = r.assume_init() };
            }
        }
        run_inlined
    }
}

impl DeviceCalls for Invocation<'_> {
    #[inline]
    fn launch_index(&self) -> [u32; 3] {
        self.current_index()
    }

    #[inline]
    fn launch_dimensions(&self) -> [u32; 3] {
        self.shared.size
    }

    fn trace(
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
    ) {
        let walk = self.shared.trace.walk;
        // SAFETY: the slice's registers, borrowed for the call.
        unsafe {
            self.trace_ray(
                handle,
                origin,
                direction,
                [tmin, tmax, time],
                [mask, flags, sbt_offset, sbt_stride, miss_index],
                payload.as_mut_ptr(),
                payload.len(),
                false,
                Inlined::NONE,
                walk,
                |_, _, _| false,
            )
        };
    }

    fn get_payload(&self, i: u32) -> u32 {
        if (i as usize) < self.payload_len {
            // SAFETY: `payload` holds `payload_len` registers of the call in progress.
            unsafe { *self.payload.add(i as usize) }
        } else {
            0
        }
    }

    fn set_payload(&mut self, i: u32, v: u32) {
        if (i as usize) < self.payload_len && !self.ending {
            // SAFETY: as in `get_payload`.
            unsafe { *self.payload.add(i as usize) = v };
        }
    }

    fn get_attribute(&self, i: u32) -> u32 {
        self.hit()
            .and_then(|h| h.attributes.get(i as usize).copied())
            .unwrap_or(0)
    }

    fn report_intersection(&mut self, t: f32, hit_kind: u32, attributes: &[u32; 8]) -> bool {
        if self.ending
            || self.view().kind != ProgramKind::Intersection
            || self.trace.is_null()
            || self.tr().intersection_exit
        {
            return false;
        }
        // SAFETY: a non-null context is in the frame of the `custom` call that runs the
        // intersection program calling this.
        let Some(&ctx) = (unsafe { self.tr().intersection.as_ref() }) else {
            return false;
        };
        if !semantics::ray::reported_t_accepted(t, self.traced_ray().tmin, self.tr().tmax) {
            return false;
        }
        let hit = HitState {
            t,
            hit_kind: facing::custom_hit_kind(hit_kind),
            attributes: *attributes,
            ..ctx.base
        };
        let mut terminate = false;
        if self.shared.features.any_hit
            && ctx.fate == CandidateFate::NonOpaque
            && let Some(ah) = ctx.record.programs.any_hit
        {
            match self.any_hit(ah, ctx.record, &hit, ctx.path) {
                None | Some(AnyHitOutcome::Ignore) => return false,
                Some(AnyHitOutcome::Terminate) => terminate = true,
                Some(AnyHitOutcome::Accept) => {}
            }
        }
        self.commit(hit, ctx.path, ctx.record, terminate);
        let tr = self.tr_mut();
        tr.intersection_exit = tr.terminated;
        // The intersection program now sees the new end of the interval, through the
        // methods and through its state.
        // SAFETY: `view` and `state` are the intersection program's (it is running).
        unsafe {
            (*self.view).tmax = t;
            (*self.state).ray_tmax = t;
        }
        true
    }

    fn ignore_intersection(&mut self) {
        if self.view().kind == ProgramKind::AnyHit {
            self.tr_mut().any_hit = AnyHitOutcome::Ignore;
        }
    }

    fn terminate_ray(&mut self) {
        if self.view().kind == ProgramKind::AnyHit {
            self.tr_mut().any_hit = AnyHitOutcome::Terminate;
        }
    }

    #[inline]
    fn world_ray_origin(&self) -> [f32; 3] {
        self.ray().origin
    }

    #[inline]
    fn world_ray_direction(&self) -> [f32; 3] {
        self.ray().direction
    }

    #[inline]
    fn object_ray_origin(&self) -> [f32; 3] {
        self.view().object_ray().0
    }

    #[inline]
    fn object_ray_direction(&self) -> [f32; 3] {
        self.view().object_ray().1
    }

    #[inline]
    fn ray_tmin(&self) -> f32 {
        self.ray().tmin
    }

    #[inline]
    fn ray_tmax(&self) -> f32 {
        self.view().tmax
    }

    #[inline]
    fn ray_time(&self) -> f32 {
        self.ray().time
    }

    #[inline]
    fn ray_flags(&self) -> u32 {
        self.ray().flags.0
    }

    #[inline]
    fn ray_mask(&self) -> u32 {
        self.ray().mask
    }

    #[inline]
    fn primitive_index(&self) -> u32 {
        self.view().primitive_index()
    }

    #[inline]
    fn sbt_gas_index(&self) -> u32 {
        self.view().sbt_gas_index()
    }

    #[inline]
    fn instance_id(&self) -> u32 {
        self.view().instance_id()
    }

    #[inline]
    fn instance_index(&self) -> u32 {
        self.view().instance_index()
    }

    #[inline]
    fn hit_kind(&self) -> u32 {
        self.view().hit_kind()
    }

    fn is_front_face_hit(&self) -> bool {
        self.hit()
            .is_some_and(|h| facing::hit_kind_is_front(h.hit_kind))
    }

    #[inline]
    fn triangle_barycentrics(&self) -> [f32; 2] {
        self.view().triangle_barycentrics()
    }

    fn triangle_vertices(&self) -> [[f32; 3]; 3] {
        match self.hit().and_then(|h| h.data) {
            // SAFETY: the hit is the running trace's, whose structures the launch keeps
            // alive.
            Some(HitData::Triangle { vertices, .. }) => unsafe { vertices.get() },
            _ => [[0.0; 3]; 3],
        }
    }

    fn sphere(&self) -> [f32; 4] {
        match self.hit().and_then(|h| h.data) {
            Some(HitData::Sphere { sphere }) => sphere,
            _ => [0.0; 4],
        }
    }

    fn curve_parameter(&self) -> f32 {
        match self.hit().and_then(|h| h.data) {
            Some(HitData::Curve { u }) => u,
            _ => 0.0,
        }
    }

    #[inline]
    fn object_to_world(&self) -> [f32; 12] {
        self.view().object_to_world()
    }

    #[inline]
    fn world_to_object(&self) -> [f32; 12] {
        self.view().world_to_object()
    }

    fn sbt_data_u32(&self, i: u32) -> u32 {
        self.view().record.map_or(0, |r| r.data_u32(i))
    }

    fn direct_call(&mut self, index: u32, args: &mut [u32]) {
        self.call_callable(index, args, false);
    }

    fn continuation_call(&mut self, index: u32, args: &mut [u32]) {
        self.call_callable(index, args, true);
    }

    fn throw_exception(&mut self, user_code: u32) {
        if self.exceptions().contains(ExceptionFlags::USER) {
            self.raise(code::user_code(user_code));
        }
    }

    fn exception_code(&self) -> i32 {
        self.view().exception_code
    }

    #[inline]
    fn remaining_trace_depth(&self) -> u32 {
        self.shared
            .features
            .max_trace_depth
            .saturating_sub(self.depth)
    }

    fn unwinding(&self) -> bool {
        self.ending
            || (self.view().kind == ProgramKind::Intersection
                && !self.trace.is_null()
                && self.tr().intersection_exit)
    }

    fn stop_flag(&self) -> *const AtomicU32 {
        self.shared.stop
    }

    fn state(&self) -> *const DeviceState {
        self.state
    }
}
