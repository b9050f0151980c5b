//! Device functions (`rt_*` prelude stubs) and texture built-ins: calls out to Rust.
//!
//! Every device function becomes a call of its trampoline in `host.rs` with the call
//! context first; getters whose value the runtime offers in its `DeviceState` read it
//! from there when present (a load instead of a call). Results wider than a scalar come back through the scratch slot.
//! `rt_trace`, `rt_direct_call` and `rt_continuation_call` pass the address and length of
//! the caller's `RtPayload`; the runtime copies in and out. These three and
//! `rt_report_intersection` also tell whether the runtime is unwinding
//! (`DeviceCalls::unwinding`); the program then returns at once. `rt_trace` may also ask
//! the caller to run the closest-hit program it inlined (`InlinedClosestHit`, lowered by
//! `trace` on the state the runtime wrote, without presence checks). The terminators
//! (`rt_ignore_intersection`, `rt_terminate_ray`, `rt_throw_exception`) call the host and
//! then jump to the program's exit, whichever inlined helper they are in.

use super::place::Place;
use super::{LResult, LowerError, Lowered, Lowerer};
use crate::program::abi::{self, DeviceState};
use crate::program::host::{CallContext, HostFn, REPORT_ACCEPTED, REPORT_UNWINDING};
use cranelift_codegen::ir::condcodes::IntCC;
use cranelift_codegen::ir::types::{F32, I32, I64};
use cranelift_codegen::ir::{Block, BlockArg, InstBuilder, MemFlagsData, Type, Value};
use naga::{Expression, Handle, TypeInner};
use optik_api::ProgramKind;
use optik_core::frontend::DeviceFunction as D;
use optik_core::frontend::{CompiledModule, ProgramInfo};

impl Lowerer<'_, '_> {
    /// Lowers a call of the device function `df`.
    pub(super) fn device_call(
        &mut self,
        df: D,
        args: &[Handle<Expression>],
        result: Option<Handle<Expression>>,
    ) -> LResult<()> {
        let ctx = self.ctx;
        let scalar = |s: &mut Self, f: HostFn| s.call_host(f, &[ctx])[0];
        let value: Option<Vec<Value>> = match df {
            D::LaunchIndex
            | D::LaunchDimensions
            | D::WorldRayOrigin
            | D::WorldRayDirection
            | D::ObjectRayOrigin
            | D::ObjectRayDirection
            | D::RayTmin
            | D::RayTmax
            | D::RayTime
            | D::RayFlags
            | D::RayMask
            | D::PrimitiveIndex
            | D::SbtGasIndex
            | D::InstanceId
            | D::InstanceIndex
            | D::HitKind
            | D::TriangleBarycentrics
            | D::ObjectToWorld
            | D::WorldToObject
            | D::RemainingTraceDepth => {
                if let (D::LaunchIndex, Some(index), None) =
                    (df, self.loop_index, self.state_override)
                {
                    // The program's own read in its launch loop (`LaunchLoop`).
                    Some(index.to_vec())
                } else {
                    let (bit, offset, ty, n) =
                        state_field(df).expect("every getter listed has a field");
                    let v = self.state_or_call(bit, offset, ty, n, |s| s.getter_call(df));
                    Some(match df {
                        D::ObjectToWorld | D::WorldToObject => columns_4x3(&v),
                        _ => v,
                    })
                }
            }
            D::TriangleVertices => Some(self.host_out(HostFn::triangle_vertices, F32, 9)),
            D::Sphere => Some(self.host_out(HostFn::sphere, F32, 4)),
            D::CurveParameter => Some(vec![scalar(self, HostFn::curve_parameter)]),
            D::ExceptionCode => Some(vec![scalar(self, HostFn::exception_code)]),
            D::IsFrontFaceHit => {
                let r = scalar(self, HostFn::is_front_face_hit);
                Some(vec![self.b.ins().icmp_imm_u(IntCC::NotEqual, r, 0)])
            }
            D::GetPayload => {
                let i = self.scalar(args[0])?;
                Some(vec![self.payload_access(i, None)])
            }
            D::SetPayload => {
                let i = self.scalar(args[0])?;
                let v = self.scalar(args[1])?;
                self.payload_access(i, Some(v));
                None
            }
            D::GetAttribute | D::SbtDataU32 | D::SbtDataF32 => {
                let i = self.scalar(args[0])?;
                let f = match df {
                    D::GetAttribute => HostFn::get_attribute,
                    D::SbtDataU32 => HostFn::sbt_data_u32,
                    _ => HostFn::sbt_data_f32,
                };
                Some(self.call_host(f, &[ctx, i]))
            }
            D::ReportIntersection => {
                let t = self.scalar(args[0])?;
                let kind = self.scalar(args[1])?;
                let attributes = self.values(args[2])?;
                let at = self.scratch_addr();
                for (i, &a) in attributes.iter().enumerate() {
                    self.b
                        .ins()
                        .store(MemFlagsData::trusted(), a, at, 4 * i as i32);
                }
                let r = self.call_host(HostFn::report_intersection, &[ctx, t, kind, at])[0];
                let accepted = self.b.ins().band_imm_u(r, REPORT_ACCEPTED);
                let accepted = self.b.ins().icmp_imm_u(IntCC::NotEqual, accepted, 0);
                let unwinding = self.b.ins().band_imm_u(r, REPORT_UNWINDING);
                self.return_if(unwinding);
                Some(vec![accepted])
            }
            D::IgnoreIntersection | D::TerminateRay => {
                let f = if df == D::TerminateRay {
                    HostFn::terminate_ray
                } else {
                    HostFn::ignore_intersection
                };
                self.call_host(f, &[ctx]);
                None
            }
            D::ThrowException => {
                let code = self.scalar(args[0])?;
                self.call_host(HostFn::throw_exception, &[ctx, code]);
                None
            }
            D::Trace => {
                self.trace(args)?;
                None
            }
            D::DirectCall | D::ContinuationCall => {
                let index = self.scalar(args[0])?;
                let f = if df == D::DirectCall {
                    HostFn::direct_call
                } else {
                    HostFn::continuation_call
                };
                let mut unwinding = None;
                self.with_payload(args[1], |s, ptr, len, _| {
                    unwinding = Some(s.call_host(f, &[ctx, index, ptr, len])[0]);
                    Ok(())
                })?;
                self.return_if(unwinding.expect("with_payload calls back"));
                None
            }
            D::OffsetRay => {
                return Err(LowerError::unspanned(
                    "internal: rt_offset_ray is compiled as WGSL",
                ));
            }
        };
        if let (Some(r), Some(v)) = (result, value) {
            self.frame_mut().cache[r.index()] = Some(Lowered::Value(v));
        }
        if df.is_terminator() {
            // The program ends here, from however deep an inlined helper.
            let exit = self.exit;
            self.goto(exit, &[]);
            self.start_dead_block();
        }
        Ok(())
    }

