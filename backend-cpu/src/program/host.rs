//! The Rust side of calls out of JIT-compiled code: the per-call context and the
//! `extern "C"` functions the code imports by name.
//!
//! Compiled code reaches Rust only through symbols (relocations), never through addresses
//! baked into the machine code, so code cached on disk stays valid in another process.
//! Every import is listed in [`HostFn`] with its Cranelift signature and its address.
//!
//! Device functions (`rt_*`) go through the `DeviceCalls` trait object the runtime passed to
//! [`ProgramFn::call`](super::ProgramFn::call); the context holds it as a raw fat pointer
//! that only Rust reads. A panic inside a `DeviceCalls` method unwinds through the program
//! to the caller on Linux, where programs have unwind tables (`unwind_tables.rs`); elsewhere it
//! is caught in the trampoline, parked in the context and resumed when the program
//! returns (the trampolines answer zeros until then).

use super::abi::{Bindings, BoundResource, DeviceCalls, TraceEntry};
use super::texture;
use cranelift_codegen::ir::types::{F32, I32, I64};
use cranelift_codegen::ir::{AbiParam, Signature, Type};
use cranelift_codegen::isa::CallConv;
use std::any::Any;
use std::sync::atomic::AtomicU32;

/// A buffer as compiled code sees it: first byte and length. The table of these is the
/// first field of [`CallContext`].
#[repr(C)]
#[derive(Clone, Copy)]
pub(crate) struct BufferSlot {
    pub ptr: *mut u8,
    pub len: usize,
}

impl BufferSlot {
    /// An unbound slot: every access to it is out of bounds, so it is never dereferenced.
    pub const EMPTY: BufferSlot = BufferSlot {
        ptr: std::ptr::null_mut(),
        len: 0,
    };
}

/// Which binding fills each slot of a module's buffer table, and what its code takes as
/// given about one of them.
pub(crate) struct SlotLayout {
    /// The binding number of each slot (`None`: a buffer without a binding).
    pub bindings: Vec<Option<u32>>,
    /// The params uniform's slot and the bytes of its type. Compiled code reads the params
    /// at constant offsets below that without a bounds check, and may hoist those loads out
    /// of loops (they cannot change during a call), so every table gives the slot at least
    /// that many bytes: [`SlotLayout::fill`] pads a shorter binding with zeros, which is
    /// what a bounds-checked read past its end would have returned.
    pub params: Option<(usize, usize)>,
}

impl SlotLayout {
    /// Fills `table` (one entry per slot) from `bindings`; `padded` holds the params'
    /// zero-padded copy where they are shorter than their type, and must outlive the
    /// table's use.
    #[inline]
    pub fn fill(&self, table: &mut [BufferSlot], bindings: &Bindings<'_>, padded: &mut Vec<u8>) {
        for (slot, binding) in table.iter_mut().zip(&self.bindings) {
            *slot = match binding.and_then(|b| bindings.resources.get(b as usize)) {
                Some(BoundResource::Buffer(b)) => BufferSlot {
                    ptr: b.ptr,
                    len: b.len,
                },
                _ => BufferSlot::EMPTY,
            };
        }
        if let Some((at, bytes)) = self.params
            && let Some(slot) = table.get_mut(at)
            && slot.len < bytes
        {
            *slot = pad(*slot, bytes, padded);
        }
    }

    /// A new table filled from `bindings` ([`SlotLayout::fill`]).
    pub fn table(&self, bindings: &Bindings<'_>, padded: &mut Vec<u8>) -> Vec<BufferSlot> {
        let mut table = vec![BufferSlot::EMPTY; self.bindings.len()];
        self.fill(&mut table, bindings, padded);
        table
    }
}

