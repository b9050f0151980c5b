//! Programs: WGSL lowered to Vulkan ray tracing stages (DESIGN.md §3,
//! docs/vulkan-backend.md §4).
//!
//! For each pipeline, each module's source is compiled again with the Vulkan prelude
//! ([`device_api`]) in place of the API's stand-ins and one compute wrapper per stage the pipeline
//! needs. naga parses and validates it; when the pipeline checks exceptions, an IR pass
//! (`exceptions`) makes user functions return after calls that raised. naga writes SPIR-V 1.4,
//! one module per stage, and the post-pass ([`postpass`]) turns each wrapper into its ray
//! tracing stage with the intrinsics' real bodies.

pub mod config;
pub mod device_api;
mod exceptions;
pub mod inline;
pub mod internal;
pub mod intrinsic;
pub mod postpass;
mod traversal;

pub use config::{HitContext, LoweringConfig, StageRole, TriangleMode, VkStage};

use optik_api::{Error, Result};
use optik_core::frontend::CompiledModule;
use postpass::{PostPassError, StageShape};

/// One lowered stage.
#[derive(Clone, Debug)]
pub struct LoweredStage {
    /// What it runs.
    pub role: StageRole,
    /// Its entry point name.
    pub entry_name: String,
    /// Its Vulkan stage.
    pub stage: VkStage,
    /// SPIR-V 1.4 words.
    pub spirv: Vec<u32>,
}

/// The WGSL a set of stages comes from.
#[derive(Clone, Copy, Debug)]
pub enum ModuleText<'a> {
    /// A user module: its source as given to `create_module`.
    User(&'a str),
    /// optik's own programs (sphere and curve intersection, null callable), with the curve
    /// basis the curve stage intersects.
    Internal {
        /// `optik_api::wgsl::curve_basis` of the curve stage's curves.
        curve_basis: u32,
    },
}

/// naga's SPIR-V settings (docs/vulkan-backend.md §4, step 3).
fn spv_options() -> naga::back::spv::Options<'static> {
    naga::back::spv::Options {
        lang_version: (1, 4),
        // DEBUG is what writes the OpNames the post-pass finds intrinsics by; naga's default
        // only sets it in debug builds (pitfall 7).
        flags: naga::back::spv::WriterFlags::DEBUG,
        fake_missing_bindings: true,
        bounds_check_policies: naga::proc::BoundsCheckPolicies {
            index: naga::proc::BoundsCheckPolicy::Restrict,
            buffer: naga::proc::BoundsCheckPolicy::ReadZeroSkipWrite,
            image_load: naga::proc::BoundsCheckPolicy::ReadZeroSkipWrite,
            binding_array: naga::proc::BoundsCheckPolicy::Restrict,
        },
        ..Default::default()
    }
}

/// A user module's direct callables for the calls inlined into its intersection and any-hit
/// stages ([`inline`]): its compiled module and its callables' ids and names.
pub type InlineCallables<'a> = (&'a CompiledModule, &'a inline::ModuleCallables);

/// The full WGSL of a module for `config`, with wrappers `_optik_entry_<i>` for `roles`.
pub fn vulkan_source(
    text: ModuleText,
    config: &LoweringConfig,
    roles: &[StageRole],
    callables: Option<InlineCallables>,
) -> String {
    let mut source = match text {
        ModuleText::User(wgsl) => wgsl.to_string(),
        ModuleText::Internal { curve_basis } => internal::internal_programs(config, curve_basis),
    };
    if !source.ends_with('\n') {
        source.push('\n');
    }
    source.push_str(&device_api::prelude(config));
    if config.inline_calls {
        source.push_str(&match callables {
            Some((module, list)) => inline::inline_source(config, Some(module), list),
            None => inline::inline_source(config, None, &[]),
        });
    }
    for (i, role) in roles.iter().enumerate() {
        source.push_str(&device_api::wrapper(
            &format!("_optik_entry_{i}"),
            role,
            config,
        ));
    }
    source
}

