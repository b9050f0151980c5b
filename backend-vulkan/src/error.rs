//! Vulkan results as optik errors: device loss and out-of-memory get their own kinds, never
//! panics.

use ash::vk;
use optik_api::{Error, ErrorKind};

/// The optik error for a failed Vulkan call `what`.
pub fn vk_error(what: &str, result: vk::Result) -> Error {
    match result {
        vk::Result::ERROR_DEVICE_LOST => Error::new(
            ErrorKind::DeviceLost,
            format!(
                "{what}: the Vulkan device was lost (VK_ERROR_DEVICE_LOST); every object of this optik device is gone, open a new one"
            ),
        ),
        vk::Result::ERROR_OUT_OF_DEVICE_MEMORY => Error::new(
            ErrorKind::OutOfMemory,
            format!("{what}: the GPU is out of memory (VK_ERROR_OUT_OF_DEVICE_MEMORY)"),
        ),
        vk::Result::ERROR_OUT_OF_HOST_MEMORY => Error::new(
            ErrorKind::OutOfMemory,
            format!("{what}: the host is out of memory (VK_ERROR_OUT_OF_HOST_MEMORY)"),
        ),
        vk::Result::ERROR_TOO_MANY_OBJECTS => Error::new(
            ErrorKind::OutOfMemory,
            format!("{what}: the driver's object limit is reached (VK_ERROR_TOO_MANY_OBJECTS)"),
        ),
        other => Error::backend(format!("{what} failed: {other:?}")),
    }
}

/// `Result<T, vk::Result>` → optik's result, naming the call.
pub trait VkResultExt<T> {
    /// Maps the error with [`vk_error`].
    fn or_vk(self, what: &str) -> optik_api::Result<T>;
}

impl<T> VkResultExt<T> for Result<T, vk::Result> {
    fn or_vk(self, what: &str) -> optik_api::Result<T> {
        self.map_err(|e| vk_error(what, e))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn device_loss_and_memory_have_their_kinds() {
        assert_eq!(
            vk_error("x", vk::Result::ERROR_DEVICE_LOST).kind(),
            ErrorKind::DeviceLost
        );
        assert_eq!(
            vk_error("x", vk::Result::ERROR_OUT_OF_DEVICE_MEMORY).kind(),
            ErrorKind::OutOfMemory
        );
        assert_eq!(
            vk_error("x", vk::Result::ERROR_OUT_OF_HOST_MEMORY).kind(),
            ErrorKind::OutOfMemory
        );
        let e = vk_error("vkQueueSubmit", vk::Result::ERROR_UNKNOWN);
        assert_eq!(e.kind(), ErrorKind::Backend);
        assert!(e.message().contains("vkQueueSubmit"));
    }
}
