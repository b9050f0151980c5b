//! Meshes on the device: every mesh's positions, normals, texture coordinates and triangles
//! concatenated into four storage buffers, and one geometry acceleration structure with one
//! build input (so one SBT record) per mesh: the layout of the course's ex06 and later, where
//! the hit record of mesh *i* says where mesh *i*'s data starts.

use crate::common::{Result, upload};
use crate::scenes::TriangleMesh;
use optik::{
    Accel, AccelBuildOptions, Buffer, BufferView, BuildFlags, BuildInput, Device, GeometryFlags,
    Resource, TraversableHandle, TriangleArray,
};

/// Where one mesh's data starts in the shared buffers, for its hit record.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MeshOffsets {
    /// First vertex (position, normal and texture coordinate index).
    pub first_vertex: u32,
    /// First triangle.
    pub first_triangle: u32,
    /// Whether the mesh has shading normals.
    pub has_normals: bool,
    /// Whether the mesh has texture coordinates.
    pub has_texcoords: bool,
}

/// The meshes' buffers and acceleration structure.
pub struct DeviceMeshes {
    /// Positions, 3 × f32 per vertex.
    pub positions: Buffer,
    /// Triangles, 3 × u32 each, relative to their mesh's first vertex.
    pub indices: Buffer,
    /// Shading normals, 3 × f32 per vertex (zeros for meshes without).
    pub normals: Buffer,
    /// Texture coordinates, 2 × f32 per vertex (zeros for meshes without).
    pub texcoords: Buffer,
    /// Per mesh, where its data starts.
    pub offsets: Vec<MeshOffsets>,
    /// The geometry acceleration structure (compacted).
    pub gas: Accel,
    /// Its traversable handle.
    pub handle: TraversableHandle,
}

impl DeviceMeshes {
    /// Binds positions, indices, normals and texture coordinates at `first`, `first + 1`, ...
    pub fn resources(&self, first: u32) -> [Resource; 4] {
        [
            Resource::buffer(first, self.positions),
            Resource::buffer(first + 1, self.indices),
            Resource::buffer(first + 2, self.normals),
            Resource::buffer(first + 3, self.texcoords),
        ]
    }
}

/// Uploads `meshes` and builds their acceleration structure, one build input per mesh. Any-hit
/// is disabled on every input, as the course does (no mesh is alpha-tested).
pub fn upload_meshes(device: &dyn Device, meshes: &[TriangleMesh]) -> Result<DeviceMeshes> {
    let (mut positions, mut normals, mut texcoords) = (Vec::<f32>::new(), Vec::new(), Vec::new());
    let mut indices = Vec::<u32>::new();
    let mut offsets = Vec::new();
    for m in meshes {
        let n = m.positions.len();
        let has_normals = m.normals.len() == n;
        let has_texcoords = m.texcoords.len() == n;
        if let Some(bad) = m.indices.iter().flatten().find(|&&i| i as usize >= n) {
            return Err(format!("a mesh names vertex {bad} but has only {n} vertices").into());
        }
        offsets.push(MeshOffsets {
            first_vertex: (positions.len() / 3) as u32,
            first_triangle: (indices.len() / 3) as u32,
            has_normals,
            has_texcoords,
        });
        positions.extend(m.positions.iter().flatten());
        if has_normals {
            normals.extend(m.normals.iter().flatten());
        } else {
            normals.extend(std::iter::repeat_n(0.0f32, 3 * n));
        }
        if has_texcoords {
            texcoords.extend(m.texcoords.iter().flatten());
        } else {
            texcoords.extend(std::iter::repeat_n(0.0f32, 2 * n));
        }
        indices.extend(m.indices.iter().flatten());
    }
    let positions_buffer = upload(device, &positions)?;
    let indices_buffer = upload(device, &indices)?;
    let inputs: Vec<BuildInput> = meshes
        .iter()
        .zip(&offsets)
        .map(|(m, o)| {
            BuildInput::Triangles(
                TriangleArray::new(
                    BufferView::at(positions_buffer, 12 * o.first_vertex as u64),
                    m.positions.len() as u32,
                    GeometryFlags::DISABLE_ANYHIT,
                )
                .with_indices(
                    BufferView::at(indices_buffer, 12 * o.first_triangle as u64),
                    m.indices.len() as u32,
                ),
            )
        })
        .collect();
    let build = AccelBuildOptions {
        flags: BuildFlags::ALLOW_COMPACTION,
        ..Default::default()
    };
    let gas = device.accel_build(&build, &inputs)?;
    let gas = device.accel_compact(gas)?;
    Ok(DeviceMeshes {
        positions: positions_buffer,
        indices: indices_buffer,
        normals: upload(device, &normals)?,
        texcoords: upload(device, &texcoords)?,
        offsets,
        handle: device.traversable_handle(gas)?,
        gas,
    })
}

/// Texture slots `surface.wgsl` declares (bindings 7 to 10).
pub const TEXTURE_SLOTS: usize = 4;

/// The hit record data `surface.wgsl` reads for each mesh: diffuse colour, first vertex,
/// first triangle, flags (1: normals, 2: texture coordinates) and texture slot.
pub fn surface_data(meshes: &[TriangleMesh], device_meshes: &DeviceMeshes) -> Vec<Vec<u32>> {
    meshes
        .iter()
        .zip(&device_meshes.offsets)
        .map(|(m, o)| {
            let [r, g, b] = m.diffuse.map(f32::to_bits);
            let flags = o.has_normals as u32 | (o.has_texcoords as u32) << 1;
            vec![
                r,
                g,
                b,
                o.first_vertex,
                o.first_triangle,
                flags,
                m.texture.unwrap_or(u32::MAX),
            ]
        })
        .collect()
}

/// Creates the model's textures and binds them with a bilinear, repeating sampler: the
/// sampler at binding 6, textures at 7 to 10 (unused slots get a 1×1 white texture, since
/// every declared binding needs a resource).
pub fn texture_resources(
    device: &dyn Device,
    textures: &[crate::scenes::TextureImage],
) -> Result<Vec<Resource>> {
    if textures.len() > TEXTURE_SLOTS {
        return Err(format!(
            "the model has {} textures; these examples bind at most {TEXTURE_SLOTS}",
            textures.len()
        )
        .into());
    }
    let white = crate::scenes::TextureImage {
        width: 1,
        height: 1,
        rgba: vec![[255; 4]],
    };
    let mut out = vec![Resource::Sampler {
        binding: 6,
        sampler: optik::SamplerDesc {
            filter: optik::FilterMode::Linear,
            address_mode: optik::AddressMode::Repeat,
        },
    }];
    for slot in 0..TEXTURE_SLOTS {
        let t = textures.get(slot).unwrap_or(&white);
        let texture = device.create_texture(&optik::TextureDesc {
            width: t.width,
            height: t.height,
            format: optik::TextureFormat::Rgba8Unorm,
        })?;
        device.write_texture(texture, bytemuck::cast_slice(&t.rgba))?;
        out.push(Resource::Texture {
            binding: 7 + slot as u32,
            texture,
        });
    }
    Ok(out)
}