    /// Returns from the program when `flag` (a host call's result) is nonzero: the runtime
    /// asks it to (`DeviceCalls::unwinding`), from however deep an inlined helper.
    fn return_if(&mut self, flag: Value) {
        let go_on = self.b.create_block();
        let exit = self.exit;
        self.branch(flag, exit, go_on);
        self.b.seal_block(go_on);
        self.enter(go_on);
    }

    /// A getter the runtime may answer from its `DeviceState`: the field's leaves when the
    /// state has `bit`, else `call`'s result (a branch on a bit of memory the runtime
    /// sets once per invocation, so it predicts well).
    fn state_or_call(
        &mut self,
        bit: u32,
        offset: usize,
        ty: Type,
        n: usize,
        call: impl FnOnce(&mut Self) -> Vec<Value>,
    ) -> Vec<Value> {
        if !self.live {
            return call(self);
        }
        // The pointer is fixed for the call; the fields are not (report_intersection
        // updates tmax), so they are loaded where used.
        let state = self.state_pointer();
        let (fast, slow, merge) = (
            self.b.create_block(),
            self.b.create_block(),
            self.b.create_block(),
        );
        for _ in 0..n {
            self.b.append_block_param(merge, ty);
        }
        self.present_or_call(state, bit, fast, slow, merge);
        self.b.switch_to_block(fast);
        let loaded: Vec<BlockArg> = (0..n)
            .map(|i| {
                self.b
                    .ins()
                    .load(ty, MemFlagsData::trusted(), state, (offset + 4 * i) as i32)
                    .into()
            })
            .collect();
        self.b.ins().jump(merge, &loaded);
        self.b.switch_to_block(slow);
        let called: Vec<BlockArg> = call(self).into_iter().map(BlockArg::from).collect();
        self.b.ins().jump(merge, &called);
        self.b.seal_block(merge);
        self.b.switch_to_block(merge);
        self.b.block_params(merge).to_vec()
    }

