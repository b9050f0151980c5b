//! Command buffers: one-shot work the host waits for (uploads, builds, copies), and launches
//! that run while the host goes on.

use crate::context::Context;
use crate::error::VkResultExt;
use ash::vk;
use optik_api::Result;

/// The device's command pool.
pub struct Commands {
    pool: vk::CommandPool,
}

/// Submitted work: its fence signals when it is done.
pub struct Submission {
    /// Signalled on completion.
    pub fence: vk::Fence,
    cmd: vk::CommandBuffer,
}

impl Commands {
    /// A pool on the device's queue family.
    pub fn new(ctx: &Context) -> Result<Commands> {
        let info = vk::CommandPoolCreateInfo::default()
            .queue_family_index(ctx.queue_family)
            .flags(
                vk::CommandPoolCreateFlags::TRANSIENT
                    | vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER,
            );
        // SAFETY: valid create info; destroyed in `destroy`.
        let pool =
            unsafe { ctx.device.create_command_pool(&info, None) }.or_vk("vkCreateCommandPool")?;
        Ok(Commands { pool })
    }

    /// Records with `record`, submits, and returns without waiting.
    pub fn submit(
        &self,
        ctx: &Context,
        record: impl FnOnce(vk::CommandBuffer) -> Result<()>,
    ) -> Result<Submission> {
        let info = vk::CommandBufferAllocateInfo::default()
            .command_pool(self.pool)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(1);
        // SAFETY: the pool is used under the device's lock only.
        let cmd = unsafe { ctx.device.allocate_command_buffers(&info) }
            .or_vk("vkAllocateCommandBuffers")?[0];
        let result = (|| {
            let begin = vk::CommandBufferBeginInfo::default()
                .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT);
            // SAFETY: a fresh command buffer.
            unsafe { ctx.device.begin_command_buffer(cmd, &begin) }
                .or_vk("vkBeginCommandBuffer")?;
            // Earlier work (launches, builds) finishes its writes before this work starts.
            full_barrier(ctx, cmd);
            record(cmd)?;
            // The host sees this work's writes once the fence signals.
            let barrier = vk::MemoryBarrier::default()
                .src_access_mask(vk::AccessFlags::MEMORY_WRITE)
                .dst_access_mask(vk::AccessFlags::HOST_READ | vk::AccessFlags::HOST_WRITE);
            // SAFETY: recording.
            unsafe {
                ctx.device.cmd_pipeline_barrier(
                    cmd,
                    vk::PipelineStageFlags::ALL_COMMANDS,
                    vk::PipelineStageFlags::HOST,
                    vk::DependencyFlags::empty(),
                    &[barrier],
                    &[],
                    &[],
                );
                ctx.device.end_command_buffer(cmd)
            }
            .or_vk("vkEndCommandBuffer")?;
            // SAFETY: valid create info.
            let fence = unsafe {
                ctx.device
                    .create_fence(&vk::FenceCreateInfo::default(), None)
            }
            .or_vk("vkCreateFence")?;
            let cmds = [cmd];
            let submit = vk::SubmitInfo::default().command_buffers(&cmds);
            // SAFETY: the queue is used under the device's lock only.
            if let Err(e) = unsafe { ctx.device.queue_submit(ctx.queue, &[submit], fence) } {
                // SAFETY: never submitted.
                unsafe { ctx.device.destroy_fence(fence, None) };
                return Err(crate::error::vk_error("vkQueueSubmit", e));
            }
            Ok(fence)
        })();
        match result {
            Ok(fence) => Ok(Submission { fence, cmd }),
            Err(e) => {
                // SAFETY: not pending.
                unsafe { ctx.device.free_command_buffers(self.pool, &[cmd]) };
                Err(e)
            }
        }
    }

    /// Records, submits and waits.
    pub fn run(
        &self,
        ctx: &Context,
        record: impl FnOnce(vk::CommandBuffer) -> Result<()>,
    ) -> Result<()> {
        let s = self.submit(ctx, record)?;
        let waited = self.wait(ctx, &s);
        self.release(ctx, s);
        waited
    }

    /// Waits for a submission.
    pub fn wait(&self, ctx: &Context, s: &Submission) -> Result<()> {
        // SAFETY: a fence of this device.
        unsafe { ctx.device.wait_for_fences(&[s.fence], true, u64::MAX) }.or_vk("vkWaitForFences")
    }

    /// Waits up to `timeout` for a submission; whether it is done.
    pub fn wait_for(
        &self,
        ctx: &Context,
        s: &Submission,
        timeout: std::time::Duration,
    ) -> Result<bool> {
        let nanos = u64::try_from(timeout.as_nanos()).unwrap_or(u64::MAX);
        // SAFETY: a fence of this device.
        match unsafe { ctx.device.wait_for_fences(&[s.fence], true, nanos) } {
            Ok(()) => Ok(true),
            Err(vk::Result::TIMEOUT) => Ok(false),
            Err(e) => Err(crate::error::vk_error("vkWaitForFences", e)),
        }
    }

    /// Whether a submission is done.
    pub fn is_done(&self, ctx: &Context, s: &Submission) -> Result<bool> {
        // SAFETY: a fence of this device.
        unsafe { ctx.device.get_fence_status(s.fence) }.or_vk("vkGetFenceStatus")
    }

    /// Frees a finished (or failed) submission.
    pub fn release(&self, ctx: &Context, s: Submission) {
        // SAFETY: the work is done, or the device is lost and nothing will run.
        unsafe {
            ctx.device.destroy_fence(s.fence, None);
            ctx.device.free_command_buffers(self.pool, &[s.cmd]);
        }
    }

    /// Frees the pool.
    pub fn destroy(&self, ctx: &Context) {
        // SAFETY: the device is idle.
        unsafe { ctx.device.destroy_command_pool(self.pool, None) };
    }
}

/// Makes every earlier write visible to every later access.
pub fn full_barrier(ctx: &Context, cmd: vk::CommandBuffer) {
    let barrier = vk::MemoryBarrier::default()
        .src_access_mask(vk::AccessFlags::MEMORY_WRITE)
        .dst_access_mask(vk::AccessFlags::MEMORY_READ | vk::AccessFlags::MEMORY_WRITE);
    // SAFETY: recording.
    unsafe {
        ctx.device.cmd_pipeline_barrier(
            cmd,
            vk::PipelineStageFlags::ALL_COMMANDS,
            vk::PipelineStageFlags::ALL_COMMANDS,
            vk::DependencyFlags::empty(),
            &[barrier],
            &[],
            &[],
        )
    };
}
