//! Turning a front-end module into callable programs with the Cranelift JIT (`program`).

use crate::pipeline::ModuleObject;
use optik_api::{ModuleCompileOptions, Result};
use optik_core::frontend::CompiledModule;
use std::sync::Arc;

/// Compiles every program of `compiled`; returns the module object and a log line.
#[cfg(feature = "jit")]
pub(crate) fn compile(
    compiled: Arc<CompiledModule>,
    options: &ModuleCompileOptions,
) -> Result<(ModuleObject, String)> {
    use crate::pipeline::ProgramCode;
    use crate::program::{JitModule, JitOptions};
    let jit = JitModule::compile(
        &compiled,
        &JitOptions {
            opt_level: options.opt_level,
            ..Default::default()
        },
    )?;
    let programs = compiled
        .programs
        .iter()
        .map(|p| {
            (
                p.name.clone(),
                (
                    p.kind,
                    ProgramCode::Jit {
                        module: jit.clone(),
                        name: Arc::from(p.name.as_str()),
                        source: compiled.clone(),
                        opt_level: options.opt_level,
                    },
                ),
            )
        })
        .collect();
    let stats = jit.stats();
    let mut log = format!(
        "{}: {} programs compiled ({} from the disk cache) in {:.1} ms",
        compiled.file_name,
        stats.functions,
        stats.disk_cache_hits,
        stats.time.as_secs_f64() * 1e3
    );
    if stats.closest_hits_inlined > 0 {
        log += &format!(
            "; the closest-hit program inlined after the traces of {} ray generation programs",
            stats.closest_hits_inlined
        );
    }
    if stats.launch_loops > 0 {
        log += &format!(
            "; {} ray generation programs compiled with their launch loop",
            stats.launch_loops
        );
    }
    Ok((
        ModuleObject {
            compiled: Some(compiled),
            programs,
            native: None,
        },
        log,
    ))
}

/// `source` compiled again with `RtPayload` of `payload_len` registers.
#[cfg(feature = "jit")]
pub(crate) fn recompile(
    source: &CompiledModule,
    opt_level: optik_api::OptLevel,
    payload_len: u32,
) -> Result<(crate::program::JitModule, Arc<CompiledModule>)> {
    use crate::program::{JitModule, JitOptions};
    let program =
        optik_api::ProgramSource::new(source.file_name.clone(), source.user_source.clone());
    let compiled = Arc::new(optik_core::frontend::compile(&program, payload_len)?);
    let jit = JitModule::compile(
        &compiled,
        &JitOptions {
            opt_level,
            ..Default::default()
        },
    )?;
    Ok((jit, compiled))
}

/// Without the JIT, WGSL modules parse and check but cannot run.
#[cfg(not(feature = "jit"))]
pub(crate) fn compile(
    compiled: Arc<CompiledModule>,
    _: &ModuleCompileOptions,
) -> Result<(ModuleObject, String)> {
    Err(optik_api::Error::unsupported(format!(
        "{}: this optik-cpu was built without the `jit` feature, so WGSL programs cannot run; enable the feature, or use CpuDevice::create_native_module for Rust programs",
        compiled.file_name
    )))
}