    /// The `DeviceState` the code being lowered reads: the call's, or an inlined closest
    /// hit's.
    pub(super) fn state_pointer(&mut self) -> Value {
        if let Some(state) = self.state_override {
            return state;
        }
        // Fixed for the call (the fields are not: report_intersection updates tmax, so
        // they are loaded where used).
        let pointer_flags = MemFlagsData::trusted().with_readonly().with_can_move();
        self.b
            .ins()
            .load(I64, pointer_flags, self.ctx, CallContext::STATE_OFFSET)
    }

    /// `rt_trace`, and the closest-hit program inlined after it, if any: run when the
    /// runtime's entry asks for it (`TRACE_RUN_INLINED`), on the state it wrote.
    fn trace(&mut self, args: &[Handle<Expression>]) -> LResult<()> {
        let ctx = self.ctx;
        let mut call_args = vec![ctx];
        for &a in &args[..11] {
            call_args.extend(self.values(a)?);
        }
        // Not inside an inlined closest hit (it does not trace; see `inlinable_closest_hit`).
        let inlined = self
            .inlined_closest_hit
            .filter(|_| self.state_override.is_none());
        let (entry, state) = match inlined {
            Some(ch) => (
                self.b.ins().func_addr(I64, ch.entry),
                self.b.ins().stack_addr(I64, ch.state, 0),
            ),
            None => {
                let null = self.b.ins().iconst(I64, 0);
                (null, null)
            }
        };
        self.with_payload(args[11], |s, ptr, len, words| {
            call_args.extend([ptr, len, entry, state]);
            let result = s.call_host(HostFn::trace, &call_args)[0];
            let unwinding =
                s.b.ins()
                    .icmp_imm_u(IntCC::Equal, result, abi::TRACE_RETURN as i64);
            s.return_if(unwinding);
            let Some(ch) = inlined else {
                return Ok(());
            };
            // Inside the payload's call, so a payload spilled for it is read back after.
            let run =
                s.b.ins()
                    .icmp_imm_u(IntCC::Equal, result, abi::TRACE_RUN_INLINED as i64);
            let (body, after) = (s.b.create_block(), s.b.create_block());
            s.branch(run, body, after);
            s.b.seal_block(body);
            s.enter(body);
            s.state_override = Some(state);
            // The runtime hands the program this payload, in place (at most `MAX_PAYLOAD`
            // registers, as the front end sizes `RtPayload`).
            s.inlined_payload = Some((ptr, words.min(abi::MAX_PAYLOAD)));
            let lowered = s.inline_call(ch.function, &[], None);
            s.state_override = None;
            s.inlined_payload = None;
            lowered?;
            s.goto(after, &[]);
            s.b.seal_block(after);
            s.enter(after);
            Ok(())
        })
    }

    /// Branches to `fast` when `state`'s `present` word has `bit`, else to `slow`; in an
    /// inlined closest hit always to `fast`, without reading `present`
    /// (`TRACE_RUN_INLINED` promises every value the program reads: `slow` is left without
    /// a predecessor, and Cranelift drops it).
    fn present_or_call(&mut self, state: Value, bit: u32, fast: Block, slow: Block, merge: Block) {
        if self.state_override.is_some() {
            self.live_blocks.extend([fast, merge]);
            self.b.ins().jump(fast, &[]);
        } else {
            let present = self.b.ins().load(I32, MemFlagsData::trusted(), state, 0);
            let has = self.b.ins().band_imm_u(present, bit as i64);
            self.live_blocks.extend([fast, slow, merge]);
            self.b.ins().brif(has, fast, &[], slow, &[]);
        }
        self.b.seal_block(fast);
        self.b.seal_block(slow);
    }

