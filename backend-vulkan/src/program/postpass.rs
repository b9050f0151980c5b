//! The SPIR-V post-pass: turns naga's compute module for one stage wrapper into a ray tracing
//! stage (docs/vulkan-backend.md §4, step 4).
//!
//! 1. The wrapper's `OpEntryPoint` gets the stage's execution model and name; its `LocalSize`
//!    goes.
//! 2. Functions the entry point cannot reach are deleted, with their names and decorations
//!    (naga writes every function that touches no other entry point's globals, §2.4 pitfall 6).
//! 3. Each reachable intrinsic's stand-in body is replaced by its SPIR-V, creating the
//!    variables it needs (built-ins, payloads, callable data, hit attributes, the shader
//!    record); an intrinsic a stage may not use is an error.
//! 4. The new variables join the entry point's interface (SPIR-V 1.4 lists every global used,
//!    pitfall 5); the `RayTracingKHR` capability and `SPV_KHR_ray_tracing` come in, and
//!    `RayQueryKHR` goes when nothing queries rays (pitfall 2).

use super::config::VkStage;
use super::device_api::SBT_DATA_WORDS;
use super::intrinsic::Intrinsic;
use rspirv::binary::Assemble;
use rspirv::dr::{self, Builder, Instruction, Operand};
use rspirv::spirv::{BuiltIn, Capability, Decoration, ExecutionModel, Op, StorageClass, Word};
use std::collections::{HashMap, HashSet};

/// What the post-pass needs to know about a stage.
pub struct StageShape<'a> {
    /// The compute wrapper naga wrote (`_optik_entry_3`).
    pub wrapper: &'a str,
    /// The name the stage's entry point gets.
    pub entry_name: &'a str,
    /// The Vulkan stage.
    pub stage: VkStage,
    /// Payload registers (the length of `RtPayload`).
    pub payload_len: u32,
}

/// Rewrites naga's module for `shape.wrapper` into a ray tracing stage. Errors are messages
/// for the caller to wrap (an intrinsic used where its stage forbids it is the user's, every
/// other one is the backend's).
pub fn post_pass(words: &[u32], shape: &StageShape) -> Result<Vec<u32>, PostPassError> {
    let mut module = dr::load_words(words)
        .map_err(|e| PostPassError::Internal(format!("naga's SPIR-V does not load: {e}")))?;
    let entry_fn = rewrite_entry_point(&mut module, shape)?;
    let names = function_names(&module);
    prune_unreachable(&mut module, entry_fn);

    let mut pass = Pass {
        b: Builder::new_from_module(module),
        shape,
        interface: Vec::new(),
        cache: HashMap::new(),
    };
    let intrinsics: Vec<(usize, Intrinsic)> = pass
        .b
        .module_ref()
        .functions
        .iter()
        .enumerate()
        .filter_map(|(i, f)| {
            let id = f.def.as_ref()?.result_id?;
            Some((i, Intrinsic::from_name(names.get(&id)?)?))
        })
        .collect();
    for (index, intrinsic) in intrinsics {
        pass.replace_body(index, intrinsic)?;
    }
    pass.finish(entry_fn);
    Ok(pass.b.module().assemble())
}

/// Why the post-pass failed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum PostPassError {
    /// The stage uses an intrinsic its Vulkan stage cannot have (for example a direct call
    /// from an any-hit program).
    Forbidden(Intrinsic, VkStage),
    /// naga's output was not what the pass expects.
    Internal(String),
}

fn model(stage: VkStage) -> ExecutionModel {
    match stage {
        VkStage::Raygen => ExecutionModel::RayGenerationKHR,
        VkStage::Miss => ExecutionModel::MissKHR,
        VkStage::ClosestHit => ExecutionModel::ClosestHitKHR,
        VkStage::AnyHit => ExecutionModel::AnyHitKHR,
        VkStage::Intersection => ExecutionModel::IntersectionKHR,
        VkStage::Callable => ExecutionModel::CallableKHR,
    }
}

