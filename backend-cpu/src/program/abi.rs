//! The contract between JIT-compiled programs and the CPU runtime.
//!
//! A compiled program is called (`ProgramFn::call`) with the resources it may touch and a
//! `&mut dyn DeviceCalls` that answers every device-API function (DESIGN.md §3) for the
//! current ray, hit and launch index. The JIT lowers each prelude stub (`rt_*`) to a call
//! of the matching [`DeviceCalls`] method (through `extern "C-unwind"` trampolines), or to a
//! load from the runtime's [`DeviceState`] when it offers one (and `rt_trace` to the runtime's
//! own [`TraceEntry`], when it gives one, without the trait object); the runtime
//! (`device_api` and `traversal`) implements the trait. Tests implement it too, which is how the
//! JIT is tested without traversal and traversal without the JIT.
//!
//! Terminators: `rt_ignore_intersection`, `rt_terminate_ray` and `rt_throw_exception` end
//! the calling program. The JIT emits the call and then returns from the whole program
//! (helpers are inlined, so this is a jump to the program's exit). The runtime records what
//! happened in its own state during the call.
//!
//! Private globals (`var<private>`) are per program invocation: zero-initialised (or set
//! to their initialiser) at each program entry, as in a Vulkan ray tracing stage.

/// Answers the device-API calls of one program invocation.
///
/// Vectors are arrays in component order. Matrices are 3×4 row-major `[f32; 12]`
/// (object-to-world maps object space to world space); WGSL's `mat4x3<f32>` has these as
/// columns: column `j` is `(m[j], m[4 + j], m[8 + j])`.
pub trait DeviceCalls {
    /// `rt_launch_index()`.
    fn launch_index(&self) -> [u32; 3];
    /// `rt_launch_dimensions()`.
    fn launch_dimensions(&self) -> [u32; 3];
    /// `rt_trace(...)`: traces and updates `payload` (copy-in/copy-out; its length is the
    /// pipeline's payload register count, at least 1).
    #[allow(clippy::too_many_arguments)]
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
    );
    /// `rt_get_payload(i)` (in callables: the call's argument registers).
    fn get_payload(&self, i: u32) -> u32;
    /// `rt_set_payload(i, v)`.
    fn set_payload(&mut self, i: u32, v: u32);
    /// `rt_get_attribute(i)`.
    fn get_attribute(&self, i: u32) -> u32;
    /// `rt_report_intersection(t, hit_kind, attributes)`.
    fn report_intersection(&mut self, t: f32, hit_kind: u32, attributes: &[u32; 8]) -> bool;
    /// `rt_ignore_intersection()`; the program ends after it.
    fn ignore_intersection(&mut self);
    /// `rt_terminate_ray()`; the program ends after it.
    fn terminate_ray(&mut self);
    /// `rt_world_ray_origin()`.
    fn world_ray_origin(&self) -> [f32; 3];
    /// `rt_world_ray_direction()`.
    fn world_ray_direction(&self) -> [f32; 3];
    /// `rt_object_ray_origin()`.
    fn object_ray_origin(&self) -> [f32; 3];
    /// `rt_object_ray_direction()`.
    fn object_ray_direction(&self) -> [f32; 3];
    /// `rt_ray_tmin()`.
    fn ray_tmin(&self) -> f32;
    /// `rt_ray_tmax()`.
    fn ray_tmax(&self) -> f32;
    /// `rt_ray_time()`.
    fn ray_time(&self) -> f32;
    /// `rt_ray_flags()`.
    fn ray_flags(&self) -> u32;
    /// `rt_ray_mask()`.
    fn ray_mask(&self) -> u32;
    /// `rt_primitive_index()`.
    fn primitive_index(&self) -> u32;
    /// `rt_sbt_gas_index()`.
    fn sbt_gas_index(&self) -> u32;
    /// `rt_instance_id()`.
    fn instance_id(&self) -> u32;
    /// `rt_instance_index()`.
    fn instance_index(&self) -> u32;
    /// `rt_hit_kind()`.
    fn hit_kind(&self) -> u32;
    /// `rt_is_front_face_hit()`.
    fn is_front_face_hit(&self) -> bool;
    /// `rt_triangle_barycentrics()`.
    fn triangle_barycentrics(&self) -> [f32; 2];
    /// `rt_triangle_vertices()`.
    fn triangle_vertices(&self) -> [[f32; 3]; 3];
    /// `rt_sphere()`: centre and radius.
    fn sphere(&self) -> [f32; 4];
    /// `rt_curve_parameter()`.
    fn curve_parameter(&self) -> f32;
    /// `rt_object_to_world()`.
    fn object_to_world(&self) -> [f32; 12];
    /// `rt_world_to_object()`.
    fn world_to_object(&self) -> [f32; 12];
    /// `rt_sbt_data_u32(i)`: word `i` of the current SBT record's data (after the header).
    fn sbt_data_u32(&self, i: u32) -> u32;
    /// `rt_sbt_data_f32(i)`.
    fn sbt_data_f32(&self, i: u32) -> f32 {
        f32::from_bits(self.sbt_data_u32(i))
    }
    /// `rt_direct_call(index, &args)`.
    fn direct_call(&mut self, index: u32, args: &mut [u32]);
    /// `rt_continuation_call(index, &args)`.
    fn continuation_call(&mut self, index: u32, args: &mut [u32]);
    /// `rt_throw_exception(code)`; the program ends after it.
    fn throw_exception(&mut self, code: u32);
    /// `rt_exception_code()`.
    fn exception_code(&self) -> i32;
    /// `rt_remaining_trace_depth()`.
    fn remaining_trace_depth(&self) -> u32;
    /// Whether the calling program must return at once. It turns true during a call that
    /// runs other programs: `trace`, `direct_call` and `continuation_call` when an
    /// exception ended the launch index (the exception program has run; OptiX ends the
    /// index), and `report_intersection` when an any-hit program terminated the ray or the
    /// ray's `TERMINATE_ON_FIRST_HIT` accepted the report (the intersection program ends, as
    /// in Vulkan). Compiled programs check it after those calls and return, as they do
    /// after a terminator; the runtime turns further device calls into no-ops meanwhile.
    fn unwinding(&self) -> bool {
        false
    }

    /// Optional: the launch's stop flag. Compiled programs read it at every loop back-edge
    /// and return when it is non-zero, so a program that never ends (an infinite loop) can
    /// be cancelled. The default (null) is a flag that is never set. The word must stay
    /// valid until the program returns.
    fn stop_flag(&self) -> *const std::sync::atomic::AtomicU32 {
        std::ptr::null()
    }

    /// Optional: the values of this invocation as plain memory (see [`DeviceState`]).
    /// Programs read a field whose `present` bit is set with a load instead of calling
    /// its method, which saves a few nanoseconds per call. The default (null) means every
    /// getter calls its method.
    ///
    /// The pointer must stay valid until the program returns, and reads through it must
    /// see what the methods would return at that moment: if a method changes a value (the
    /// ray's `tmax` after an accepted `report_intersection`), update the field too. Keep the
    /// state in memory that Rust does not also hold a `&` reference to across such updates
    /// (a field behind a `Box` or an `UnsafeCell`).
    fn state(&self) -> *const DeviceState {
        std::ptr::null()
    }
}