    /// `rt_get_payload(i)` (`value` is `None`; returns the register) or
    /// `rt_set_payload(i, value)`: in the runtime's payload memory when its `DeviceState`
    /// offers it, else through the methods. Registers past the length read 0 and ignore
    /// writes either way.
    fn payload_access(&mut self, i: Value, value: Option<Value>) -> Value {
        let ctx = self.ctx;
        let call = |s: &mut Self| match value {
            None => s.call_host(HostFn::get_payload, &[ctx, i])[0],
            Some(v) => {
                s.call_host(HostFn::set_payload, &[ctx, i, v]);
                s.b.ins().iconst(I32, 0)
            }
        };
        if !self.live {
            return call(self);
        }
        if let Some((words, len)) = self.inlined_payload {
            return self.inlined_payload_access(words, len, i, value);
        }
        let state = self.state_pointer();
        let (fast, slow, merge) = (
            self.b.create_block(),
            self.b.create_block(),
            self.b.create_block(),
        );
        self.b.append_block_param(merge, I32);
        self.present_or_call(state, DeviceState::PAYLOAD, fast, slow, merge);

        self.b.switch_to_block(fast);
        let len = self.b.ins().load(
            I32,
            MemFlagsData::trusted(),
            state,
            std::mem::offset_of!(DeviceState, payload_len) as i32,
        );
        let words = self.b.ins().load(
            I64,
            MemFlagsData::trusted(),
            state,
            std::mem::offset_of!(DeviceState, payload) as i32,
        );
        self.access_registers(words, len, i, value, merge);
        self.b.switch_to_block(slow);
        let called = call(self);
        self.b.ins().jump(merge, &[called.into()]);
        self.b.seal_block(merge);
        self.b.switch_to_block(merge);
        self.b.block_params(merge)[0]
    }

    /// [`Lowerer::payload_access`] in an inlined closest hit: register `i` of the trace's
    /// payload (`len` registers at `words`), read or written in place, with the same
    /// answers (registers past the length read 0 and ignore writes). No state is read and
    /// a constant index (the usual `rt_set_payload(0u, …)`) needs no check at all.
    fn inlined_payload_access(
        &mut self,
        words: Value,
        len: u32,
        i: Value,
        value: Option<Value>,
    ) -> Value {
        if let Some(k) = self.int_konst(i) {
            let zero = self.b.ins().iconst(I32, 0);
            if k >= len {
                return zero;
            }
            let offset = 4 * k as i32;
            return match value {
                None => self
                    .b
                    .ins()
                    .load(I32, MemFlagsData::trusted(), words, offset),
                Some(v) => {
                    self.b
                        .ins()
                        .store(MemFlagsData::trusted(), v, words, offset);
                    zero
                }
            };
        }
        let (len, after) = (self.b.ins().iconst(I32, len as i64), self.b.create_block());
        self.b.append_block_param(after, I32);
        self.live_blocks.insert(after);
        self.access_registers(words, len, i, value, after);
        self.b.seal_block(after);
        self.b.switch_to_block(after);
        self.b.block_params(after)[0]
    }

    /// Register `i` of the `len` payload registers at `words`, read (`value` is `None`) or
    /// written, from the current block, which ends in a jump to `done` with the register (a
    /// write: 0). Past the length a read gives 0 and a write stores nothing.
    fn access_registers(
        &mut self,
        words: Value,
        len: Value,
        i: Value,
        value: Option<Value>,
        done: Block,
    ) {
        let inside = self.b.ins().icmp(IntCC::UnsignedLessThan, i, len);
        let zero = self.b.ins().iconst(I32, 0);
        match value {
            None => {
                // Register 0 exists (the pointer is to at least one word), so a clamped
                // index loads without a branch.
                let index = self.b.ins().select(inside, i, zero);
                let offset = self.b.ins().uextend(I64, index);
                let offset = self.b.ins().ishl_imm_u(offset, 2);
                let at = self.b.ins().iadd(words, offset);
                let loaded = self.b.ins().load(I32, MemFlagsData::trusted(), at, 0);
                let v = self.b.ins().select(inside, loaded, zero);
                self.b.ins().jump(done, &[v.into()]);
            }
            Some(v) => {
                let store = self.b.create_block();
                self.live_blocks.insert(store);
                self.b.ins().brif(inside, store, &[], done, &[zero.into()]);
                self.b.seal_block(store);
                self.b.switch_to_block(store);
                let offset = self.b.ins().uextend(I64, i);
                let offset = self.b.ins().ishl_imm_u(offset, 2);
                let at = self.b.ins().iadd(words, offset);
                self.b.ins().store(MemFlagsData::trusted(), v, at, 0);
                self.b.ins().jump(done, &[zero.into()]);
            }
        }
    }