/// Sets the wrapper's execution model and name, drops the other entry points and the
/// wrapper's execution modes; returns the wrapper's function id.
fn rewrite_entry_point(module: &mut dr::Module, shape: &StageShape) -> Result<Word, PostPassError> {
    let position = module
        .entry_points
        .iter()
        .position(|ep| matches!(ep.operands.get(2), Some(Operand::LiteralString(n)) if n == shape.wrapper))
        .ok_or_else(|| PostPassError::Internal(format!("naga wrote no entry point `{}`", shape.wrapper)))?;
    let mut ep = module.entry_points.remove(position);
    module.entry_points.clear();
    let Some(Operand::IdRef(function)) = ep.operands.get(1).cloned() else {
        return Err(PostPassError::Internal(
            "entry point without a function".into(),
        ));
    };
    ep.operands[0] = Operand::ExecutionModel(model(shape.stage));
    ep.operands[2] = Operand::LiteralString(shape.entry_name.to_string());
    module.entry_points.push(ep);
    module.execution_modes.clear();
    Ok(function)
}

/// Function id → name, from `OpName` (naga writes them with `WriterFlags::DEBUG`, pitfall 7).
fn function_names(module: &dr::Module) -> HashMap<Word, String> {
    let functions: HashSet<Word> = module
        .functions
        .iter()
        .filter_map(|f| f.def.as_ref()?.result_id)
        .collect();
    module
        .debug_names
        .iter()
        .filter(|i| i.class.opcode == Op::Name)
        .filter_map(|i| match (i.operands.first(), i.operands.get(1)) {
            (Some(Operand::IdRef(id)), Some(Operand::LiteralString(n)))
                if functions.contains(id) =>
            {
                Some((*id, n.clone()))
            }
            _ => None,
        })
        .collect()
}

/// Deletes the functions `entry` cannot reach, with the names and decorations of every id
/// they define.
fn prune_unreachable(module: &mut dr::Module, entry: Word) {
    let id_of = |f: &dr::Function| f.def.as_ref().and_then(|d| d.result_id).unwrap_or(0);
    let calls: HashMap<Word, Vec<Word>> = module
        .functions
        .iter()
        .map(|f| {
            let callees = f
                .blocks
                .iter()
                .flat_map(|b| &b.instructions)
                .filter(|i| i.class.opcode == Op::FunctionCall)
                .filter_map(|i| match i.operands.first() {
                    Some(Operand::IdRef(callee)) => Some(*callee),
                    _ => None,
                })
                .collect();
            (id_of(f), callees)
        })
        .collect();
    let mut reachable = HashSet::from([entry]);
    let mut stack = vec![entry];
    while let Some(f) = stack.pop() {
        for callee in calls.get(&f).into_iter().flatten() {
            if reachable.insert(*callee) {
                stack.push(*callee);
            }
        }
    }
    let mut removed_ids = HashSet::new();
    module.functions.retain(|f| {
        if reachable.contains(&id_of(f)) {
            return true;
        }
        removed_ids.extend(
            f.def
                .iter()
                .chain(&f.parameters)
                .filter_map(|i| i.result_id),
        );
        for b in &f.blocks {
            removed_ids.extend(b.label.as_ref().and_then(|l| l.result_id));
            removed_ids.extend(b.instructions.iter().filter_map(|i| i.result_id));
        }
        false
    });
    let targets_removed = |i: &Instruction| matches!(i.operands.first(), Some(Operand::IdRef(id)) if removed_ids.contains(id));
    module.debug_names.retain(|i| !targets_removed(i));
    module.annotations.retain(|i| !targets_removed(i));
}

/// Whether a Vulkan stage may use an intrinsic.
fn allowed(intrinsic: Intrinsic, stage: VkStage) -> bool {
    use Intrinsic as I;
    use VkStage as S;
    let traversal = matches!(stage, S::Intersection | S::AnyHit | S::ClosestHit | S::Miss);
    let primitive = matches!(stage, S::Intersection | S::AnyHit | S::ClosestHit);
    let hit = matches!(stage, S::AnyHit | S::ClosestHit);
    match intrinsic {
        I::LaunchId | I::LaunchSize | I::SbtU32 => true,
        I::WorldRayOrigin | I::WorldRayDirection | I::RayTmin | I::RayTmax | I::RayFlags => {
            traversal
        }
        I::ObjectRayOrigin
        | I::ObjectRayDirection
        | I::PrimitiveId
        | I::InstanceCustomIndex
        | I::GeometryIndex
        | I::ObjectToWorld
        | I::WorldToObject => primitive,
        I::HitKind | I::AttributeGet => hit,
        I::Trace => matches!(stage, S::Raygen | S::ClosestHit | S::Miss),
        I::ExecuteCallable => matches!(stage, S::Raygen | S::ClosestHit | S::Miss | S::Callable),
        I::PayloadGet | I::PayloadSet => {
            matches!(stage, S::AnyHit | S::ClosestHit | S::Miss | S::Callable)
        }
        I::ReportIntersection => stage == S::Intersection,
        I::IgnoreIntersection | I::TerminateRay => stage == S::AnyHit,
    }
}