/// A runtime's own `rt_trace`, called by compiled code instead of [`DeviceCalls::trace`]
/// when the runtime offers one for a program call (`ProgramFn::call_prepared_with_state`):
/// the arguments stay scalars in registers end to end, with no `dyn` call and no arrays
/// built in memory on the way (their 4-byte stores, read back 8 or 16 bytes at a time,
/// stalled store-to-load forwarding on every trace).
///
/// `calls` is the data pointer of the `&mut dyn DeviceCalls` the program was called with;
/// the entry must do exactly what that object's `trace` followed by `unwinding` does, and
/// return whether the program must return ([`TRACE_RETURN`]) or go on ([`TRACE_GO_ON`]).
/// `payload` points to `payload_len` registers the caller owns, as the slice `trace` takes.
///
/// `inlined_closest_hit` is the entry of a closest-hit program the caller has inlined
/// after the call (or null), with `inlined_state` the `DeviceState` that inlined code reads.
/// When the trace's closest hit would run exactly that program, the entry may instead
/// write `inlined_state` as it would the program's own state (its payload in place) and
/// return [`TRACE_RUN_INLINED`]: the caller then runs the program's code itself, which
/// saves the call (docs/cpu-backend.md §8).
pub type TraceEntry = unsafe extern "C-unwind" fn(
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
) -> u32;

