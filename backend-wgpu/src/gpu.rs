//! The wgpu device under an optik device: adapter choice, limits, and turning wgpu's
//! failures (device loss, out-of-memory, validation) into `optik_api::Error`s.

use optik_api::{Error, ErrorKind, Result};
use std::mem::ManuallyDrop;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};

/// Environment variable naming the adapter to use (a substring of its name).
pub const ADAPTER_ENV: &str = "OPTIK_WGPU_ADAPTER";

/// A wgpu device and queue with what optik needs to know about them.
pub(crate) struct Gpu {
    /// Dropped (with `queue`) under `optik_core::vulkan_loader::changing_devices`, by
    /// `Gpu`'s drop: the last handles on the wgpu device, so the Vulkan device goes then.
    pub device: ManuallyDrop<wgpu::Device>,
    pub queue: ManuallyDrop<wgpu::Queue>,
    pub info: wgpu::AdapterInfo,
    pub limits: wgpu::Limits,
    pub features: wgpu::Features,
    /// The device's long-lived allocations (`crate::memory`).
    pub memory: crate::memory::MemoryTracker,
    /// Where compiled kernels are written (`WgpuOptions::kernel_dir`).
    pub kernel_dir: Option<std::path::PathBuf>,
    lost: Arc<AtomicBool>,
    lost_reason: Arc<Mutex<String>>,
    uncaptured: Arc<Mutex<Vec<String>>>,
}

