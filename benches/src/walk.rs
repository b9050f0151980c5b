//! optik's CPU traversal without a launch: each ray handed straight to the walk
//! (`optik_cpu::traversal::trace_blocks`) with a handler that keeps the nearest hit.
//!
//! `bench-cpu` times it beside the launch (`optik::raycast`, what users call) on the same
//! structure and rays, one thread, to split the launch's time into the walk (its ray
//! preparation, the node and leaf tests) and the launch path around it (the launch loop, the
//! compiled ray generation program, the trace entry, the closest hit): the part issue 14 item
//! 1 works on (docs/cpu-backend.md §8, "the walk alone on both machines"). The walk here is
//! the one a launch of `optik::raycast`'s pipeline runs (`traversal::nearest_triangle_hits`,
//! compiled in the backend with that pipeline's switches): the same build options, the same
//! ray flags; so it finds the same hits, which `bench-cpu` checks.

use crate::mesh::Mesh;
use optik::backends::cpu::accel::{
    BufferBytes, Gas, MicromapArrayData, MicromapLookup, SceneTable, Traversable,
};
use optik::backends::cpu::traversal;
use optik::raycast::{NO_HIT, RAY_FLOATS};
use optik::{
    AccelBuildOptions, Buffer, BufferView, BuildFlags, BuildInput, DeviceId, Error, GeometryFlags,
    Handle, MicromapArray, RawHandle, Result, TraversableHandle, TriangleArray,
};
use std::sync::Arc;
use std::time::Instant;

/// A mesh built for the walk alone, as `optik::raycast` builds it for a launch.
pub struct Walk {
    scene: SceneTable,
    root: TraversableHandle,
}

/// A pass's results, in ray order: the nearest hit's triangle ([`NO_HIT`] on a miss) and
/// distance (+inf on a miss), as `optik::raycast::Hits` gives them.
pub type WalkHits = (Vec<u32>, Vec<f32>);

impl Walk {
    /// Builds `mesh` as `optik::raycast::RayCaster` does (one triangle input without any-hit
    /// programs, `PREFER_FAST_TRACE`).
    pub fn new(mesh: &Mesh) -> Result<Walk> {
        let count = |n: usize, what: &str| {
            u32::try_from(n).map_err(|_| Error::invalid(format!("{n} {what}: at most 2^32 - 1")))
        };
        let buffers = Buffers(vec![
            mesh.positions
                .iter()
                .flatten()
                .flat_map(|x| x.to_le_bytes())
                .collect(),
            mesh.triangles
                .iter()
                .flatten()
                .flat_map(|x| x.to_le_bytes())
                .collect(),
        ]);
        let input = TriangleArray::new(
            BufferView::new(Buffers::buffer(0)),
            count(mesh.positions.len(), "vertices")?,
            GeometryFlags::DISABLE_ANYHIT,
        )
        .with_indices(
            BufferView::new(Buffers::buffer(1)),
            count(mesh.triangles.len(), "triangles")?,
        );
        let options = AccelBuildOptions {
            flags: BuildFlags::PREFER_FAST_TRACE,
            ..Default::default()
        };
        let gas = Gas::build(
            &options,
            &[BuildInput::Triangles(input)],
            &buffers,
            &buffers,
        )?;
        let mut scene = SceneTable::new(DeviceId(0));
        let root = scene.set(0, 0, Arc::new(Traversable::Geometry(gas)));
        if !traversal::nearest_triangle_hits(&scene, root, &[], &mut []) {
            return Err(Error::invalid(
                "the mesh's structure has no triangle blocks to walk",
            ));
        }
        Ok(Walk { scene, root })
    }

    /// Traces `rays` (`RAY_FLOATS` floats each, as `optik::raycast` reads them; valid rays:
    /// the launch's validity check is part of the launch path, not of the walk) one by one on
    /// this thread.
    pub fn trace(&self, rays: &[f32]) -> WalkHits {
        self.time(rays, 1).1
    }