/// A [`TraceEntry`]'s result: the program goes on.
pub const TRACE_GO_ON: u32 = 0;
/// A [`TraceEntry`]'s result: the program must return (`DeviceCalls::unwinding`).
pub const TRACE_RETURN: u32 = 1;
/// A [`TraceEntry`]'s result: the caller runs its inlined closest-hit program on the
/// state the entry wrote, which holds every value the program reads (the inlined code
/// does not check `present`) but its payload: the inlined code addresses the caller's
/// payload in place, so the entry leaves `DeviceState::PAYLOAD` unwritten.
pub const TRACE_RUN_INLINED: u32 = 2;

/// Most payload (and callable argument) registers a trace or call hands a program: a
/// caller's longer `RtPayload` is cut to these.
pub const MAX_PAYLOAD: u32 = optik_api::MAX_PAYLOAD_VALUES;

/// Device-API values a runtime may hand to programs as memory ([`DeviceCalls::state`]).
/// Each group of fields has a bit in `present`; a getter whose bit is clear calls its
/// [`DeviceCalls`] method instead. Matrices are row-major 3×4, as the methods return them.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DeviceState {
    /// Which fields hold values: a union of the `DeviceState::*` bits.
    pub present: u32,
    /// `rt_launch_index()` ([`DeviceState::LAUNCH_INDEX`]).
    pub launch_index: [u32; 3],
    /// `rt_launch_dimensions()` ([`DeviceState::LAUNCH_DIMENSIONS`]).
    pub launch_dimensions: [u32; 3],
    /// `rt_world_ray_origin()` ([`DeviceState::WORLD_RAY`]).
    pub world_ray_origin: [f32; 3],
    /// `rt_world_ray_direction()` ([`DeviceState::WORLD_RAY`]).
    pub world_ray_direction: [f32; 3],
    /// `rt_object_ray_origin()` ([`DeviceState::OBJECT_RAY`]).
    pub object_ray_origin: [f32; 3],
    /// `rt_object_ray_direction()` ([`DeviceState::OBJECT_RAY`]).
    pub object_ray_direction: [f32; 3],
    /// `rt_ray_tmin()` ([`DeviceState::RAY`]).
    pub ray_tmin: f32,
    /// `rt_ray_tmax()` ([`DeviceState::RAY`]).
    pub ray_tmax: f32,
    /// `rt_ray_time()` ([`DeviceState::RAY`]).
    pub ray_time: f32,
    /// `rt_ray_flags()` ([`DeviceState::RAY`]).
    pub ray_flags: u32,
    /// `rt_ray_mask()` ([`DeviceState::RAY`]).
    pub ray_mask: u32,
    /// `rt_primitive_index()` ([`DeviceState::PRIMITIVE`]).
    pub primitive_index: u32,
    /// `rt_sbt_gas_index()` ([`DeviceState::PRIMITIVE`]).
    pub sbt_gas_index: u32,
    /// `rt_instance_id()` ([`DeviceState::PRIMITIVE`]).
    pub instance_id: u32,
    /// `rt_instance_index()` ([`DeviceState::PRIMITIVE`]).
    pub instance_index: u32,
    /// `rt_hit_kind()` ([`DeviceState::HIT`]).
    pub hit_kind: u32,
    /// `rt_triangle_barycentrics()` ([`DeviceState::HIT`]).
    pub triangle_barycentrics: [f32; 2],
    /// `rt_object_to_world()` ([`DeviceState::TRANSFORMS`]).
    pub object_to_world: [f32; 12],
    /// `rt_world_to_object()` ([`DeviceState::TRANSFORMS`]).
    pub world_to_object: [f32; 12],
    /// `rt_remaining_trace_depth()` ([`DeviceState::TRACE_DEPTH`]).
    pub remaining_trace_depth: u32,
    /// Registers `len` of `rt_get_payload` / `rt_set_payload` ([`DeviceState::PAYLOAD`]):
    /// reads past it give 0 and writes past it are dropped, as the methods do.
    pub payload_len: u32,
    /// The payload registers ([`DeviceState::PAYLOAD`]): programs read and write them in
    /// place, so this must point to `max(payload_len, 1)` words that nothing else uses
    /// while the program runs, and writes must be allowed (a runtime that drops writes
    /// leaves the bit clear).
    pub payload: *mut u32,
}

