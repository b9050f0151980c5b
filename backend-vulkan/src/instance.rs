//! The process's Vulkan instances: one plain, one with the validation layer, each created on
//! first use and kept for the process's life.
//!
//! NVIDIA's driver does not survive many rounds of `vkCreateInstance`/`vkDestroyInstance` in
//! one process: on an H100 with driver 580 the 30th creation fails with
//! `ERROR_INCOMPATIBLE_DRIVER` (file descriptors stay flat, and keeping the loader loaded does
//! not help; other projects report corrupted subgroup state after fewer rounds). So optik
//! never destroys an instance: devices come and go on the kept ones, and any number of them
//! can be opened in turn (`tests/internal/device.rs` opens 40).

use crate::error::VkResultExt;
use crate::probe;
use crate::validation::{self, MessageLog};
use ash::vk;
use optik_api::{Error, Result};
use std::sync::{Arc, Mutex};

/// A kept instance and what was loaded with it.
pub struct SharedInstance {
    /// The Vulkan loader.
    pub entry: ash::Entry,
    /// The instance.
    pub instance: ash::Instance,
    /// `VK_EXT_debug_utils` functions, on the validated instance only.
    pub debug_utils: Option<ash::ext::debug_utils::Instance>,
    /// What the layer said while the instance was being created; the first device opened on
    /// the instance takes these into its own log.
    pub creation_log: Arc<MessageLog>,
}

/// The instance with the validation layer on (`validated`) or off, created on first use.
/// A failed creation is not kept: the next call tries again.
pub fn shared(validated: bool) -> Result<&'static SharedInstance> {
    static PLAIN: Mutex<Option<&'static SharedInstance>> = Mutex::new(None);
    static VALIDATED: Mutex<Option<&'static SharedInstance>> = Mutex::new(None);
    let slot = if validated { &VALIDATED } else { &PLAIN };
    let mut kept = slot.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
    if let Some(shared) = *kept {
        return Ok(shared);
    }
    let created: &'static SharedInstance = Box::leak(Box::new(create(validated)?));
    *kept = Some(created);
    Ok(created)
}

fn create(validated: bool) -> Result<SharedInstance> {
    let entry = probe::load_entry()?;
    probe::check_instance_version(&entry)?;
    let creation_log = Arc::new(MessageLog::default());
    let mut layers = Vec::new();
    let mut extensions = Vec::new();
    if validated {
        // SAFETY: a global command of the loaded entry.
        let available = unsafe { entry.enumerate_instance_layer_properties() }
            .or_vk("vkEnumerateInstanceLayerProperties")?;
        let has = available.iter().any(|l| {
            l.layer_name_as_c_str()
                .is_ok_and(|n| n == c"VK_LAYER_KHRONOS_validation")
        });
        if !has {
            return Err(Error::unsupported(
                "validation was asked for (OPTIK_VALIDATION=1 or a test), but VK_LAYER_KHRONOS_validation is not installed (Debian: apt install vulkan-validationlayers)",
            ));
        }
        layers.push(c"VK_LAYER_KHRONOS_validation".as_ptr());
        extensions.push(ash::ext::debug_utils::NAME.as_ptr());
    }
    let app = vk::ApplicationInfo::default()
        .application_name(c"optik")
        .engine_name(c"optik")
        .api_version(probe::API_VERSION);
    let mut messenger_info = validation::messenger_info(&creation_log);
    let mut create = vk::InstanceCreateInfo::default()
        .application_info(&app)
        .enabled_layer_names(&layers)
        .enabled_extension_names(&extensions);
    if validated {
        // Also report what instance creation itself gets wrong.
        create = create.push_next(&mut messenger_info);
    }
    // SAFETY: valid create info; the instance is kept for the process's life, and the log
    // the creation messenger points to lives as long (it is kept in the instance's record).
    let instance = unsafe { entry.create_instance(&create, None) }.or_vk("vkCreateInstance")?;
    let debug_utils = validated.then(|| ash::ext::debug_utils::Instance::new(&entry, &instance));
    Ok(SharedInstance {
        entry,
        instance,
        debug_utils,
        creation_log,
    })
}