    /// The best of `repeat` passes over `rays` ([`Walk::trace`]) in seconds, and the hits. A
    /// pass is the walk alone: the rays are unpacked and the output made before, the hits
    /// converted after.
    pub fn time(&self, rays: &[f32], repeat: usize) -> (f64, WalkHits) {
        const _: () = assert!(RAY_FLOATS == 8);
        let rays: Vec<[f32; 8]> = rays
            .chunks_exact(RAY_FLOATS)
            .map(|r| std::array::from_fn(|k| r[k]))
            .collect();
        let mut hits = vec![None; rays.len()];
        let mut best = f64::INFINITY;
        for _ in 0..repeat.max(1) {
            let start = Instant::now();
            // `new` checked that the root walks triangle blocks; nothing changes it.
            traversal::nearest_triangle_hits(
                &self.scene,
                self.root,
                std::hint::black_box(&rays),
                &mut hits,
            );
            std::hint::black_box(&hits);
            best = best.min(start.elapsed().as_secs_f64());
        }
        let hits = hits
            .iter()
            .map(|h| h.unwrap_or((NO_HIT, f32::INFINITY)))
            .unzip();
        (best, hits)
    }
}

/// The mesh's vertex and index bytes, as the build reads buffers.
struct Buffers(Vec<Vec<u8>>);

impl Buffers {
    fn buffer(slot: u32) -> Buffer {
        Buffer::from_raw(RawHandle {
            device: DeviceId(0),
            slot,
            generation: 0,
        })
    }
}

impl BufferBytes for Buffers {
    fn bytes(&self, buffer: Buffer) -> Result<&[u8]> {
        self.0
            .get(buffer.raw().slot as usize)
            .map(Vec::as_slice)
            .ok_or_else(|| Error::invalid("no such buffer"))
    }
}

impl MicromapLookup for Buffers {
    fn micromap_array(&self, _: MicromapArray) -> Result<Arc<MicromapArrayData>> {
        Err(Error::invalid("the walk alone builds no micromaps"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::BenchMesh;
    use optik::raycast::RayCaster;
    use optik::{BackendChoice, BackendKind, OpenOptions};

    /// The walk alone finds what a launch of `optik::raycast` finds, ray for ray, bit for bit:
    /// the same structure walked with the same switches. Rays from hashed points around an
    /// icosphere towards hashed points near its centre, about half of them hitting it.
    #[test]
    fn the_walk_alone_finds_what_the_launch_finds() {
        let centre = [0.25, -0.5, 3.0];
        let mesh = Mesh::icosphere(3).transformed(1.0, centre.map(f64::from));
        let mut h = 0x9E37_79B9u32;
        let mut next = || {
            h ^= h << 13;
            h ^= h >> 17;
            h ^= h << 5;
            h as f32 / u32::MAX as f32
        };
        let mut rays = Vec::new();
        for _ in 0..4000 {
            let origin: [f32; 3] = std::array::from_fn(|k| centre[k] + next() * 8.0 - 4.0);
            let aim: [f32; 3] = std::array::from_fn(|k| centre[k] + next() * 3.0 - 1.5);
            rays.extend_from_slice(&[origin[0], origin[1], origin[2], 0.0]);
            rays.extend((0..3).map(|k| aim[k] - origin[k]));
            rays.push(f32::INFINITY);
        }
        let device = optik::open_with(
            BackendChoice::Named(BackendKind::Cpu),
            &OpenOptions { threads: Some(1) },
        )
        .unwrap();
        let mut caster = RayCaster::new(device.as_ref(), &mesh.positions, &mesh.triangles).unwrap();
        let (launch, _) = caster.cast(&rays, 1).unwrap();
        let (prim, t) = Walk::new(&mesh).unwrap().trace(&rays);
        assert_eq!(prim.len(), launch.prim.len());
        let differs = (0..prim.len())
            .find(|&i| prim[i] != launch.prim[i] || t[i].to_bits() != launch.t[i].to_bits());
        if let Some(i) = differs {
            panic!(
                "ray {i}: the walk alone found triangle {} at {}, the launch {} at {}",
                prim[i], t[i], launch.prim[i], launch.t[i]
            );
        }
        let hits = prim.iter().filter(|&&p| p != NO_HIT).count();
        assert!((1000..3000).contains(&hits), "{hits} of 4000 rays hit");
    }
}