    /// A getter through its `DeviceCalls` method (matrices row-major, as the host has them).
    fn getter_call(&mut self, df: D) -> Vec<Value> {
        let ctx = self.ctx;
        let (f, ty, n) = match df {
            D::LaunchIndex => (HostFn::launch_index, I32, 3),
            D::LaunchDimensions => (HostFn::launch_dimensions, I32, 3),
            D::WorldRayOrigin => (HostFn::world_ray_origin, F32, 3),
            D::WorldRayDirection => (HostFn::world_ray_direction, F32, 3),
            D::ObjectRayOrigin => (HostFn::object_ray_origin, F32, 3),
            D::ObjectRayDirection => (HostFn::object_ray_direction, F32, 3),
            D::TriangleBarycentrics => (HostFn::triangle_barycentrics, F32, 2),
            D::ObjectToWorld => (HostFn::object_to_world, F32, 12),
            D::WorldToObject => (HostFn::world_to_object, F32, 12),
            D::RayTmin => return self.call_host(HostFn::ray_tmin, &[ctx]),
            D::RayTmax => return self.call_host(HostFn::ray_tmax, &[ctx]),
            D::RayTime => return self.call_host(HostFn::ray_time, &[ctx]),
            D::RayFlags => return self.call_host(HostFn::ray_flags, &[ctx]),
            D::RayMask => return self.call_host(HostFn::ray_mask, &[ctx]),
            D::PrimitiveIndex => return self.call_host(HostFn::primitive_index, &[ctx]),
            D::SbtGasIndex => return self.call_host(HostFn::sbt_gas_index, &[ctx]),
            D::InstanceId => return self.call_host(HostFn::instance_id, &[ctx]),
            D::InstanceIndex => return self.call_host(HostFn::instance_index, &[ctx]),
            D::HitKind => return self.call_host(HostFn::hit_kind, &[ctx]),
            D::RemainingTraceDepth => return self.call_host(HostFn::remaining_trace_depth, &[ctx]),
            other => unreachable!("{other:?} has no DeviceState field"),
        };
        self.host_out(f, ty, n)
    }

    /// Calls `f(ctx, scratch)` and loads `n` leaves of `ty` from scratch.
    fn host_out(&mut self, f: HostFn, ty: Type, n: usize) -> Vec<Value> {
        let out = self.scratch_addr();
        let ctx = self.ctx;
        self.call_host(f, &[ctx, out]);
        (0..n)
            .map(|i| {
                self.b
                    .ins()
                    .load(ty, MemFlagsData::trusted(), out, 4 * i as i32)
            })
            .collect()
    }

    /// Runs `call` with the address and length (i32, and as a number) of the `RtPayload`
    /// that `pointer` points to. Payloads are arrays, so they live in memory; a payload in registers (not
    /// produced by the front end today) is spilled to scratch and read back.
    fn with_payload(
        &mut self,
        pointer: Handle<Expression>,
        call: impl FnOnce(&mut Self, Value, Value, u32) -> LResult<()>,
    ) -> LResult<()> {
        let pointee = self.pointee(pointer)?;
        let TypeInner::Array {
            size: naga::ArraySize::Constant(n),
            ..
        } = pointee
        else {
            return Err(LowerError::unspanned(
                "the payload argument must point to an RtPayload array",
            ));
        };
        let len = self.b.ins().iconst(I32, n.get() as i64);
        match self.place(pointer)? {
            Place::Memory(m) => {
                let ptr = self.address(&m);
                call(self, ptr, len, n.get())?;
            }
            place @ Place::Vars(_) => {
                let values = self.load(&place, &pointee)?;
                let at = self.scratch_addr();
                for (i, &v) in values.iter().enumerate() {
                    self.b
                        .ins()
                        .store(MemFlagsData::trusted(), v, at, 4 * i as i32);
                }
                call(self, at, len, n.get())?;
                let back: Vec<Value> = (0..values.len())
                    .map(|i| {
                        self.b
                            .ins()
                            .load(I32, MemFlagsData::trusted(), at, 4 * i as i32)
                    })
                    .collect();
                self.store(&place, &pointee, &back)?;
            }
        }
        Ok(())
    }

    /// The binding of a texture or sampler expression.
    fn resource(&mut self, h: Handle<Expression>) -> LResult<u32> {
        match self.expr(h)? {
            Lowered::Resource(b) => Ok(b),
            _ => Err(LowerError::unspanned("expected a texture or sampler")),
        }
    }

