//! The on-disk pipeline cache: a `VkPipelineCache` loaded when the device opens and saved
//! after each pipeline and when the device closes, under `$OPTIK_CACHE_PATH`, else
//! `$XDG_CACHE_HOME/optik`, else `~/.cache/optik`; `OPTIK_CACHE_DISABLE=1` turns it off.
//! One file per device model and driver (the cache header's vendor, device and UUID), so
//! drivers never see another's data. The file is an `optik_api::cache` checked file: each
//! save goes to a temporary name of its own (devices of several threads save at once) and a
//! torn or damaged file reads as no cache, so the driver only ever gets data it returned
//! (`vkCreatePipelineCache` need not survive anything else). Failures to read or write only
//! lose the cache.

use crate::context::Context;
use ash::vk;
use std::path::PathBuf;

/// The kind of the cache's checked file (a file of the earlier, unchecked format reads as
/// no cache and is replaced at the next save).
const MAGIC: &[u8; 8] = b"optikvk1";

/// A pipeline cache and where it is kept.
pub struct PipelineCache {
    cache: vk::PipelineCache,
    path: Option<PathBuf>,
}

/// The directory the cache lives in, from the environment.
pub fn cache_dir() -> Option<PathBuf> {
    optik_api::cache::root()
}

/// Whether `data` is a cache this device wrote (Vulkan's header version one).
fn header_matches(data: &[u8], ctx: &Context) -> bool {
    let word = |i: usize| {
        data.get(i * 4..i * 4 + 4)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    };
    data.len() >= 32
        && word(1) == Some(1)
        && word(2) == Some(ctx.info.vendor_id)
        && word(3) == Some(ctx.info.device_id)
        && data[16..32] == ctx.info.pipeline_cache_uuid
}

impl PipelineCache {
    /// Opens the cache in `dir` (default: [`cache_dir`]); `enabled` false keeps it in memory.
    pub fn open(ctx: &Context, enabled: bool, dir: Option<PathBuf>) -> PipelineCache {
        let path = enabled
            .then(|| dir.or_else(cache_dir))
            .flatten()
            .map(|dir| {
                let uuid: String = ctx
                    .info
                    .pipeline_cache_uuid
                    .iter()
                    .map(|b| format!("{b:02x}"))
                    .collect();
                dir.join(format!(
                    "vulkan-{:04x}-{:04x}-{uuid}.bin",
                    ctx.info.vendor_id, ctx.info.device_id
                ))
            });
        let data = path
            .as_ref()
            .and_then(|p| optik_api::cache::read_checked(p, MAGIC))
            .filter(|d| header_matches(d, ctx))
            .unwrap_or_default();
        let info = vk::PipelineCacheCreateInfo::default().initial_data(&data);
        // SAFETY: the data is either empty or, whole (checked), a cache with this device's
        // header that this driver returned.
        let cache = unsafe { ctx.device.create_pipeline_cache(&info, None) }
            .or_else(|_| {
                // SAFETY: an empty cache.
                unsafe {
                    ctx.device
                        .create_pipeline_cache(&vk::PipelineCacheCreateInfo::default(), None)
                }
            })
            .unwrap_or_default();
        PipelineCache { cache, path }
    }

    /// The cache for `vkCreateRayTracingPipelinesKHR`.
    pub fn handle(&self) -> vk::PipelineCache {
        self.cache
    }

    /// Where the cache file is, when on disk.
    pub fn path(&self) -> Option<&PathBuf> {
        self.path.as_ref()
    }

    /// Writes the cache to disk (a checked file: a temporary file of this save's own, then a
    /// rename).
    pub fn save(&self, ctx: &Context) {
        let Some(path) = &self.path else { return };
        if self.cache == vk::PipelineCache::null() {
            return;
        }
        // SAFETY: a cache of this device.
        let Ok(data) = (unsafe { ctx.device.get_pipeline_cache_data(self.cache) }) else {
            return;
        };
        if let Some(dir) = path.parent() {
            let _ = std::fs::create_dir_all(dir);
        }
        optik_api::cache::write_checked(path, MAGIC, &data);
    }

    /// Frees the cache object.
    pub fn destroy(&self, ctx: &Context) {
        // SAFETY: no pipeline creation is running.
        unsafe { ctx.device.destroy_pipeline_cache(self.cache, None) };
    }
}