/// `slot`'s bytes followed by zeros up to `bytes`, in `padded`: params bound shorter than
/// their type (never in a launch, whose bindings optik-core checks).
#[cold]
fn pad(slot: BufferSlot, bytes: usize, padded: &mut Vec<u8>) -> BufferSlot {
    padded.clear();
    padded.resize(bytes, 0);
    if slot.len > 0 {
        // SAFETY: a bound buffer's pointer is valid for its length for the call (the
        // contract of `Bindings`), and `padded` is a separate allocation of more bytes.
        unsafe { std::ptr::copy_nonoverlapping(slot.ptr, padded.as_mut_ptr(), slot.len) };
    }
    BufferSlot {
        ptr: padded.as_mut_ptr(),
        len: bytes,
    }
}

/// Bytes of [`ZERO_PAGE`]: the largest value one load may read from a buffer.
pub(crate) const ZERO_PAGE_BYTES: u32 = 1 << 16;

/// Out-of-bounds buffer loads read here instead (and so return zeros) without a branch.
pub(crate) static ZERO_PAGE: [u8; ZERO_PAGE_BYTES as usize] = [0; ZERO_PAGE_BYTES as usize];

/// What a program invocation receives. Compiled code reads the first four fields (at the
/// byte offsets below) and passes the context's address to every host function.
#[repr(C)]
pub(crate) struct CallContext<'a> {
    pub buffers: *const BufferSlot,
    pub zero_page: *const u8,
    /// The runtime's [`DeviceState`](super::abi::DeviceState), or an empty one; never null.
    pub state: *const super::abi::DeviceState,
    /// The launch's stop flag ([`DeviceCalls::stop_flag`]), or [`NEVER_STOP`]; never null.
    pub stop: *const AtomicU32,
    pub calls: *mut (dyn DeviceCalls + 'a),
    /// The runtime's own `rt_trace` for `calls`, if it offers one.
    pub trace: Option<TraceEntry>,
    pub bindings: *const Bindings<'a>,
    pub panic: Option<Box<dyn Any + Send>>,
}

impl CallContext<'_> {
    /// Byte offset of `buffers`.
    pub const BUFFERS_OFFSET: i32 = 0;
    /// Byte offset of `zero_page`.
    pub const ZERO_PAGE_OFFSET: i32 = 8;
    /// Byte offset of `state`.
    pub const STATE_OFFSET: i32 = 16;
    /// Byte offset of `stop`.
    pub const STOP_OFFSET: i32 = 24;
}

/// The stop flag of calls whose runtime offers none.
pub(crate) static NEVER_STOP: AtomicU32 = AtomicU32::new(0);

