//! Textures and samplers bound to programs' `texture_2d<f32>` and `sampler` variables.

use crate::device::Inner;
use crate::error::VkResultExt;
use ash::vk;
use optik_api::{AddressMode, Error, FilterMode, Result, SamplerDesc, TextureDesc, TextureFormat};

/// A 2D image in shader-read layout, with its own memory.
pub struct TextureObject {
    /// The image.
    pub image: vk::Image,
    /// Its view.
    pub view: vk::ImageView,
    memory: vk::DeviceMemory,
    /// Its size and format.
    pub desc: TextureDesc,
}

impl TextureObject {
    /// Frees the image, view and memory.
    pub fn destroy(self, ctx: &crate::context::Context, _alloc: &mut crate::memory::Allocator) {
        // SAFETY: no pending work uses the texture (callers wait first).
        unsafe {
            ctx.device.destroy_image_view(self.view, None);
            ctx.device.destroy_image(self.image, None);
            ctx.device.free_memory(self.memory, None);
        }
    }
}

fn vk_format(f: TextureFormat) -> vk::Format {
    match f {
        TextureFormat::Rgba8Unorm => vk::Format::R8G8B8A8_UNORM,
        TextureFormat::Rgba32Float => vk::Format::R32G32B32A32_SFLOAT,
        TextureFormat::R32Float => vk::Format::R32_SFLOAT,
    }
}

fn color_range() -> vk::ImageSubresourceRange {
    vk::ImageSubresourceRange::default()
        .aspect_mask(vk::ImageAspectFlags::COLOR)
        .level_count(1)
        .layer_count(1)
}

/// Records a layout transition of a whole colour image.
fn transition(
    device: &ash::Device,
    cmd: vk::CommandBuffer,
    image: vk::Image,
    from: vk::ImageLayout,
    to: vk::ImageLayout,
) {
    let barrier = vk::ImageMemoryBarrier::default()
        .src_access_mask(vk::AccessFlags::MEMORY_WRITE)
        .dst_access_mask(vk::AccessFlags::MEMORY_READ | vk::AccessFlags::MEMORY_WRITE)
        .old_layout(from)
        .new_layout(to)
        .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .image(image)
        .subresource_range(color_range());
    // SAFETY: recording.
    unsafe {
        device.cmd_pipeline_barrier(
            cmd,
            vk::PipelineStageFlags::ALL_COMMANDS,
            vk::PipelineStageFlags::ALL_COMMANDS,
            vk::DependencyFlags::empty(),
            &[],
            &[],
            &[barrier],
        )
    };
}