    /// `textureSampleLevel`, `textureLoad`, `textureDimensions`, `textureNumLevels`.
    pub(super) fn image(&mut self, e: &Expression) -> LResult<Vec<Value>> {
        let ctx = self.ctx;
        match *e {
            Expression::ImageSample {
                image,
                sampler,
                gather,
                coordinate,
                array_index,
                offset,
                level,
                depth_ref,
                clamp_to_edge,
            } => {
                if gather.is_some() {
                    return Err(LowerError::unspanned(
                        "textureGather is not supported by the CPU JIT; sample the four texels with textureLoad",
                    ));
                }
                if clamp_to_edge {
                    return Err(LowerError::unspanned(
                        "textureSampleBaseClampToEdge is not supported by the CPU JIT; use textureSampleLevel with a clamp-to-edge sampler",
                    ));
                }
                if array_index.is_some() || depth_ref.is_some() {
                    return Err(LowerError::unspanned(
                        "only texture_2d<f32> sampling is supported (no arrays, no depth comparison)",
                    ));
                }
                let level = match level {
                    naga::SampleLevel::Zero => self.b.ins().f32const(0.0),
                    naga::SampleLevel::Exact(l) => self.scalar(l)?,
                    _ => {
                        return Err(LowerError::unspanned(
                            "only textureSampleLevel is available in ray tracing programs (no derivatives)",
                        ));
                    }
                };
                let (tex, smp) = (self.resource(image)?, self.resource(sampler)?);
                let uv = self.values(coordinate)?;
                let off = match offset {
                    Some(o) => self.values(o)?,
                    None => vec![self.b.ins().iconst(I32, 0); 2],
                };
                let tex = self.b.ins().iconst(I32, tex as i64);
                let smp = self.b.ins().iconst(I32, smp as i64);
                let out = self.scratch_addr();
                self.call_host(
                    HostFn::texture_sample,
                    &[ctx, tex, smp, uv[0], uv[1], level, off[0], off[1], out],
                );
                Ok((0..4)
                    .map(|i| self.b.ins().load(F32, MemFlagsData::trusted(), out, 4 * i))
                    .collect())
            }
            Expression::ImageLoad {
                image,
                coordinate,
                array_index,
                sample,
                level,
            } => {
                if array_index.is_some() || sample.is_some() {
                    return Err(LowerError::unspanned(
                        "only texture_2d<f32> loads are supported",
                    ));
                }
                let tex = self.resource(image)?;
                let xy = self.values(coordinate)?;
                let level = match level {
                    Some(l) => self.scalar(l)?,
                    None => self.b.ins().iconst(I32, 0),
                };
                let tex = self.b.ins().iconst(I32, tex as i64);
                let out = self.scratch_addr();
                self.call_host(HostFn::texture_load, &[ctx, tex, xy[0], xy[1], level, out]);
                Ok((0..4)
                    .map(|i| self.b.ins().load(F32, MemFlagsData::trusted(), out, 4 * i))
                    .collect())
            }
            Expression::ImageQuery { image, query } => match query {
                naga::ImageQuery::Size { level } => {
                    let tex = self.resource(image)?;
                    let level = match level {
                        Some(l) => self.scalar(l)?,
                        None => self.b.ins().iconst(I32, 0),
                    };
                    let tex = self.b.ins().iconst(I32, tex as i64);
                    let out = self.scratch_addr();
                    self.call_host(HostFn::texture_size, &[ctx, tex, level, out]);
                    Ok((0..2)
                        .map(|i| self.b.ins().load(I32, MemFlagsData::trusted(), out, 4 * i))
                        .collect())
                }
                // Textures have one mip level.
                naga::ImageQuery::NumLevels => Ok(vec![self.b.ins().iconst(I32, 1)]),
                other => Err(LowerError::unspanned(format!(
                    "the texture query {other:?} is not supported"
                ))),
            },
            _ => Err(LowerError::unspanned("internal: not a texture expression")),
        }
    }
}

/// A row-major 3×4 matrix (as the host has it) as WGSL's `mat4x3<f32>`: column `j` is
/// `(m[j], m[4 + j], m[8 + j])`.
fn columns_4x3(row_major: &[Value]) -> Vec<Value> {
    (0..4)
        .flat_map(|j| (0..3).map(move |r| r * 4 + j))
        .map(|i| row_major[i])
        .collect()
}

