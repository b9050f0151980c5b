//! Geometry acceleration structures: built by optik-accel (`optik_accel::Gas`: decoding,
//! which primitives can be hit, the binary BVH, the slot order) and encoded here in the GPU
//! layout of [`super::layout`].
//!
//! Triangles keep full f32 vertices (48 bytes per triangle and key), so the GPU's
//! watertight test sees exactly the vertices the user gave (no f16 edges, docs/numerics.md
//! F7). Motion geometry stores every key.

use super::bvh4::{Bvh4, NODE_VEC4S};
use super::layout::{self, HEADER_VEC4S, kind, prim};
use optik_accel::decode::BufferBytes;
use optik_accel::{Aabb, Gas, Geometry, MicromapLookup, MicromapRef, curve_caps};
use optik_api::{AccelBuildOptions, BuildFlags, BuildInput, Error, OpacityMicromapFormat, Result};

/// What an update needs: the host structure and the wide tree of the build.
#[derive(Clone, Debug)]
pub(crate) struct RefitState {
    gas: Gas,
    bvh: Bvh4,
}

/// An encoded geometry structure.
pub(crate) struct BuiltGeometry {
    pub words: Vec<[u32; 4]>,
    pub bounds: Aabb,
    pub stack_need: u32,
    /// Kept only for structures built with `ALLOW_UPDATE`.
    pub refit: Option<RefitState>,
}

/// Builds a geometry structure from validated inputs.
pub(crate) fn build(
    options: &AccelBuildOptions,
    inputs: &[BuildInput],
    bytes: &dyn BufferBytes,
    micromaps: &dyn MicromapLookup,
) -> Result<BuiltGeometry> {
    let gas = Gas::build(options, inputs, bytes, micromaps)?;
    let bvh = Bvh4::from_binary(gas.bvh.nodes());
    let words = encode(&gas, &bvh)?;
    Ok(BuiltGeometry {
        words,
        bounds: gas.bounds,
        stack_need: bvh.stack_need(|_, _| 0),
        refit: options
            .flags
            .contains(BuildFlags::ALLOW_UPDATE)
            .then_some(RefitState { gas, bvh }),
    })
}

/// Re-encodes a structure for moved geometry with the topology of its build.
pub(crate) fn update(
    options: &AccelBuildOptions,
    inputs: &[BuildInput],
    bytes: &dyn BufferBytes,
    micromaps: &dyn MicromapLookup,
    state: &RefitState,
) -> Result<BuiltGeometry> {
    let mut gas = state.gas.clone();
    gas.refit(options, inputs, bytes, micromaps)?;
    let mut bvh = state.bvh.clone();
    bvh.refit_from_binary(gas.bvh.nodes());
    let words = encode(&gas, &bvh)?;
    Ok(BuiltGeometry {
        words,
        bounds: gas.bounds,
        stack_need: bvh.stack_need(|_, _| 0),
        refit: Some(RefitState { gas, bvh }),
    })
}

fn bits3(v: [f32; 3], w: u32) -> [u32; 4] {
    [v[0].to_bits(), v[1].to_bits(), v[2].to_bits(), w]
}