impl Default for DeviceState {
    fn default() -> DeviceState {
        DeviceState::EMPTY
    }
}

impl DeviceState {
    /// `launch_index` is set.
    pub const LAUNCH_INDEX: u32 = 1 << 0;
    /// `launch_dimensions` is set.
    pub const LAUNCH_DIMENSIONS: u32 = 1 << 1;
    /// `world_ray_origin` and `world_ray_direction` are set.
    pub const WORLD_RAY: u32 = 1 << 2;
    /// `object_ray_origin` and `object_ray_direction` are set.
    pub const OBJECT_RAY: u32 = 1 << 3;
    /// `ray_tmin`, `ray_tmax`, `ray_time`, `ray_flags` and `ray_mask` are set.
    pub const RAY: u32 = 1 << 4;
    /// `primitive_index`, `sbt_gas_index`, `instance_id` and `instance_index` are set.
    pub const PRIMITIVE: u32 = 1 << 5;
    /// `hit_kind` and `triangle_barycentrics` are set.
    pub const HIT: u32 = 1 << 6;
    /// `object_to_world` and `world_to_object` are set.
    pub const TRANSFORMS: u32 = 1 << 7;
    /// `remaining_trace_depth` is set.
    pub const TRACE_DEPTH: u32 = 1 << 8;
    /// `payload` and `payload_len` are set.
    pub const PAYLOAD: u32 = 1 << 9;
    /// Nothing set: every getter calls its method.
    pub const EMPTY: DeviceState = DeviceState {
        present: 0,
        launch_index: [0; 3],
        launch_dimensions: [0; 3],
        world_ray_origin: [0.0; 3],
        world_ray_direction: [0.0; 3],
        object_ray_origin: [0.0; 3],
        object_ray_direction: [0.0; 3],
        ray_tmin: 0.0,
        ray_tmax: 0.0,
        ray_time: 0.0,
        ray_flags: 0,
        ray_mask: 0,
        primitive_index: 0,
        sbt_gas_index: 0,
        instance_id: 0,
        instance_index: 0,
        hit_kind: 0,
        triangle_barycentrics: [0.0; 2],
        object_to_world: [0.0; 12],
        world_to_object: [0.0; 12],
        remaining_trace_depth: 0,
        payload_len: 0,
        payload: std::ptr::null_mut(),
    };
}

/// A storage buffer (or the params uniform) bound for a program call.
#[derive(Clone, Copy, Debug)]
pub struct BoundBuffer {
    /// First byte.
    pub ptr: *mut u8,
    /// Bytes bound.
    pub len: usize,
}

/// Texel formats the JIT's sampler understands (mirrors `optik_api::TextureFormat`).
pub use optik_api::TextureFormat;

/// A texture bound for a program call: texels row by row.
#[derive(Clone, Copy, Debug)]
pub struct BoundTexture {
    /// First texel.
    pub ptr: *const u8,
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// Texel format.
    pub format: TextureFormat,
}

/// One `@group(0)` binding's resource for a program call.
#[derive(Clone, Copy, Debug)]
pub enum BoundResource {
    /// Nothing bound (a binding the program does not use).
    None,
    /// A buffer (binding 0: the params bytes).
    Buffer(BoundBuffer),
    /// A texture.
    Texture(BoundTexture),
    /// A sampler.
    Sampler(optik_api::SamplerDesc),
}

/// Resources indexed by binding number: `resources[b]` is `@group(0) @binding(b)`.
/// The runtime keeps the memory alive and unaliased by Rust references for the launch.
pub struct Bindings<'a> {
    /// By binding number.
    pub resources: &'a [BoundResource],
}

// Programs run on many threads at once, reading and writing user buffers through raw
// pointers exactly as GPU programs do; the runtime guarantees the memory outlives the launch.
unsafe impl Send for BoundBuffer {}
unsafe impl Sync for BoundBuffer {}
unsafe impl Send for BoundTexture {}
unsafe impl Sync for BoundTexture {}