/// Whether an intrinsic a stage may not use is nevertheless reachable there, but never runs:
/// direct callables compiled into intersection and any-hit stages (program/inline.rs) go
/// through the same device functions as elsewhere, whose bodies choose the inlined path in
/// those stages before they would execute a callable or touch a payload, and a raygen stage
/// of such a module never takes the inlined path. Such intrinsics get a body that does
/// nothing.
fn unreached(intrinsic: Intrinsic, stage: VkStage) -> bool {
    use Intrinsic as I;
    match intrinsic {
        I::ExecuteCallable => matches!(stage, VkStage::Intersection | VkStage::AnyHit),
        // A raygen reaches them only through the inlined callables of its module, which
        // run in intersection and any-hit stages only (rt_direct_call checks the stage; the
        // front end refuses rt_get_payload and rt_set_payload in raygen programs).
        I::PayloadGet | I::PayloadSet => {
            matches!(stage, VkStage::Intersection | VkStage::Raygen)
        }
        _ => false,
    }
}

/// Variables the pass creates, one each per module.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
enum Var {
    Builtin(BuiltIn),
    Payload,
    CallableData,
    Incoming,
    HitAttributes,
    ShaderRecord,
}

struct Pass<'a> {
    b: Builder,
    shape: &'a StageShape<'a>,
    /// Variables to add to the entry point's interface.
    interface: Vec<Word>,
    cache: HashMap<Var, Word>,
}