const _: () = assert!(std::mem::offset_of!(CallContext<'static>, buffers) == 0);
const _: () = assert!(std::mem::offset_of!(CallContext<'static>, zero_page) == 8);
const _: () = assert!(std::mem::offset_of!(CallContext<'static>, state) == 16);
const _: () = assert!(std::mem::offset_of!(CallContext<'static>, stop) == 24);

/// Runs `f` on the context's `DeviceCalls`. On Linux compiled code has unwind tables
/// (`unwind_tables.rs`), so a panic in `f` unwinds through it to the caller of `ProgramFn::call`.
///
/// # Safety
/// `ctx` is the live context of the current program call.
#[cfg(target_os = "linux")]
unsafe fn with_calls<R>(
    ctx: *mut CallContext<'_>,
    _default: R,
    f: impl FnOnce(&mut dyn DeviceCalls) -> R,
) -> R {
    // SAFETY: the caller passes the context `ProgramFn::call` created for this call; its
    // `calls` pointer comes from a `&mut dyn DeviceCalls` borrowed for the whole call.
    f(unsafe { &mut *(*ctx).calls })
}

/// Runs `f` on the context's `DeviceCalls`, unless an earlier call panicked. Where compiled
/// code has no unwind tables, a panic is caught here, parked in the context and resumed by
/// `ProgramFn::call` after the program returns; until then calls answer `default`.
///
/// # Safety
/// `ctx` is the live context of the current program call.
#[cfg(not(target_os = "linux"))]
unsafe fn with_calls<R>(
    ctx: *mut CallContext<'_>,
    default: R,
    f: impl FnOnce(&mut dyn DeviceCalls) -> R,
) -> R {
    // SAFETY: as above.
    let ctx = unsafe { &mut *ctx };
    if ctx.panic.is_some() {
        return default;
    }
    let calls = unsafe { &mut *ctx.calls };
    match catch_unwind(AssertUnwindSafe(|| f(calls))) {
        Ok(r) => r,
        Err(payload) => {
            ctx.panic = Some(payload);
            default
        }
    }
}

/// Writes `values` to `out`.
///
/// # Safety
/// `out` points to at least `N` writable, 4-byte values (a stack slot of compiled code).
unsafe fn write_out<T: Copy, const N: usize>(out: *mut T, values: [T; N]) {
    for (i, v) in values.into_iter().enumerate() {
        unsafe { out.add(i).write_unaligned(v) };
    }
}

macro_rules! vec_getter {
    ($name:ident, $method:ident, $t:ty, $n:literal) => {
        unsafe extern "C-unwind" fn $name(ctx: *mut CallContext<'_>, out: *mut $t) {
            let v = unsafe { with_calls(ctx, [<$t>::default(); $n], |c| c.$method()) };
            unsafe { write_out(out, v) };
        }
    };
}

macro_rules! scalar_getter {
    ($name:ident, $method:ident, $t:ty) => {
        unsafe extern "C-unwind" fn $name(ctx: *mut CallContext<'_>) -> $t {
            unsafe { with_calls(ctx, <$t>::default(), |c| c.$method()) }
        }
    };
}

vec_getter!(rt_launch_index, launch_index, u32, 3);
vec_getter!(rt_launch_dimensions, launch_dimensions, u32, 3);
vec_getter!(rt_world_ray_origin, world_ray_origin, f32, 3);
vec_getter!(rt_world_ray_direction, world_ray_direction, f32, 3);
vec_getter!(rt_object_ray_origin, object_ray_origin, f32, 3);
vec_getter!(rt_object_ray_direction, object_ray_direction, f32, 3);
vec_getter!(rt_triangle_barycentrics, triangle_barycentrics, f32, 2);
vec_getter!(rt_sphere, sphere, f32, 4);
vec_getter!(rt_object_to_world, object_to_world, f32, 12);
vec_getter!(rt_world_to_object, world_to_object, f32, 12);
scalar_getter!(rt_ray_tmin, ray_tmin, f32);
scalar_getter!(rt_ray_tmax, ray_tmax, f32);
scalar_getter!(rt_ray_time, ray_time, f32);
scalar_getter!(rt_ray_flags, ray_flags, u32);
scalar_getter!(rt_ray_mask, ray_mask, u32);
scalar_getter!(rt_primitive_index, primitive_index, u32);
scalar_getter!(rt_sbt_gas_index, sbt_gas_index, u32);
scalar_getter!(rt_instance_id, instance_id, u32);
scalar_getter!(rt_instance_index, instance_index, u32);
scalar_getter!(rt_hit_kind, hit_kind, u32);
scalar_getter!(rt_curve_parameter, curve_parameter, f32);
scalar_getter!(rt_exception_code, exception_code, i32);
scalar_getter!(rt_remaining_trace_depth, remaining_trace_depth, u32);

unsafe extern "C-unwind" fn rt_triangle_vertices(ctx: *mut CallContext<'_>, out: *mut f32) {
    let v = unsafe { with_calls(ctx, [[0.0; 3]; 3], |c| c.triangle_vertices()) };
    unsafe { write_out(out, v.concat().try_into().unwrap_or([0.0; 9])) };
}

unsafe extern "C-unwind" fn rt_is_front_face_hit(ctx: *mut CallContext<'_>) -> u32 {
    unsafe { with_calls(ctx, false, |c| c.is_front_face_hit()) as u32 }
}

unsafe extern "C-unwind" fn rt_get_payload(ctx: *mut CallContext<'_>, i: u32) -> u32 {
    unsafe { with_calls(ctx, 0, |c| c.get_payload(i)) }
}

unsafe extern "C-unwind" fn rt_set_payload(ctx: *mut CallContext<'_>, i: u32, v: u32) {
    unsafe { with_calls(ctx, (), |c| c.set_payload(i, v)) }
}

unsafe extern "C-unwind" fn rt_get_attribute(ctx: *mut CallContext<'_>, i: u32) -> u32 {
    unsafe { with_calls(ctx, 0, |c| c.get_attribute(i)) }
}

unsafe extern "C-unwind" fn rt_sbt_data_u32(ctx: *mut CallContext<'_>, i: u32) -> u32 {
    unsafe { with_calls(ctx, 0, |c| c.sbt_data_u32(i)) }
}

unsafe extern "C-unwind" fn rt_sbt_data_f32(ctx: *mut CallContext<'_>, i: u32) -> f32 {
    unsafe { with_calls(ctx, 0.0, |c| c.sbt_data_f32(i)) }
}

/// Bit of `rt_report_intersection`'s result: the report was accepted.
pub(crate) const REPORT_ACCEPTED: i64 = 1;
/// Bit of `rt_report_intersection`'s result: the program must return
/// (`DeviceCalls::unwinding`).
pub(crate) const REPORT_UNWINDING: i64 = 2;

/// `rt_report_intersection`: returns [`REPORT_ACCEPTED`] and [`REPORT_UNWINDING`] bits, so
/// the program learns both in one call.
unsafe extern "C-unwind" fn rt_report_intersection(
    ctx: *mut CallContext<'_>,
    t: f32,
    hit_kind: u32,
    attributes: *const u32,
) -> u32 {
    // SAFETY: compiled code passes a stack slot holding the 8 attribute words.
    let attributes: [u32; 8] = unsafe { attributes.cast::<[u32; 8]>().read_unaligned() };
    // A parked panic (no unwind tables) answers "unwinding": the program returns and
    // `ProgramFn::call` resumes the panic.
    unsafe {
        with_calls(ctx, REPORT_UNWINDING as u32, |c| {
            let accepted = c.report_intersection(t, hit_kind, &attributes);
            accepted as u32 * REPORT_ACCEPTED as u32
                + c.unwinding() as u32 * REPORT_UNWINDING as u32
        })
    }
}

unsafe extern "C-unwind" fn rt_ignore_intersection(ctx: *mut CallContext<'_>) {
    unsafe { with_calls(ctx, (), |c| c.ignore_intersection()) }
}

unsafe extern "C-unwind" fn rt_terminate_ray(ctx: *mut CallContext<'_>) {
    unsafe { with_calls(ctx, (), |c| c.terminate_ray()) }
}

unsafe extern "C-unwind" fn rt_throw_exception(ctx: *mut CallContext<'_>, code: u32) {
    unsafe { with_calls(ctx, (), |c| c.throw_exception(code)) }
}

/// `rt_trace`: the payload is the caller's `RtPayload` array in its own memory. Returns a
/// [`TraceEntry`] result: whether the program must return (`DeviceCalls::unwinding`), as
/// the callables do, or run the closest-hit program it inlined (only the runtime's entry
/// asks that).
#[allow(clippy::too_many_arguments)]
unsafe extern "C-unwind" fn rt_trace(
    ctx: *mut CallContext<'_>,
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
    inlined_state: *mut super::abi::DeviceState,
) -> u32 {
    // Where panics unwind through compiled code, the runtime's entry takes the call as it
    // came (elsewhere `with_calls` must catch them, so the trait's path is taken).
    #[cfg(target_os = "linux")]
    // SAFETY: `ctx` is the live context of this program call; its `trace` entry was given
    // for its `calls` object, whose data pointer it receives, with the arguments as
    // compiled code passed them (the payload is the caller's own array).
    if let Some(entry) = unsafe { (*ctx).trace } {
        return unsafe {
            entry(
                (*ctx).calls as *mut (),
                handle_lo,
                handle_hi,
                ox,
                oy,
                oz,
                dx,
                dy,
                dz,
                tmin,
                tmax,
                time,
                mask,
                flags,
                sbt_offset,
                sbt_stride,
                miss_index,
                payload,
                payload_len,
                inlined_closest_hit,
                inlined_state,
            )
        };
    }
    // The trait's `trace` runs every closest hit itself.
    let _ = (inlined_closest_hit, inlined_state);
    // SAFETY: compiled code passes the address and length of a `array<u32, N>` it owns.
    let payload = unsafe { std::slice::from_raw_parts_mut(payload, payload_len as usize) };
    unsafe {
        with_calls(ctx, 1, |c| {
            c.trace(
                [handle_lo, handle_hi],
                [ox, oy, oz],
                [dx, dy, dz],
                tmin,
                tmax,
                time,
                mask,
                flags,
                sbt_offset,
                sbt_stride,
                miss_index,
                payload,
            );
            c.unwinding() as u32
        })
    }
}

unsafe extern "C-unwind" fn rt_direct_call(
    ctx: *mut CallContext<'_>,
    index: u32,
    args: *mut u32,
    len: u32,
) -> u32 {
    // SAFETY: as for `rt_trace`'s payload.
    let args = unsafe { std::slice::from_raw_parts_mut(args, len as usize) };
    unsafe {
        with_calls(ctx, 1, |c| {
            c.direct_call(index, args);
            c.unwinding() as u32
        })
    }
}

unsafe extern "C-unwind" fn rt_continuation_call(
    ctx: *mut CallContext<'_>,
    index: u32,
    args: *mut u32,
    len: u32,
) -> u32 {
    // SAFETY: as for `rt_trace`'s payload.
    let args = unsafe { std::slice::from_raw_parts_mut(args, len as usize) };
    unsafe {
        with_calls(ctx, 1, |c| {
            c.continuation_call(index, args);
            c.unwinding() as u32
        })
    }
}

/// The resource bound at `binding`, if any.
///
/// # Safety
/// `ctx` is the live context of the current program call.
unsafe fn resource<'a>(ctx: *mut CallContext<'a>, binding: u32) -> BoundResource {
    let bindings = unsafe { &*(*ctx).bindings };
    bindings
        .resources
        .get(binding as usize)
        .copied()
        .unwrap_or(BoundResource::None)
}

/// `textureSampleLevel(t, s, uv, level[, offset])`.
#[allow(clippy::too_many_arguments)]
unsafe extern "C" fn optik_texture_sample(
    ctx: *mut CallContext<'_>,
    texture: u32,
    sampler: u32,
    u: f32,
    v: f32,
    level: f32,
    offset_x: i32,
    offset_y: i32,
    out: *mut f32,
) {
    let texel = match unsafe { (resource(ctx, texture), resource(ctx, sampler)) } {
        (BoundResource::Texture(t), BoundResource::Sampler(s)) => {
            // SAFETY: the runtime binds textures whose texels are valid for the launch.
            unsafe { texture::sample_level(&t, &s, [u, v], level, [offset_x, offset_y]) }
        }
        _ => [0.0; 4],
    };
    unsafe { write_out(out, texel) };
}

/// `textureLoad(t, coords, level)`.
unsafe extern "C" fn optik_texture_load(
    ctx: *mut CallContext<'_>,
    texture: u32,
    x: i32,
    y: i32,
    level: i32,
    out: *mut f32,
) {
    let texel = match unsafe { resource(ctx, texture) } {
        // SAFETY: as for sampling.
        BoundResource::Texture(t) => unsafe { texture::load(&t, [x, y], level) },
        _ => [0.0; 4],
    };
    unsafe { write_out(out, texel) };
}

/// `textureDimensions(t[, level])`.
unsafe extern "C" fn optik_texture_size(
    ctx: *mut CallContext<'_>,
    texture: u32,
    level: u32,
    out: *mut u32,
) {
    let size = match unsafe { resource(ctx, texture) } {
        BoundResource::Texture(t) => texture::size(&t, level),
        _ => [0, 0],
    };
    unsafe { write_out(out, size) };
}

extern "C" fn optik_sin(x: f32) -> f32 {
    x.sin()
}
extern "C" fn optik_cos(x: f32) -> f32 {
    x.cos()
}
extern "C" fn optik_tan(x: f32) -> f32 {
    x.tan()
}
extern "C" fn optik_asin(x: f32) -> f32 {
    x.asin()
}
extern "C" fn optik_acos(x: f32) -> f32 {
    x.acos()
}
extern "C" fn optik_atan(x: f32) -> f32 {
    x.atan()
}
extern "C" fn optik_atan2(y: f32, x: f32) -> f32 {
    y.atan2(x)
}
extern "C" fn optik_sinh(x: f32) -> f32 {
    x.sinh()
}
extern "C" fn optik_cosh(x: f32) -> f32 {
    x.cosh()
}
extern "C" fn optik_tanh(x: f32) -> f32 {
    x.tanh()
}
extern "C" fn optik_asinh(x: f32) -> f32 {
    x.asinh()
}
extern "C" fn optik_acosh(x: f32) -> f32 {
    x.acosh()
}
extern "C" fn optik_atanh(x: f32) -> f32 {
    x.atanh()
}
extern "C" fn optik_exp(x: f32) -> f32 {
    x.exp()
}
extern "C" fn optik_exp2(x: f32) -> f32 {
    x.exp2()
}
extern "C" fn optik_ln(x: f32) -> f32 {
    x.ln()
}
extern "C" fn optik_log2(x: f32) -> f32 {
    x.log2()
}
extern "C" fn optik_pow(x: f32, y: f32) -> f32 {
    x.powf(y)
}
extern "C" fn optik_ldexp(x: f32, e: i32) -> f32 {
    super::math_ref::ldexp(x, e)
}
unsafe extern "C" fn optik_frexp(x: f32, exp: *mut i32) -> f32 {
    let (fract, e) = super::math_ref::frexp(x);
    unsafe { exp.write_unaligned(e) };
    fract
}
extern "C" fn optik_quantize_f16(x: f32) -> f32 {
    super::math_ref::quantize_f16(x)
}
extern "C" fn optik_pack4x8snorm(a: f32, b: f32, c: f32, d: f32) -> u32 {
    super::math_ref::pack4x8snorm([a, b, c, d])
}
extern "C" fn optik_pack2x16snorm(a: f32, b: f32) -> u32 {
    super::math_ref::pack2x16snorm([a, b])
}
extern "C" fn optik_pack2x16unorm(a: f32, b: f32) -> u32 {
    super::math_ref::pack2x16unorm([a, b])
}
extern "C" fn optik_pack2x16float(a: f32, b: f32) -> u32 {
    super::math_ref::pack2x16float([a, b])
}
extern "C" fn optik_pack4xi8(a: i32, b: i32, c: i32, d: i32) -> u32 {
    super::math_ref::pack4xi8([a, b, c, d])
}
extern "C" fn optik_pack4xu8(a: u32, b: u32, c: u32, d: u32) -> u32 {
    super::math_ref::pack4xu8([a, b, c, d])
}
extern "C" fn optik_pack4xi8_clamp(a: i32, b: i32, c: i32, d: i32) -> u32 {
    super::math_ref::pack4xi8_clamp([a, b, c, d])
}
extern "C" fn optik_pack4xu8_clamp(a: u32, b: u32, c: u32, d: u32) -> u32 {
    super::math_ref::pack4xu8_clamp([a, b, c, d])
}
unsafe extern "C" fn optik_unpack4x8snorm(x: u32, out: *mut f32) {
    unsafe { write_out(out, super::math_ref::unpack4x8snorm(x)) }
}
unsafe extern "C" fn optik_unpack4x8unorm(x: u32, out: *mut f32) {
    unsafe { write_out(out, super::math_ref::unpack4x8unorm(x)) }
}
unsafe extern "C" fn optik_unpack2x16snorm(x: u32, out: *mut f32) {
    unsafe { write_out(out, super::math_ref::unpack2x16snorm(x)) }
}
unsafe extern "C" fn optik_unpack2x16unorm(x: u32, out: *mut f32) {
    unsafe { write_out(out, super::math_ref::unpack2x16unorm(x)) }
}
unsafe extern "C" fn optik_unpack2x16float(x: u32, out: *mut f32) {
    unsafe { write_out(out, super::math_ref::unpack2x16float(x)) }
}
unsafe extern "C" fn optik_unpack4xi8(x: u32, out: *mut i32) {
    unsafe { write_out(out, super::math_ref::unpack4xi8(x)) }
}
unsafe extern "C" fn optik_unpack4xu8(x: u32, out: *mut u32) {
    unsafe { write_out(out, super::math_ref::unpack4xu8(x)) }
}
extern "C" fn optik_dot4i8packed(a: u32, b: u32) -> i32 {
    super::math_ref::dot4i8packed(a, b)
}
extern "C" fn optik_dot4u8packed(a: u32, b: u32) -> u32 {
    super::math_ref::dot4u8packed(a, b)
}

/// The shape of a host function's parameters and results, in Cranelift types.
struct Shape {
    params: &'static [Type],
    returns: &'static [Type],
}

const P: Type = I64;
const CTX: &[Type] = &[P];
const CTX_OUT: &[Type] = &[P, P];
const F1: &[Type] = &[F32];
const F2: &[Type] = &[F32, F32];
const NONE: &[Type] = &[];
const U1: &[Type] = &[I32];

macro_rules! host_fns {
    ($($variant:ident => $func:expr, $params:expr, $returns:expr;)*) => {
        /// Every function compiled code may import.
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
        #[allow(non_camel_case_types, missing_docs)]
        pub(crate) enum HostFn { $($variant,)* }

        impl HostFn {
            /// Every host function.
            pub const ALL: &'static [HostFn] = &[$(HostFn::$variant,)*];

            /// The symbol name compiled code imports it by.
            pub fn symbol(self) -> &'static str {
                match self { $(HostFn::$variant => concat!("optik_host_", stringify!($variant)),)* }
            }

            /// Its address in this process.
            pub fn address(self) -> *const u8 {
                match self { $(HostFn::$variant => $func as *const u8,)* }
            }

            fn shape(self) -> Shape {
                match self { $(HostFn::$variant => Shape { params: $params, returns: $returns },)* }
            }
        }
    };
}

host_fns! {
    launch_index => rt_launch_index, CTX_OUT, NONE;
    launch_dimensions => rt_launch_dimensions, CTX_OUT, NONE;
    world_ray_origin => rt_world_ray_origin, CTX_OUT, NONE;
    world_ray_direction => rt_world_ray_direction, CTX_OUT, NONE;
    object_ray_origin => rt_object_ray_origin, CTX_OUT, NONE;
    object_ray_direction => rt_object_ray_direction, CTX_OUT, NONE;
    triangle_barycentrics => rt_triangle_barycentrics, CTX_OUT, NONE;
    triangle_vertices => rt_triangle_vertices, CTX_OUT, NONE;
    sphere => rt_sphere, CTX_OUT, NONE;
    object_to_world => rt_object_to_world, CTX_OUT, NONE;
    world_to_object => rt_world_to_object, CTX_OUT, NONE;
    ray_tmin => rt_ray_tmin, CTX, F1;
    ray_tmax => rt_ray_tmax, CTX, F1;
    ray_time => rt_ray_time, CTX, F1;
    ray_flags => rt_ray_flags, CTX, U1;
    ray_mask => rt_ray_mask, CTX, U1;
    primitive_index => rt_primitive_index, CTX, U1;
    sbt_gas_index => rt_sbt_gas_index, CTX, U1;
    instance_id => rt_instance_id, CTX, U1;
    instance_index => rt_instance_index, CTX, U1;
    hit_kind => rt_hit_kind, CTX, U1;
    curve_parameter => rt_curve_parameter, CTX, F1;
    exception_code => rt_exception_code, CTX, U1;
    remaining_trace_depth => rt_remaining_trace_depth, CTX, U1;
    is_front_face_hit => rt_is_front_face_hit, CTX, U1;
    get_payload => rt_get_payload, &[P, I32], U1;
    set_payload => rt_set_payload, &[P, I32, I32], NONE;
    get_attribute => rt_get_attribute, &[P, I32], U1;
    sbt_data_u32 => rt_sbt_data_u32, &[P, I32], U1;
    sbt_data_f32 => rt_sbt_data_f32, &[P, I32], F1;
    report_intersection => rt_report_intersection, &[P, F32, I32, P], U1;
    ignore_intersection => rt_ignore_intersection, CTX, NONE;
    terminate_ray => rt_terminate_ray, CTX, NONE;
    throw_exception => rt_throw_exception, &[P, I32], NONE;
    trace => rt_trace, &[P, I32, I32, F32, F32, F32, F32, F32, F32, F32, F32, F32, I32, I32, I32, I32, I32, P, I32, P, P], U1;
    direct_call => rt_direct_call, &[P, I32, P, I32], U1;
    continuation_call => rt_continuation_call, &[P, I32, P, I32], U1;
    texture_sample => optik_texture_sample, &[P, I32, I32, F32, F32, F32, I32, I32, P], NONE;
    texture_load => optik_texture_load, &[P, I32, I32, I32, I32, P], NONE;
    texture_size => optik_texture_size, &[P, I32, I32, P], NONE;
    sin => optik_sin, F1, F1;
    cos => optik_cos, F1, F1;
    tan => optik_tan, F1, F1;
    asin => optik_asin, F1, F1;
    acos => optik_acos, F1, F1;
    atan => optik_atan, F1, F1;
    atan2 => optik_atan2, F2, F1;
    sinh => optik_sinh, F1, F1;
    cosh => optik_cosh, F1, F1;
    tanh => optik_tanh, F1, F1;
    asinh => optik_asinh, F1, F1;
    acosh => optik_acosh, F1, F1;
    atanh => optik_atanh, F1, F1;
    exp => optik_exp, F1, F1;
    exp2 => optik_exp2, F1, F1;
    ln => optik_ln, F1, F1;
    log2 => optik_log2, F1, F1;
    pow => optik_pow, F2, F1;
    ldexp => optik_ldexp, &[F32, I32], F1;
    frexp => optik_frexp, &[F32, P], F1;
    quantize_f16 => optik_quantize_f16, F1, F1;
    pack4x8snorm => optik_pack4x8snorm, &[F32, F32, F32, F32], U1;
    pack2x16snorm => optik_pack2x16snorm, F2, U1;
    pack2x16unorm => optik_pack2x16unorm, F2, U1;
    pack2x16float => optik_pack2x16float, F2, U1;
    pack4xi8 => optik_pack4xi8, &[I32, I32, I32, I32], U1;
    pack4xu8 => optik_pack4xu8, &[I32, I32, I32, I32], U1;
    pack4xi8_clamp => optik_pack4xi8_clamp, &[I32, I32, I32, I32], U1;
    pack4xu8_clamp => optik_pack4xu8_clamp, &[I32, I32, I32, I32], U1;
    unpack4x8snorm => optik_unpack4x8snorm, &[I32, P], NONE;
    unpack4x8unorm => optik_unpack4x8unorm, &[I32, P], NONE;
    unpack2x16snorm => optik_unpack2x16snorm, &[I32, P], NONE;
    unpack2x16unorm => optik_unpack2x16unorm, &[I32, P], NONE;
    unpack2x16float => optik_unpack2x16float, &[I32, P], NONE;
    unpack4xi8 => optik_unpack4xi8, &[I32, P], NONE;
    unpack4xu8 => optik_unpack4xu8, &[I32, P], NONE;
    dot4i8packed => optik_dot4i8packed, &[I32, I32], U1;
    dot4u8packed => optik_dot4u8packed, &[I32, I32], U1;
}

impl HostFn {
    /// Its Cranelift signature under `call_conv`.
    pub fn signature(self, call_conv: CallConv) -> Signature {
        let shape = self.shape();
        let mut sig = Signature::new(call_conv);
        sig.params
            .extend(shape.params.iter().map(|&t| AbiParam::new(t)));
        sig.returns
            .extend(shape.returns.iter().map(|&t| AbiParam::new(t)));
        sig
    }
}