/// Lowers `roles` of one module into SPIR-V stages; `callables` are the module's direct
/// callables when the pipeline inlines calls ([`inline`]).
pub fn lower_stages(
    text: ModuleText,
    config: &LoweringConfig,
    roles: &[StageRole],
    callables: Option<InlineCallables>,
) -> Result<Vec<LoweredStage>> {
    let source = vulkan_source(text, config, roles, callables);
    let internal = |what: &str, detail: String| {
        Error::backend(format!(
            "internal error of the Vulkan lowering ({what}): {detail}; please report it with the WGSL module"
        ))
    };
    let mut module = naga::front::wgsl::parse_str(&source)
        .map_err(|e| internal("parse", e.emit_to_string(&source)))?;
    let mut raising = exceptions::ENDING_REPORTS.to_vec();
    if config.unwinds() {
        raising.extend_from_slice(exceptions::RAISING);
    }
    exceptions::insert_unwinding(&mut module, &raising).map_err(|e| internal("unwinding", e))?;
    // The watertight triangle test's exact fallback uses f64 (when the device has it).
    let mut capabilities = naga::valid::Capabilities::default();
    capabilities.set(
        naga::valid::Capabilities::FLOAT64,
        matches!(config.triangles, TriangleMode::Watertight { f64: true }),
    );
    let info = naga::valid::Validator::new(naga::valid::ValidationFlags::all(), capabilities)
        .validate(&module)
        .map_err(|e| internal("validation", e.emit_to_string(&source)))?;
    let options = spv_options();
    let mut stages = Vec::with_capacity(roles.len());
    for (i, role) in roles.iter().enumerate() {
        let wrapper = format!("_optik_entry_{i}");
        let pipeline = naga::back::spv::PipelineOptions {
            shader_stage: naga::ShaderStage::Compute,
            entry_point: wrapper.clone(),
        };
        let words = naga::back::spv::write_vec(&module, &info, &options, Some(&pipeline))
            .map_err(|e| internal("SPIR-V writer", e.to_string()))?;
        let entry_name = role.entry_name();
        let shape = StageShape {
            wrapper: &wrapper,
            entry_name: &entry_name,
            stage: role.vk_stage(),
            payload_len: config.payload_len,
        };
        let spirv = postpass::post_pass(&words, &shape).map_err(|e| match e {
            PostPassError::Forbidden(intrinsic, stage) => forbidden(role, intrinsic, stage),
            PostPassError::Internal(detail) => internal("post-pass", detail),
        })?;
        dump(&entry_name, &spirv);
        stages.push(LoweredStage {
            role: role.clone(),
            entry_name,
            stage: role.vk_stage(),
            spirv,
        });
    }
    Ok(stages)
}

/// Writes a lowered stage to `$OPTIK_VULKAN_DUMP_SPIRV/<entry>-<hash>.spv` when that is set,
/// for `spirv-val` and `spirv-dis` on machines where a driver misbehaves.
fn dump(entry_name: &str, spirv: &[u32]) {
    let Some(dir) = std::env::var_os("OPTIK_VULKAN_DUMP_SPIRV").filter(|d| !d.is_empty()) else {
        return;
    };
    use std::hash::{Hash, Hasher};
    let mut h = std::collections::hash_map::DefaultHasher::new();
    spirv.hash(&mut h);
    let dir = std::path::PathBuf::from(dir);
    let _ = std::fs::create_dir_all(&dir);
    let bytes: Vec<u8> = spirv.iter().flat_map(|w| w.to_le_bytes()).collect();
    let _ = std::fs::write(
        dir.join(format!("{entry_name}-{:016x}.spv", h.finish())),
        bytes,
    );
}

/// The error for a device function the Vulkan stage of a program cannot have.
fn forbidden(role: &StageRole, intrinsic: intrinsic::Intrinsic, stage: VkStage) -> Error {
    let program = match role {
        StageRole::Program { name, .. } => format!("`{name}`"),
        other => format!("optik's {}", other.entry_name()),
    };
    Error::backend(format!(
        "internal error of the Vulkan lowering: {program} reaches {} in a {stage:?} stage, which Vulkan forbids; please report it with the WGSL module",
        intrinsic.name()
    ))
}

#[cfg(test)]
mod golden;
#[cfg(test)]
mod tests;