impl Pass<'_> {
    fn u32_type(&mut self) -> Word {
        self.b.type_int(32, 0)
    }

    fn u32_constant(&mut self, value: u32) -> Word {
        let ty = self.u32_type();
        self.b.constant_bit32(ty, value)
    }

    /// An `array<u32, len>` type: naga's when it declared one (so stores of naga values type
    /// check), else a new one.
    fn u32_array_type(&mut self, len: u32) -> Word {
        let u32_ty = self.u32_type();
        let m = self.b.module_ref();
        let constant_value = |id: Word| {
            m.types_global_values
                .iter()
                .find(|i| i.result_id == Some(id) && i.class.opcode == Op::Constant)
                .and_then(|i| match i.operands.first() {
                    Some(Operand::LiteralBit32(v)) => Some(*v),
                    _ => None,
                })
        };
        let existing = m.types_global_values.iter().find(|i| {
            i.class.opcode == Op::TypeArray
                && i.operands.first() == Some(&Operand::IdRef(u32_ty))
                && matches!(i.operands.get(1), Some(Operand::IdRef(c)) if constant_value(*c) == Some(len))
        });
        if let Some(id) = existing.and_then(|i| i.result_id) {
            return id;
        }
        let length = self.u32_constant(len);
        let id = self.b.id();
        self.b
            .module_mut()
            .types_global_values
            .push(Instruction::new(
                Op::TypeArray,
                None,
                Some(id),
                vec![Operand::IdRef(u32_ty), Operand::IdRef(length)],
            ));
        id
    }

    /// The pointee of a pointer type.
    fn pointee(&self, pointer_type: Word) -> Result<Word, PostPassError> {
        self.b
            .module_ref()
            .types_global_values
            .iter()
            .find(|i| i.result_id == Some(pointer_type) && i.class.opcode == Op::TypePointer)
            .and_then(|i| match i.operands.get(1) {
                Some(Operand::IdRef(t)) => Some(*t),
                _ => None,
            })
            .ok_or_else(|| {
                PostPassError::Internal(format!("id {pointer_type} is not a pointer type"))
            })
    }

    /// A module-scope variable, created once.
    fn variable(&mut self, var: Var, ty: Word, class: StorageClass) -> Word {
        if let Some(id) = self.cache.get(&var) {
            return *id;
        }
        let pointer = self.b.type_pointer(None, class, ty);
        let id = self.b.variable(pointer, None, class, None);
        match var {
            Var::Builtin(builtin) => {
                self.b
                    .decorate(id, Decoration::BuiltIn, [Operand::BuiltIn(builtin)])
            }
            Var::Payload | Var::CallableData => {
                self.b
                    .decorate(id, Decoration::Location, [Operand::LiteralBit32(0)])
            }
            _ => {}
        }
        self.cache.insert(var, id);
        self.interface.push(id);
        id
    }

    /// The shader record: `struct { array<u32, SBT_DATA_WORDS> }`, laid out explicitly.
    fn shader_record(&mut self) -> Word {
        if let Some(id) = self.cache.get(&Var::ShaderRecord) {
            return *id;
        }
        let u32_ty = self.u32_type();
        let length = self.u32_constant(SBT_DATA_WORDS);
        let array = self.b.id();
        let block = self.b.id();
        let m = self.b.module_mut();
        // Fresh ids, not deduplicated with naga's types: these carry layout decorations.
        m.types_global_values.push(Instruction::new(
            Op::TypeArray,
            None,
            Some(array),
            vec![Operand::IdRef(u32_ty), Operand::IdRef(length)],
        ));
        m.types_global_values.push(Instruction::new(
            Op::TypeStruct,
            None,
            Some(block),
            vec![Operand::IdRef(array)],
        ));
        self.b
            .decorate(array, Decoration::ArrayStride, [Operand::LiteralBit32(4)]);
        self.b.decorate(block, Decoration::Block, []);
        self.b
            .member_decorate(block, 0, Decoration::Offset, [Operand::LiteralBit32(0)]);
        self.variable(
            Var::ShaderRecord,
            block,
            StorageClass::ShaderRecordBufferKHR,
        )
    }

    fn inst(&mut self, op: Op, ty: Option<Word>, operands: Vec<Operand>) -> (Word, Instruction) {
        let id = self.b.id();
        (id, Instruction::new(op, ty, Some(id), operands))
    }

    /// `%v = OpLoad ty ptr` appended to `body`.
    fn load(&mut self, ty: Word, ptr: Word, body: &mut Vec<Instruction>) -> Word {
        let (v, load) = self.inst(Op::Load, Some(ty), vec![Operand::IdRef(ptr)]);
        body.push(load);
        v
    }

    /// Copies the `ty` value `from` points to into `to`: the copy-in and copy-out of payloads
    /// and callable data.
    fn copy(&mut self, ty: Word, from: Word, to: Word, body: &mut Vec<Instruction>) {
        let v = self.load(ty, from, body);
        body.push(store(to, v));
    }

    /// A pointer to the `u32` at `indices` of `var` (storage class `class`).
    fn element(
        &mut self,
        var: Word,
        class: StorageClass,
        indices: &[Word],
        body: &mut Vec<Instruction>,
    ) -> Word {
        let u32_ty = self.u32_type();
        let element_ptr = self.b.type_pointer(None, class, u32_ty);
        let mut operands = vec![Operand::IdRef(var)];
        operands.extend(indices.iter().map(|i| Operand::IdRef(*i)));
        let (ptr, chain) = self.inst(Op::AccessChain, Some(element_ptr), operands);
        body.push(chain);
        ptr
    }

    /// Replaces the body of function `index`, which is `intrinsic`'s stand-in.
    fn replace_body(&mut self, index: usize, intrinsic: Intrinsic) -> Result<(), PostPassError> {
        if !allowed(intrinsic, self.shape.stage) {
            if unreached(intrinsic, self.shape.stage) {
                self.neutral_body(index);
                return Ok(());
            }
            return Err(PostPassError::Forbidden(intrinsic, self.shape.stage));
        }
        let f = &self.b.module_ref().functions[index];
        let ret_ty = f.def.as_ref().and_then(|d| d.result_type).unwrap_or(0);
        let params: Vec<(Word, Word)> = f
            .parameters
            .iter()
            .map(|p| (p.result_id.unwrap_or(0), p.result_type.unwrap_or(0)))
            .collect();
        let param = |i: usize| {
            params.get(i).copied().ok_or_else(|| {
                PostPassError::Internal(format!("{} lacks parameter {i}", intrinsic.name()))
            })
        };
        let mut body: Vec<Instruction> = Vec::new();
        let u32_ty = self.u32_type();
        use Intrinsic as I;
        match intrinsic {
            _ if intrinsic.builtin().is_some() => {
                let builtin = intrinsic.builtin().unwrap_or(BuiltIn::LaunchIdKHR);
                let var = self.variable(Var::Builtin(builtin), ret_ty, StorageClass::Input);
                let v = self.load(ret_ty, var, &mut body);
                body.push(return_value(v));
            }
            I::Trace => {
                let (payload, payload_ptr_ty) = param(10)?;
                let payload_ty = self.pointee(payload_ptr_ty)?;
                let var = self.variable(Var::Payload, payload_ty, StorageClass::RayPayloadKHR);
                let as_ty = self.b.type_acceleration_structure_khr();
                let (accel, convert) = self.inst(
                    Op::ConvertUToAccelerationStructureKHR,
                    Some(as_ty),
                    vec![Operand::IdRef(param(0)?.0)],
                );
                body.push(convert);
                self.copy(payload_ty, payload, var, &mut body);
                let mut operands = vec![Operand::IdRef(accel)];
                for i in 1..10 {
                    operands.push(Operand::IdRef(param(i)?.0));
                }
                operands.push(Operand::IdRef(var));
                body.push(Instruction::new(Op::TraceRayKHR, None, None, operands));
                self.copy(payload_ty, var, payload, &mut body);
                body.push(Instruction::new(Op::Return, None, None, vec![]));
            }
            I::ExecuteCallable => {
                let (sbt_index, _) = param(0)?;
                let (data, data_ptr_ty) = param(1)?;
                let data_ty = self.pointee(data_ptr_ty)?;
                let var = self.variable(Var::CallableData, data_ty, StorageClass::CallableDataKHR);
                self.copy(data_ty, data, var, &mut body);
                body.push(Instruction::new(
                    Op::ExecuteCallableKHR,
                    None,
                    None,
                    vec![Operand::IdRef(sbt_index), Operand::IdRef(var)],
                ));
                self.copy(data_ty, var, data, &mut body);
                body.push(Instruction::new(Op::Return, None, None, vec![]));
            }
            I::PayloadGet | I::PayloadSet => {
                let class = if self.shape.stage == VkStage::Callable {
                    StorageClass::IncomingCallableDataKHR
                } else {
                    StorageClass::IncomingRayPayloadKHR
                };
                let array = self.u32_array_type(self.shape.payload_len.max(1));
                let var = self.variable(Var::Incoming, array, class);
                let ptr = self.element(var, class, &[param(0)?.0], &mut body);
                if intrinsic == I::PayloadGet {
                    let v = self.load(u32_ty, ptr, &mut body);
                    body.push(return_value(v));
                } else {
                    body.push(store(ptr, param(1)?.0));
                    body.push(Instruction::new(Op::Return, None, None, vec![]));
                }
            }
            I::AttributeGet => {
                let array = self.u32_array_type(8);
                let var = self.variable(Var::HitAttributes, array, StorageClass::HitAttributeKHR);
                let ptr = self.element(
                    var,
                    StorageClass::HitAttributeKHR,
                    &[param(0)?.0],
                    &mut body,
                );
                let v = self.load(u32_ty, ptr, &mut body);
                body.push(return_value(v));
            }
            I::ReportIntersection => {
                let (t, _) = param(0)?;
                let (kind, _) = param(1)?;
                let (attributes, attributes_ty) = param(2)?;
                let var = self.variable(
                    Var::HitAttributes,
                    attributes_ty,
                    StorageClass::HitAttributeKHR,
                );
                body.push(store(var, attributes));
                let (accepted, report) = self.inst(
                    Op::ReportIntersectionKHR,
                    Some(ret_ty),
                    vec![Operand::IdRef(t), Operand::IdRef(kind)],
                );
                body.push(report);
                body.push(return_value(accepted));
            }
            // Terminators: the function's only block ends in them, as glslang writes a GLSL
            // helper that calls ignoreIntersectionEXT.
            I::IgnoreIntersection => body.push(Instruction::new(
                Op::IgnoreIntersectionKHR,
                None,
                None,
                vec![],
            )),
            I::TerminateRay => body.push(Instruction::new(Op::TerminateRayKHR, None, None, vec![])),
            I::SbtU32 => {
                let var = self.shader_record();
                let zero = self.u32_constant(0);
                let ptr = self.element(
                    var,
                    StorageClass::ShaderRecordBufferKHR,
                    &[zero, param(0)?.0],
                    &mut body,
                );
                let v = self.load(u32_ty, ptr, &mut body);
                body.push(return_value(v));
            }
            _ => {
                return Err(PostPassError::Internal(format!(
                    "no lowering for {}",
                    intrinsic.name()
                )));
            }
        }
        let label = self.b.id();
        let function = &mut self.b.module_mut().functions[index];
        function.blocks = vec![dr::Block {
            label: Some(Instruction::new(Op::Label, None, Some(label), vec![])),
            instructions: body,
        }];
        Ok(())
    }

    /// Gives function `index` a body that returns a zero (or nothing).
    fn neutral_body(&mut self, index: usize) {
        let ret_ty = self.b.module_ref().functions[index]
            .def
            .as_ref()
            .and_then(|d| d.result_type)
            .unwrap_or(0);
        let void = self
            .b
            .module_ref()
            .types_global_values
            .iter()
            .any(|i| i.result_id == Some(ret_ty) && i.class.opcode == Op::TypeVoid);
        let instruction = if void {
            Instruction::new(Op::Return, None, None, vec![])
        } else {
            let zero = self.b.constant_null(ret_ty);
            return_value(zero)
        };
        let label = self.b.id();
        self.b.module_mut().functions[index].blocks = vec![dr::Block {
            label: Some(Instruction::new(Op::Label, None, Some(label), vec![])),
            instructions: vec![instruction],
        }];
    }

    /// Adds the new variables to the interface and sets capabilities and extensions.
    fn finish(&mut self, entry_fn: Word) {
        let interface = std::mem::take(&mut self.interface);
        let m = self.b.module_mut();
        if let Some(ep) = m
            .entry_points
            .iter_mut()
            .find(|ep| ep.operands.get(1) == Some(&Operand::IdRef(entry_fn)))
        {
            for id in interface {
                if !ep.operands.contains(&Operand::IdRef(id)) {
                    ep.operands.push(Operand::IdRef(id));
                }
            }
        }
        let queries_rays = m
            .functions
            .iter()
            .flat_map(|f| &f.blocks)
            .flat_map(|b| &b.instructions)
            .any(|i| format!("{:?}", i.class.opcode).starts_with("RayQuery"));
        if !queries_rays {
            m.capabilities.retain(|c| {
                c.operands.first() != Some(&Operand::Capability(Capability::RayQueryKHR))
            });
            m.extensions.retain(|e| {
                e.operands.first() != Some(&Operand::LiteralString("SPV_KHR_ray_query".into()))
            });
        }
        let has_rt = m
            .capabilities
            .iter()
            .any(|c| c.operands.first() == Some(&Operand::Capability(Capability::RayTracingKHR)));
        if !has_rt {
            self.b.capability(Capability::RayTracingKHR);
        }
        let m = self.b.module_ref();
        if !m.extensions.iter().any(|e| {
            e.operands.first() == Some(&Operand::LiteralString("SPV_KHR_ray_tracing".into()))
        }) {
            self.b.extension("SPV_KHR_ray_tracing");
        }
    }
}

fn store(ptr: Word, value: Word) -> Instruction {
    Instruction::new(
        Op::Store,
        None,
        None,
        vec![Operand::IdRef(ptr), Operand::IdRef(value)],
    )
}

fn return_value(v: Word) -> Instruction {
    Instruction::new(Op::ReturnValue, None, None, vec![Operand::IdRef(v)])
}