/// The closest-hit program of `module` that its ray generation programs inline after
/// each `rt_trace` ([`InlinedClosestHit`](super::InlinedClosestHit)), if exactly one
/// qualifies: everything it asks of the device comes from the state or the payload (so
/// the runtime writes it all before the body runs, and the body never calls the runtime:
/// no trace, callable, exception, attribute or record data), it keeps no private or
/// workgroup variables (an inlined body would share the caller's), and it is small
/// (at most `MAX_INLINED_EXPRESSIONS` expressions with its helpers: it is copied to every
/// trace).
pub(crate) fn inlinable_closest_hit(module: &CompiledModule) -> Option<Handle<naga::Function>> {
    const MAX_INLINED_EXPRESSIONS: usize = 512;
    let ir = &module.module;
    let qualifies = |p: &ProgramInfo| {
        let from_state = p
            .device_functions
            .iter()
            .all(|&f| state_field(f).is_some() || matches!(f, D::GetPayload | D::SetPayload));
        let uses = &module.info[p.function];
        let no_privates = ir.global_variables.iter().all(|(g, var)| {
            !matches!(
                var.space,
                naga::AddressSpace::Private | naga::AddressSpace::WorkGroup
            ) || uses[g].is_empty()
        });
        let helpers = ir
            .functions
            .iter()
            .filter(|(_, f)| f.name.as_ref().is_some_and(|n| p.helpers.contains(n)))
            .map(|(_, f)| f.expressions.len());
        let size = ir.functions[p.function].expressions.len() + helpers.sum::<usize>();
        from_state && no_privates && size <= MAX_INLINED_EXPRESSIONS
    };
    let mut found = module
        .programs
        .iter()
        .filter(|p| p.kind == ProgramKind::ClosestHit && qualifies(p));
    match (found.next(), found.next()) {
        (Some(p), None) => Some(p.function),
        _ => None,
    }
}

/// The `DeviceState` bits a device function reads when present (0: none).
pub(crate) fn state_bits(df: D) -> u32 {
    match df {
        D::GetPayload | D::SetPayload => DeviceState::PAYLOAD,
        _ => state_field(df).map_or(0, |(bit, ..)| bit),
    }
}

/// The `DeviceState` field of a getter: (present bit, byte offset, leaf type, leaves).
fn state_field(df: D) -> Option<(u32, usize, Type, usize)> {
    use std::mem::offset_of;
    type S = DeviceState;
    Some(match df {
        D::LaunchIndex => (S::LAUNCH_INDEX, offset_of!(S, launch_index), I32, 3),
        D::LaunchDimensions => (
            S::LAUNCH_DIMENSIONS,
            offset_of!(S, launch_dimensions),
            I32,
            3,
        ),
        D::WorldRayOrigin => (S::WORLD_RAY, offset_of!(S, world_ray_origin), F32, 3),
        D::WorldRayDirection => (S::WORLD_RAY, offset_of!(S, world_ray_direction), F32, 3),
        D::ObjectRayOrigin => (S::OBJECT_RAY, offset_of!(S, object_ray_origin), F32, 3),
        D::ObjectRayDirection => (S::OBJECT_RAY, offset_of!(S, object_ray_direction), F32, 3),
        D::RayTmin => (S::RAY, offset_of!(S, ray_tmin), F32, 1),
        D::RayTmax => (S::RAY, offset_of!(S, ray_tmax), F32, 1),
        D::RayTime => (S::RAY, offset_of!(S, ray_time), F32, 1),
        D::RayFlags => (S::RAY, offset_of!(S, ray_flags), I32, 1),
        D::RayMask => (S::RAY, offset_of!(S, ray_mask), I32, 1),
        D::PrimitiveIndex => (S::PRIMITIVE, offset_of!(S, primitive_index), I32, 1),
        D::SbtGasIndex => (S::PRIMITIVE, offset_of!(S, sbt_gas_index), I32, 1),
        D::InstanceId => (S::PRIMITIVE, offset_of!(S, instance_id), I32, 1),
        D::InstanceIndex => (S::PRIMITIVE, offset_of!(S, instance_index), I32, 1),
        D::HitKind => (S::HIT, offset_of!(S, hit_kind), I32, 1),
        D::TriangleBarycentrics => (S::HIT, offset_of!(S, triangle_barycentrics), F32, 2),
        D::ObjectToWorld => (S::TRANSFORMS, offset_of!(S, object_to_world), F32, 12),
        D::WorldToObject => (S::TRANSFORMS, offset_of!(S, world_to_object), F32, 12),
        D::RemainingTraceDepth => (S::TRACE_DEPTH, offset_of!(S, remaining_trace_depth), I32, 1),
        _ => return None,
    })
}