/// The GPU words of a built structure.
fn encode(gas: &Gas, bvh: &Bvh4) -> Result<Vec<[u32; 4]>> {
    let keys = gas.motion.map_or(1, |m| m.num_keys as u32);
    let (prim_type, basis) = match &gas.geometry {
        Geometry::Triangles(_) => (prim::TRIANGLES, 0),
        Geometry::Custom(_) => (prim::CUSTOM, 0),
        Geometry::Spheres(_) => (prim::SPHERES, 0),
        Geometry::Curves(c) => (prim::CURVES, optik_api::wgsl::curve_basis(c.curve_type)),
    };
    // Micromap arrays the triangles use, copied in: a table of (byte offset, level, 4-state)
    // per micromap, and the states.
    let mut table: Vec<[u32; 4]> = Vec::new();
    let mut data: Vec<u8> = Vec::new();
    let mut table_base: Vec<u32> = Vec::new();
    if let Geometry::Triangles(t) = &gas.geometry
        && let Some(m) = &t.micromaps
    {
        for array in &m.arrays {
            table_base.push(table.len() as u32);
            let data_base = data.len() as u32;
            for d in &array.micromaps {
                table.push([
                    data_base + d.byte_offset,
                    d.subdivision_level as u32,
                    (d.format == OpacityMicromapFormat::FourState) as u32,
                    0,
                ]);
            }
            data.extend_from_slice(&array.data);
        }
    }
    let micromap_word = |r: MicromapRef| -> u32 {
        if r == MicromapRef::NONE {
            0
        } else if r.index < 0 {
            (-r.index) as u32
        } else {
            5 + table_base[r.array as usize] + r.index as u32
        }
    };
    let table_rel = HEADER_VEC4S as u32;
    let data_rel = table_rel + table.len() as u32;
    let data_vec4s = data.len().div_ceil(16) as u32;
    let node_rel = data_rel + data_vec4s;
    let prim_rel = node_rel + (bvh.nodes.len() * NODE_VEC4S) as u32;
    let stride = layout::slot_vec4s(prim_type, keys) as usize;
    let mut words = Vec::with_capacity(prim_rel as usize + gas.num_slots() * stride);
    words.push([
        layout::kind_word(kind::GAS, prim_type, basis),
        keys,
        node_rel,
        prim_rel,
    ]);
    words.push([
        gas.motion.map_or(0.0f32, |m| m.time_begin).to_bits(),
        gas.motion.map_or(0.0f32, |m| m.time_end).to_bits(),
        gas.motion.map_or(0, |m| m.flags.0),
        table_rel,
    ]);
    words.push([data_rel, bvh.nodes.len() as u32, 0, 0]);
    words.extend_from_slice(&table);
    data.resize(data_vec4s as usize * 16, 0);
    for chunk in data.chunks_exact(16) {
        words.push(std::array::from_fn(|i| {
            u32::from_le_bytes([
                chunk[i * 4],
                chunk[i * 4 + 1],
                chunk[i * 4 + 2],
                chunk[i * 4 + 3],
            ])
        }));
    }
    bvh.encode(&mut words);
    for (slot, info) in gas.primitives.iter().enumerate() {
        if info.sbt_gas_index > layout::MAX_GAS_INDEX {
            return Err(Error::limit(format!(
                "SBT GAS index {} exceeds this backend's limit of {}",
                info.sbt_gas_index,
                layout::MAX_GAS_INDEX
            )));
        }
        let gas_word = info.sbt_gas_index | ((info.geometry_flags & 7) << layout::GAS_INDEX_BITS);
        match &gas.geometry {
            Geometry::Triangles(t) => {
                let omm = t
                    .micromaps
                    .as_ref()
                    .map_or(0, |m| micromap_word(m.refs[slot]));
                for key in &t.keys {
                    let [v0, v1, v2] = key[slot];
                    words.push(bits3(v0, info.primitive_index));
                    words.push(bits3(v1, gas_word));
                    words.push(bits3(v2, omm));
                }
            }
            Geometry::Custom(c) => {
                words.push([info.primitive_index, gas_word, 0, 0]);
                for key in &c.keys {
                    words.push(bits3(key[slot].min, 0));
                    words.push(bits3(key[slot].max, 0));
                }
            }
            Geometry::Spheres(s) => {
                words.push([info.primitive_index, gas_word, 0, 0]);
                for key in &s.keys {
                    words.push(key[slot].map(f32::to_bits));
                }
            }
            Geometry::Curves(c) => {
                // The kernel reads bit 0 / bit 1 as "round cap at the start / end".
                let open = c.caps[slot];
                let caps = (open & curve_caps::OPEN_START == 0) as u32
                    | (((open & curve_caps::OPEN_END == 0) as u32) << 1);
                words.push([info.primitive_index, gas_word, caps, 0]);
                for key in &c.keys {
                    for point in key[slot] {
                        words.push(point.map(f32::to_bits));
                    }
                }
            }
        }
    }
    Ok(words)
}