impl Gpu {
    /// Opens the adapter named by [`ADAPTER_ENV`], or else the first of discrete GPUs,
    /// integrated GPUs, virtual GPUs and CPU adapters.
    pub fn open(options: &crate::WgpuOptions) -> Result<Gpu> {
        let instance = crate::probe::instance();
        let adapters = pollster::block_on(instance.enumerate_adapters(wgpu::Backends::PRIMARY));
        if adapters.is_empty() {
            return Err(Error::unsupported(
                "wgpu found no adapter (no Vulkan, Metal or DX12 driver); install a GPU driver or Mesa's lavapipe",
            ));
        }
        let wanted = std::env::var(ADAPTER_ENV).ok();
        let rank = |t: wgpu::DeviceType| match t {
            wgpu::DeviceType::DiscreteGpu => 0,
            wgpu::DeviceType::IntegratedGpu => 1,
            wgpu::DeviceType::VirtualGpu => 2,
            wgpu::DeviceType::Cpu => 3,
            wgpu::DeviceType::Other => 4,
        };
        let adapter = match &wanted {
            Some(name) => adapters
                .into_iter()
                .find(|a| a.get_info().name.contains(name.as_str()))
                .ok_or_else(|| {
                    Error::unsupported(format!(
                        "{ADAPTER_ENV}={name}, but no wgpu adapter has that in its name (`optik info` lists them)"
                    ))
                })?,
            None => adapters
                .into_iter()
                .min_by_key(|a| rank(a.get_info().device_type))
                .ok_or_else(|| Error::unsupported("wgpu found no adapter"))?,
        };
        let info = adapter.get_info();
        let offered = adapter.features();
        let features = offered
            & (wgpu::Features::TIMESTAMP_QUERY
                | wgpu::Features::SHADER_F64
                | wgpu::Features::FLOAT32_FILTERABLE);
        let adapter_limits = adapter.limits();
        let opened = {
            let _devices = optik_core::vulkan_loader::changing_devices();
            pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
                label: Some("optik-wgpu"),
                required_features: features,
                required_limits: adapter_limits.clone(),
                ..Default::default()
            }))
        };
        let (device, queue) = opened.map_err(|e| {
            Error::unsupported(format!("wgpu could not open adapter `{}`: {e}", info.name))
        })?;
        let (device, queue) = (ManuallyDrop::new(device), ManuallyDrop::new(queue));
        // optik's own decisions (arena chunks, binding checks, the dispatch grid) may use
        // lower caps than the adapter's, so that splitting can be tested on any adapter.
        let mut limits = adapter_limits;
        if let Some(cap) = options.max_storage_binding {
            limits.max_storage_buffer_binding_size =
                limits.max_storage_buffer_binding_size.min(cap);
        }
        if let Some(cap) = options.max_storage_buffers_per_stage {
            limits.max_storage_buffers_per_shader_stage =
                limits.max_storage_buffers_per_shader_stage.min(cap);
        }
        if let Some(cap) = options.max_workgroups_per_dimension {
            limits.max_compute_workgroups_per_dimension =
                limits.max_compute_workgroups_per_dimension.min(cap.max(1));
        }
        let lost = Arc::new(AtomicBool::new(false));
        let lost_reason = Arc::new(Mutex::new(String::new()));
        {
            let lost = lost.clone();
            let lost_reason = lost_reason.clone();
            device.set_device_lost_callback(move |reason, message| {
                if let Ok(mut r) = lost_reason.lock() {
                    *r = format!("{reason:?}: {message}");
                }
                lost.store(true, Ordering::SeqCst);
            });
        }
        // wgpu's default handler panics; errors outside error scopes are kept and reported
        // by the next call instead.
        let uncaptured = Arc::new(Mutex::new(Vec::new()));
        {
            let uncaptured = uncaptured.clone();
            device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
                if let Ok(mut v) = uncaptured.lock() {
                    v.push(e.to_string());
                }
            }));
        }
        Ok(Gpu {
            device,
            queue,
            info,
            limits,
            features,
            memory: crate::memory::MemoryTracker::default(),
            kernel_dir: options.kernel_dir.clone(),
            lost,
            lost_reason,
            uncaptured,
        })
    }

    /// An error when the device was lost or an earlier command failed outside a scope.
    pub fn check(&self) -> Result<()> {
        if self.lost.load(Ordering::SeqCst) {
            let reason = self
                .lost_reason
                .lock()
                .map(|r| r.clone())
                .unwrap_or_default();
            return Err(Error::new(
                ErrorKind::DeviceLost,
                format!(
                    "the wgpu device `{}` was lost ({reason}); every object it owned is gone: open a new device",
                    self.info.name
                ),
            ));
        }
        let pending: Vec<String> = self
            .uncaptured
            .lock()
            .map(|mut v| std::mem::take(&mut *v))
            .unwrap_or_default();
        if let Some(first) = pending.first() {
            return Err(Error::backend(format!(
                "an earlier wgpu command failed: {first}"
            )));
        }
        Ok(())
    }

    /// Runs `f` inside out-of-memory and validation error scopes; a failure becomes an
    /// error naming `what`.
    pub fn scoped<T>(&self, what: &str, f: impl FnOnce() -> T) -> Result<T> {
        self.check()?;
        let validation = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let oom = self.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let value = f();
        let oom = pollster::block_on(oom.pop());
        let validation = pollster::block_on(validation.pop());
        if let Some(e) = oom {
            return Err(Error::new(
                ErrorKind::OutOfMemory,
                format!(
                    "{what}: the device `{}` is out of memory ({e})",
                    self.info.name
                ),
            ));
        }
        if let Some(e) = validation {
            return Err(map_wgpu_error(what, &e));
        }
        self.check()?;
        Ok(value)
    }

    /// Waits for all submitted work.
    pub fn wait(&self) -> Result<()> {
        self.check()?;
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| Error::backend(format!("waiting for the GPU failed: {e}")))?;
        self.check()
    }

    /// Reads `len` bytes at `offset` of `buffer` (usage COPY_SRC) after all submitted work.
    pub fn read(&self, buffer: &wgpu::Buffer, offset: u64, len: u64) -> Result<Vec<u8>> {
        if len == 0 {
            return Ok(Vec::new());
        }
        let start = offset & !3;
        let end = (offset + len).div_ceil(4) * 4;
        let staging = self.scoped("allocating a readback buffer", || {
            self.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("optik readback"),
                size: end - start,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        })?;
        let mut encoder = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor::default());
        encoder.copy_buffer_to_buffer(buffer, start, &staging, 0, end - start);
        self.queue.submit([encoder.finish()]);
        let (tx, rx) = std::sync::mpsc::channel();
        staging.slice(..).map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        self.wait()?;
        match rx.recv() {
            Ok(Ok(())) => {}
            _ => {
                return Err(Error::backend(
                    "mapping a readback buffer failed (was the device lost?)",
                ));
            }
        }
        let view = staging
            .slice(..)
            .get_mapped_range()
            .map_err(|e| Error::backend(format!("reading a mapped buffer failed: {e}")))?;
        let skip = (offset - start) as usize;
        let out = view[skip..skip + len as usize].to_vec();
        drop(view);
        staging.unmap();
        Ok(out)
    }
}

impl Drop for Gpu {
    fn drop(&mut self) {
        let _devices = optik_core::vulkan_loader::changing_devices();
        // SAFETY: dropped once, here, and never used after (`self` is going).
        unsafe {
            ManuallyDrop::drop(&mut self.queue);
            ManuallyDrop::drop(&mut self.device);
        }
    }
}

/// A wgpu validation error as an optik error: most are limits the caller can act on.
pub(crate) fn map_wgpu_error(what: &str, e: &wgpu::Error) -> Error {
    match e {
        wgpu::Error::OutOfMemory { .. } => Error::new(
            ErrorKind::OutOfMemory,
            format!("{what}: the device is out of memory"),
        ),
        _ => Error::backend(format!("{what}: wgpu reported: {e}")),
    }
}
