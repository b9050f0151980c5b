//! Launch resources and textures.
//!
//! A launch binds the user's `@group(0)` resources by number: binding 0 is the launch
//! parameters (`var<uniform> params`), given as bytes; bindings from 1 up are the buffers,
//! textures and samplers listed here.

use crate::handle::{Buffer, Texture};

mod cancel;

pub use cancel::{
    CancelToken, LaunchOptions, LaunchWatch, clear_interrupt, interrupt_launches,
    launches_interrupted,
};

/// Texel formats of textures.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum TextureFormat {
    /// 8-bit RGBA, normalised to [0, 1] when sampled.
    Rgba8Unorm,
    /// 32-bit float RGBA.
    Rgba32Float,
    /// One 32-bit float channel.
    R32Float,
}

impl TextureFormat {
    /// Bytes per texel.
    pub fn texel_size(self) -> u32 {
        match self {
            TextureFormat::Rgba8Unorm => 4,
            TextureFormat::Rgba32Float => 16,
            TextureFormat::R32Float => 4,
        }
    }
}

/// A 2D texture to create.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct TextureDesc {
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// Texel format.
    pub format: TextureFormat,
}

/// Texture filtering.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum FilterMode {
    /// Nearest texel.
    #[default]
    Nearest,
    /// Bilinear.
    Linear,
}

/// Texture addressing outside [0, 1].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum AddressMode {
    /// Clamp to the edge texel.
    #[default]
    ClampToEdge,
    /// Wrap around.
    Repeat,
}

/// A sampler bound at launch.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub struct SamplerDesc {
    /// Filtering for magnification and minification.
    pub filter: FilterMode,
    /// Addressing in u and v.
    pub address_mode: AddressMode,
}

/// A resource bound to a `@group(0) @binding(n)` variable (n ≥ 1) at launch.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Resource {
    /// A storage buffer, from `offset` for `size` bytes (`None`: to the end).
    Buffer {
        /// The binding number.
        binding: u32,
        /// The buffer.
        buffer: Buffer,
        /// First byte bound (a multiple of 256 for portability across backends).
        offset: u64,
        /// Bytes bound; `None` binds to the end of the buffer.
        size: Option<u64>,
    },
    /// A 2D texture.
    Texture {
        /// The binding number.
        binding: u32,
        /// The texture.
        texture: Texture,
    },
    /// A sampler.
    Sampler {
        /// The binding number.
        binding: u32,
        /// How it samples.
        sampler: SamplerDesc,
    },
}

impl Resource {
    /// A whole buffer at `binding`.
    pub fn buffer(binding: u32, buffer: Buffer) -> Self {
        Resource::Buffer {
            binding,
            buffer,
            offset: 0,
            size: None,
        }
    }

    /// The binding number.
    pub fn binding(&self) -> u32 {
        match self {
            Resource::Buffer { binding, .. }
            | Resource::Texture { binding, .. }
            | Resource::Sampler { binding, .. } => *binding,
        }
    }
}

/// Launch dimensions (OptiX `optixLaunch`'s width, height, depth).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct LaunchSize {
    /// Width.
    pub width: u32,
    /// Height.
    pub height: u32,
    /// Depth.
    pub depth: u32,
}

impl LaunchSize {
    /// A width × height × depth launch.
    pub fn new(width: u32, height: u32, depth: u32) -> Self {
        Self {
            width,
            height,
            depth,
        }
    }

    /// Total invocations.
    pub fn count(&self) -> u64 {
        self.width as u64 * self.height as u64 * self.depth as u64
    }

    /// Whether the launch runs nothing (any dimension zero): a no-op, not an error.
    pub fn is_empty(&self) -> bool {
        self.count() == 0
    }
}
