//! The Khronos validation layer's messages: a debug messenger collects them per device, and
//! tests fail on any (DESIGN.md §9: zero messages is part of passing).

use ash::vk;
use std::ffi::CStr;
use std::sync::Mutex;

/// Messages the validation layer reported, oldest first.
#[derive(Default, Debug)]
pub struct MessageLog {
    messages: Mutex<Vec<String>>,
}

impl MessageLog {
    /// Takes the messages collected so far.
    pub fn take(&self) -> Vec<String> {
        std::mem::take(&mut *self.messages.lock().unwrap_or_else(|p| p.into_inner()))
    }

    pub(crate) fn push(&self, message: String) {
        self.messages
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .push(message);
    }
}

/// Whether the environment asks for validation (`OPTIK_VALIDATION=1`).
pub fn requested_by_env() -> bool {
    std::env::var("OPTIK_VALIDATION").is_ok_and(|v| v == "1" || v.eq_ignore_ascii_case("true"))
}

/// The messenger's settings: warnings and errors of validation and performance checks.
/// General messages (the loader's notes about drivers that are installed but find no
/// hardware) are not the program's fault and are left out.
pub fn messenger_info(log: &MessageLog) -> vk::DebugUtilsMessengerCreateInfoEXT<'_> {
    vk::DebugUtilsMessengerCreateInfoEXT::default()
        .message_severity(
            vk::DebugUtilsMessageSeverityFlagsEXT::WARNING
                | vk::DebugUtilsMessageSeverityFlagsEXT::ERROR,
        )
        .message_type(
            vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE,
        )
        .pfn_user_callback(Some(callback))
        .user_data(log as *const MessageLog as *mut std::ffi::c_void)
}

unsafe extern "system" fn callback(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    kind: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    user: *mut std::ffi::c_void,
) -> vk::Bool32 {
    if data.is_null() || user.is_null() {
        return vk::FALSE;
    }
    // SAFETY: the layer passes a valid callback data struct for the call's duration, and
    // `user` is the MessageLog the device owns and keeps alive (boxed) until the messenger
    // is destroyed.
    let (data, log) = unsafe { (&*data, &*(user as *const MessageLog)) };
    let text = |p: *const std::ffi::c_char| {
        if p.is_null() {
            String::new()
        } else {
            unsafe { CStr::from_ptr(p) }.to_string_lossy().into_owned()
        }
    };
    log.push(format!(
        "[{severity:?} {kind:?}] {}: {}",
        text(data.p_message_id_name),
        text(data.p_message)
    ));
    vk::FALSE
}

#[cfg(test)]
mod tests {
    use crate::context::{Context, VulkanOptions};
    use ash::vk;

    /// The messenger really reports: an invalid call through the device is caught.
    #[test]
    fn the_layer_reports_invalid_usage() {
        let options = VulkanOptions {
            validation: true,
            device: None,
            force_staging: false,
            pipeline_cache: false,
            cache_dir: None,
            max_dispatch_invocations: None,
            driver_triangles: None,
        };
        let ctx = Context::new(&options).expect("a Vulkan ray tracing device for the tests");
        assert!(ctx.log.take().is_empty());
        // No usage bits: VUID-VkBufferCreateInfo-usage-requiredbitmask.
        let info = vk::BufferCreateInfo::default().size(16);
        // SAFETY: deliberately invalid usage for the layer to catch; the buffer is destroyed.
        if let Ok(b) = unsafe { ctx.device.create_buffer(&info, None) } {
            unsafe { ctx.device.destroy_buffer(b, None) };
        }
        let messages = ctx.log.take();
        assert!(messages.iter().any(|m| m.contains("usage")), "{messages:?}");
    }
}
