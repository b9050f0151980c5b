//! Unwind tables for compiled programs, so that a panic inside a `DeviceCalls` method
//! unwinds through program frames to the caller of `ProgramFn::call`, as through Rust
//! frames.
//!
//! Without them a panic could not leave the trampoline (the unwinder would find no frame
//! information for the program and abort), so each device call would need a
//! `catch_unwind`, which measured at several nanoseconds per call. Program frames hold
//! nothing that needs dropping, so unwinding through them is sound.
//!
//! Cranelift describes each function's frame (System V CFI); this module writes them as an
//! `.eh_frame` section and hands it to the unwinder with `__register_frame`. On Linux with
//! glibc (libgcc's unwinder) that call takes the whole section; the LLVM libunwind used
//! elsewhere takes one FDE per call. Other platforms keep `catch_unwind` (see `host.rs`).

use cranelift_codegen::gimli::RunTimeEndian;
use cranelift_codegen::gimli::write::{Address, EhFrame, EndianVec, FrameTable};
use cranelift_codegen::isa::TargetIsa;
use cranelift_codegen::isa::unwind::UnwindInfo;

unsafe extern "C" {
    fn __register_frame(fde: *const u8);
    fn __deregister_frame(fde: *const u8);
}

/// An `.eh_frame` registered with the unwinder; deregistered on drop (before the code it
/// describes is freed).
pub(crate) struct UnwindRegistration {
    /// Owns the section the unwinder reads.
    _eh_frame: Box<[u8]>,
    /// Addresses passed to `__register_frame`, as integers (the registration is global).
    registered: Vec<usize>,
}

impl UnwindRegistration {
    /// Registers the frames of `functions`: (address of the finalized code, its unwind
    /// information).
    pub fn new(isa: &dyn TargetIsa, functions: &[(usize, UnwindInfo)]) -> Result<Self, String> {
        let cie = isa
            .create_systemv_cie()
            .ok_or("this target has no System V unwind information")?;
        let mut table = FrameTable::default();
        let cie_id = table.add_cie(cie);
        for (address, info) in functions {
            match info {
                UnwindInfo::SystemV(info) => {
                    table.add_fde(cie_id, info.to_fde(Address::Constant(*address as u64)))
                }
                _ => return Err("Cranelift produced non-System V unwind information".into()),
            }
        }
        let endian = if cfg!(target_endian = "little") {
            RunTimeEndian::Little
        } else {
            RunTimeEndian::Big
        };
        let mut eh_frame = EhFrame(EndianVec::new(endian));
        table
            .write_eh_frame(&mut eh_frame)
            .map_err(|e| format!("writing unwind tables: {e}"))?;
        let mut bytes = eh_frame.0.into_vec();
        // A zero-length record ends the section.
        bytes.extend_from_slice(&[0; 4]);
        let eh_frame = bytes.into_boxed_slice();
        let mut registered = Vec::new();
        if cfg!(all(target_os = "linux", target_env = "gnu")) {
            // SAFETY: a well-formed, terminated `.eh_frame` that lives until deregistered.
            unsafe { __register_frame(eh_frame.as_ptr()) };
            registered.push(eh_frame.as_ptr() as usize);
        } else {
            let mut at = 0;
            while at + 8 <= eh_frame.len() {
                let len = u32::from_ne_bytes(eh_frame[at..at + 4].try_into().unwrap_or_default())
                    as usize;
                if len == 0 {
                    break;
                }
                let cie_pointer =
                    u32::from_ne_bytes(eh_frame[at + 4..at + 8].try_into().unwrap_or_default());
                if cie_pointer != 0 {
                    // SAFETY: `at` starts an FDE of the section above.
                    unsafe { __register_frame(eh_frame.as_ptr().add(at)) };
                    registered.push(eh_frame.as_ptr() as usize + at);
                }
                at += 4 + len;
            }
        }
        Ok(Self {
            _eh_frame: eh_frame,
            registered,
        })
    }
}

impl Drop for UnwindRegistration {
    fn drop(&mut self) {
        for &fde in self.registered.iter().rev() {
            // SAFETY: registered above, not yet deregistered.
            unsafe { __deregister_frame(fde as *const u8) };
        }
    }
}