impl Inner {
    pub fn create_texture(&mut self, desc: &TextureDesc) -> Result<TextureObject> {
        let format = vk_format(desc.format);
        let ctx = self.ctx.clone();
        let info = vk::ImageCreateInfo::default()
            .image_type(vk::ImageType::TYPE_2D)
            .format(format)
            .extent(vk::Extent3D {
                width: desc.width,
                height: desc.height,
                depth: 1,
            })
            .mip_levels(1)
            .array_layers(1)
            .samples(vk::SampleCountFlags::TYPE_1)
            .tiling(vk::ImageTiling::OPTIMAL)
            .usage(vk::ImageUsageFlags::SAMPLED | vk::ImageUsageFlags::TRANSFER_DST)
            .initial_layout(vk::ImageLayout::UNDEFINED);
        // SAFETY: valid create info; destroyed with the texture.
        let image = unsafe { ctx.device.create_image(&info, None) }.or_vk("vkCreateImage")?;
        // SAFETY: valid image.
        let req = unsafe { ctx.device.get_image_memory_requirements(image) };
        let Some(type_index) = ctx.memory_type(
            req.memory_type_bits,
            vk::MemoryPropertyFlags::empty(),
            vk::MemoryPropertyFlags::DEVICE_LOCAL,
            vk::MemoryPropertyFlags::empty(),
        ) else {
            // SAFETY: unused image.
            unsafe { ctx.device.destroy_image(image, None) };
            return Err(Error::backend("no memory type fits a texture"));
        };
        let alloc = vk::MemoryAllocateInfo::default()
            .allocation_size(req.size)
            .memory_type_index(type_index);
        // SAFETY: valid allocate info.
        let memory = match unsafe { ctx.device.allocate_memory(&alloc, None) } {
            Ok(m) => m,
            Err(e) => {
                // SAFETY: unused image.
                unsafe { ctx.device.destroy_image(image, None) };
                return Err(crate::error::vk_error("vkAllocateMemory (texture)", e));
            }
        };
        let view = (|| {
            // SAFETY: memory of a fitting type.
            unsafe { ctx.device.bind_image_memory(image, memory, 0) }.or_vk("vkBindImageMemory")?;
            let view_info = vk::ImageViewCreateInfo::default()
                .image(image)
                .view_type(vk::ImageViewType::TYPE_2D)
                .format(format)
                .subresource_range(color_range());
            // SAFETY: valid image with bound memory.
            unsafe { ctx.device.create_image_view(&view_info, None) }.or_vk("vkCreateImageView")
        })();
        let view = match view {
            Ok(v) => v,
            Err(e) => {
                // SAFETY: unused objects.
                unsafe {
                    ctx.device.destroy_image(image, None);
                    ctx.device.free_memory(memory, None);
                }
                return Err(e);
            }
        };
        let obj = TextureObject {
            image,
            view,
            memory,
            desc: *desc,
        };
        // Zero-filled, then in the layout programs sample it in.
        let cleared = self.run_commands(|cmd| {
            transition(
                &ctx.device,
                cmd,
                image,
                vk::ImageLayout::UNDEFINED,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
            );
            let clear = vk::ClearColorValue { float32: [0.0; 4] };
            // SAFETY: recording; the image is in TRANSFER_DST layout.
            unsafe {
                ctx.device.cmd_clear_color_image(
                    cmd,
                    image,
                    vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                    &clear,
                    &[color_range()],
                )
            };
            transition(
                &ctx.device,
                cmd,
                image,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
            );
            Ok(())
        });
        if let Err(e) = cleared {
            obj.destroy(&ctx, &mut self.alloc);
            return Err(e);
        }
        Ok(obj)
    }

    pub fn write_texture(&mut self, texture: &TextureObject, data: &[u8]) -> Result<()> {
        let (image, desc) = (texture.image, texture.desc);
        self.wait_launches()?;
        self.upload_with(data, |device, cmd, src| {
            transition(
                device,
                cmd,
                image,
                vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
            );
            let region = vk::BufferImageCopy::default()
                .image_subresource(
                    vk::ImageSubresourceLayers::default()
                        .aspect_mask(vk::ImageAspectFlags::COLOR)
                        .layer_count(1),
                )
                .image_extent(vk::Extent3D {
                    width: desc.width,
                    height: desc.height,
                    depth: 1,
                });
            // SAFETY: recording; the staging buffer holds the whole image.
            unsafe {
                device.cmd_copy_buffer_to_image(
                    cmd,
                    src,
                    image,
                    vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                    &[region],
                )
            };
            transition(
                device,
                cmd,
                image,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
            );
        })
    }

    /// The sampler for `desc`, created once.
    pub fn sampler(&mut self, desc: SamplerDesc) -> Result<vk::Sampler> {
        if let Some(s) = self.samplers.get(&desc) {
            return Ok(*s);
        }
        let filter = match desc.filter {
            FilterMode::Nearest => vk::Filter::NEAREST,
            FilterMode::Linear => vk::Filter::LINEAR,
        };
        let address = match desc.address_mode {
            AddressMode::ClampToEdge => vk::SamplerAddressMode::CLAMP_TO_EDGE,
            AddressMode::Repeat => vk::SamplerAddressMode::REPEAT,
        };
        let info = vk::SamplerCreateInfo::default()
            .mag_filter(filter)
            .min_filter(filter)
            .mipmap_mode(vk::SamplerMipmapMode::NEAREST)
            .address_mode_u(address)
            .address_mode_v(address)
            .address_mode_w(address)
            .max_lod(0.0);
        // SAFETY: valid create info; destroyed with the device.
        let s = unsafe { self.ctx.device.create_sampler(&info, None) }.or_vk("vkCreateSampler")?;
        self.samplers.insert(desc, s);
        Ok(s)
    }
}
