//! Modules and program groups.
//!
//! A module keeps its source: pipelines recompile it with their payload length and lower
//! it into the megakernel ([`instance`] clones its functions per call context, `crate::kernel`
//! writes the rest). Program groups keep their modules alive, so destroying a module does
//! not break groups made from it.

pub(crate) mod analysis;
pub(crate) mod instance;

use optik_api::{
    Error, ModuleCompileOptions, PipelineCompileOptions, ProgramGroupDesc, ProgramRef,
    ProgramSource, Result,
};
use optik_core::frontend::{self, CompiledModule};
use std::sync::Arc;

/// A compiled module.
///
/// (Public only as `WgpuBackend`'s `optik_core::Backend::Module`, the type optik-core's
/// device keeps; its insides stay private to this crate.)
pub struct ModuleObject {
    pub(crate) source: Arc<ModuleSource>,
}

/// A module's source and its check at creation.
pub(crate) struct ModuleSource {
    pub source: ProgramSource,
    /// Compiled with the creation's payload length (the pipeline's, or 32 when `Auto`).
    pub compiled: CompiledModule,
}

impl ModuleObject {
    /// Compiles `source`; the log lists the programs found. The optimisation and debug
    /// levels of `options` do not change the generated WGSL (the driver optimises it).
    pub(crate) fn create(
        _options: &ModuleCompileOptions,
        pipeline_options: &PipelineCompileOptions,
        source: &ProgramSource,
    ) -> Result<(ModuleObject, String)> {
        // optik-core has checked the register count.
        let payload = pipeline_options.num_payload_values.or(32);
        let compiled = frontend::compile(source, payload)?;
        let mut log = format!("{}: {} programs", source.file_name, compiled.programs.len());
        for p in &compiled.programs {
            log.push_str(&format!("\n  {} ({}) at line {}", p.name, p.kind, p.line));
        }
        Ok((
            ModuleObject {
                source: Arc::new(ModuleSource {
                    source: source.clone(),
                    compiled,
                }),
            },
            log,
        ))
    }
}

/// A program group: its description and the modules its programs come from.
///
/// (Public only as `WgpuBackend`'s `optik_core::Backend::ProgramGroup`, the type optik-core's
/// device keeps; its insides stay private to this crate.)
pub struct GroupObject {
    pub(crate) desc: ProgramGroupDesc,
    /// The source of each program of `desc.programs()`, in that order.
    pub(crate) sources: Vec<Arc<ModuleSource>>,
}

impl GroupObject {
    /// Resolves the modules of `desc`'s programs.
    pub(crate) fn create(
        desc: &ProgramGroupDesc,
        module_of: &dyn Fn(&ProgramRef) -> Result<Arc<ModuleSource>>,
    ) -> Result<GroupObject> {
        let mut sources = Vec::new();
        for (kind, program) in desc.programs() {
            let source = module_of(program)?;
            // optik-core has checked that the program exists with this kind.
            if source.compiled.program(&program.entry).is_none() {
                return Err(Error::backend(format!(
                    "{} program `{}` vanished from its module",
                    kind.name(),
                    program.entry
                )));
            }
            sources.push(source);
        }
        if let ProgramGroupDesc::Callables {
            direct: None,
            continuation: None,
        } = desc
        {
            return Err(Error::invalid(
                "a callables program group needs a direct or a continuation callable",
            ));
        }
        Ok(GroupObject {
            desc: desc.clone(),
            sources,
        })
    }
}
