//! Whether a device's own triangle test (`TriangleTest::Driver`, the Vulkan driver's native
//! triangles) is watertight on the rays where tests usually fail: optik's check, run once per
//! driver build and cached.
//!
//! With the driver's triangles the check traces rays that no watertight test lets out of a
//! closed mesh: from points inside closed icospheres (5 120 triangles, edges shared exactly)
//! at three scales and at two places far from the origin, aimed exactly at every vertex and
//! every edge midpoint (so through shared edges and vertices); from near the surface too, so
//! rays graze the faces around the point they aim at; and from the centre along the axes with
//! every sign of zero in the other components. Each ray counts the triangles the driver
//! reports along it (an any-hit program that counts and ignores each candidate): a ray from
//! inside a closed convex mesh crosses it exactly once, so none is a leak and two or more an
//! edge or vertex claimed twice (which breaks OptiX's one any-hit per crossing, and the
//! conformance suite's closed-mesh cases). The driver passes when every ray meets exactly one.
//!
//! A pass is evidence about one driver build, not a guarantee: the check is cached under
//! [`DeviceProperties::device_name`](crate::DeviceProperties) and
//! [`DeviceProperties::driver`](crate::DeviceProperties) (with optik's version), in
//! `driver-triangles.tsv` of the cache folder ([`crate::cache`]), so a driver update runs it
//! again. What optik does with the answer is in docs/vulkan-backend.md ("The driver's
//! triangles").

use crate::{
    AccelBuildOptions, Accuracy, BufferView, BuildInput, Device, GeometryFlags, LaunchSize,
    ModuleCompileOptions, PipelineCompileOptions, PipelineLinkOptions, ProgramGroupDesc,
    ProgramRef, ProgramSource, Resource, Result, ShaderBindingTable, TriangleArray, TriangleTest,
    shapes,
};
use std::io::Write;

/// The outcome of [`check_driver_triangles`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TriangleCheck {
    /// Whether every ray met exactly one triangle.
    pub passed: bool,
    /// Rays traced.
    pub rays: u64,
    /// Rays that met no triangle of a closed mesh from inside it.
    pub leaks: u64,
    /// Rays that met two or more triangles where they share an edge or a vertex.
    pub doubles: u64,
    /// Whether the answer was read from the cache (made by an earlier run on this driver).
    pub cached: bool,
}

impl std::fmt::Display for TriangleCheck {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let verdict = if self.passed { "passed" } else { "failed" };
        write!(
            f,
            "{verdict}: of {} rays through shared edges and vertices of closed meshes, {} leaked and {} met two triangles or more{}",
            self.rays,
            self.leaks,
            self.doubles,
            if self.cached { " (cached)" } else { "" }
        )
    }
}

/// The closed meshes: (scale, offset) of the unit icosphere.
const PLACES: [(f64, [f64; 3]); 5] = [
    (1.0, [0.0, 0.0, 0.0]),
    (1e-3, [0.0, 0.0, 0.0]),
    (1e3, [0.0, 0.0, 0.0]),
    (1.0, [1e5, -1e5, 1e5]),
    (1.0, [-3072.5, 700.25, 5000.125]),
];

/// Subdivisions of the icosphere (5 120 triangles).
const SUBDIVISIONS: u32 = 4;

/// Cache file in the cache folder.
const CACHE_FILE: &str = "driver-triangles.tsv";

/// Runs (or reads from the cache) the check of `device`'s own triangle test. The device's
/// accuracy is set to `TriangleTest::Driver` for the check and set back afterwards, so it
/// must hold no triangle structures (the Vulkan backend refuses to switch while any live);
/// backends without a triangle test of their own refuse it (`Unsupported`).
pub fn check_driver_triangles(device: &dyn Device) -> Result<TriangleCheck> {
    let props = device.properties();
    let key = format!(
        "{} | {} | optik {}",
        props.device_name,
        props.driver,
        env!("CARGO_PKG_VERSION")
    )
    .replace(['\t', '\n'], " ");
    if let Some(found) = remembered(&key).or_else(|| cached(&key)) {
        remember(&key, &found);
        return Ok(found);
    }
    let saved = device.accuracy();
    device.set_accuracy(Accuracy {
        triangle: TriangleTest::Driver,
        ..saved
    })?;
    let traced = trace_all(device);
    // The structures are gone: the accuracy can go back whatever happened.
    let restored = device.set_accuracy(saved);
    let (rays, leaks, doubles) = traced?;
    restored?;
    let result = TriangleCheck {
        passed: leaks == 0 && doubles == 0,
        rays,
        leaks,
        doubles,
        cached: false,
    };
    store(&key, &result);
    remember(&key, &result);
    Ok(result)
}

/// Answers of this process (every `optik::open` of a Vulkan device asks, and the disk cache
/// may be off), by key.
static ANSWERS: std::sync::Mutex<Vec<(String, TriangleCheck)>> = std::sync::Mutex::new(Vec::new());

/// This process's answer for `key`, if it has one.
fn remembered(key: &str) -> Option<TriangleCheck> {
    let answers = ANSWERS.lock().unwrap_or_else(|p| p.into_inner());
    answers
        .iter()
        .find(|(k, _)| k == key)
        .map(|(_, c)| TriangleCheck {
            cached: true,
            ..c.clone()
        })
}

/// Keeps `result` for this process.
fn remember(key: &str, result: &TriangleCheck) {
    let mut answers = ANSWERS.lock().unwrap_or_else(|p| p.into_inner());
    if !answers.iter().any(|(k, _)| k == key) {
        answers.push((key.to_string(), result.clone()));
    }
}

/// Every ray set of the check: (rays, leaks, doubles).
fn trace_all(device: &dyn Device) -> Result<(u64, u64, u64)> {
    let (unit_positions, triangles) = shapes::icosphere(SUBDIVISIONS);
    let (mut rays, mut leaks, mut doubles) = (0u64, 0u64, 0u64);
    for (scale, offset) in PLACES {
        let at = |p: [f64; 3]| -> [f32; 3] {
            std::array::from_fn(|k| (offset[k] + scale * p[k]) as f32)
        };
        let positions: Vec<[f32; 3]> = unit_positions
            .iter()
            .map(|p| at([p[0] as f64, p[1] as f64, p[2] as f64]))
            .collect();
        // Near the centre, and near the surface (0.97 of the way to a vertex), whose rays
        // to nearby vertices and edges graze the faces around them.
        let v = unit_positions[0];
        let insides = [
            at([0.0123, -0.0311, 0.0217]),
            at([0.97 * v[0] as f64, 0.97 * v[1] as f64, 0.97 * v[2] as f64]),
        ];
        let mut set = Vec::new();
        for inside in insides {
            set.extend(shapes::rays_at_vertices_and_edges(
                &positions, &triangles, inside,
            ));
        }
        if scale == 1.0 && offset == [0.0; 3] {
            set.extend(signed_zero_rays());
        }
        let counts = count_crossings(device, &positions, &triangles, &set)?;
        rays += counts.len() as u64;
        leaks += counts.iter().filter(|&&c| c == 0).count() as u64;
        doubles += counts.iter().filter(|&&c| c > 1).count() as u64;
    }
    Ok((rays, leaks, doubles))
}

/// Counts the triangles the device reports along each ray: every candidate runs an
/// any-hit program that counts it and ignores it, so the ray goes on to its end
/// (`REQUIRE_SINGLE_ANYHIT_CALL`: one call per triangle).
const COUNTING: &str = r#"
struct Params { scene: vec2<u32>, count: u32, width: u32 }
@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> rays: array<f32>;
@group(0) @binding(2) var<storage, read_write> counts: array<u32>;

fn raygen__count() {
    let id = rt_launch_index();
    let i = id.y * params.width + id.x;
    if i >= params.count { return; }
    let b = i * 8u;
    var p: RtPayload;
    p[0] = 0u;
    rt_trace(params.scene, vec3<f32>(rays[b], rays[b + 1u], rays[b + 2u]),
             vec3<f32>(rays[b + 4u], rays[b + 5u], rays[b + 6u]), rays[b + 3u], rays[b + 7u],
             0.0, 0xFFu, 0u, 0u, 1u, 0u, &p);
    counts[i] = p[0];
}

fn anyhit__count() {
    rt_set_payload(0u, rt_get_payload(0u) + 1u);
    rt_ignore_intersection();
}

fn miss__none() {
}
"#;

/// Rays per launch row.
const WIDTH: u32 = 4096;

/// The number of triangles of the mesh each ray of `rays` (origin, tmin, direction, tmax)
/// meets, traced on `device` with its current accuracy.
fn count_crossings(
    device: &dyn Device,
    positions: &[[f32; 3]],
    triangles: &[[u32; 3]],
    rays: &[f32],
) -> Result<Vec<u32>> {
    let n = (rays.len() / 8) as u32;
    let mut buffers = Vec::new();
    let mut accel = None;
    let mut pipeline = None;
    let result = (|| -> Result<Vec<u32>> {
        let mut upload = |bytes: Vec<u8>| -> Result<crate::Buffer> {
            let b = device.create_buffer(bytes.len().max(4) as u64)?;
            buffers.push(b);
            device.write_buffer(b, 0, &bytes)?;
            Ok(b)
        };
        let words = |v: &mut dyn Iterator<Item = u32>| -> Vec<u8> {
            v.flat_map(u32::to_le_bytes).collect()
        };
        let vertices = upload(words(&mut positions.iter().flatten().map(|c| c.to_bits())))?;
        let indices = upload(words(&mut triangles.iter().flatten().copied()))?;
        let input = TriangleArray::new(
            BufferView::new(vertices),
            positions.len() as u32,
            GeometryFlags::REQUIRE_SINGLE_ANYHIT_CALL,
        )
        .with_indices(BufferView::new(indices), triangles.len() as u32);
        let gas = device.accel_build(
            &AccelBuildOptions::default(),
            &[BuildInput::Triangles(input)],
        )?;
        accel = Some(gas);
        let handle = device.traversable_handle(gas)?.to_words();
        let options = PipelineCompileOptions::default();
        let (module, _) = device.create_module(
            &ModuleCompileOptions::default(),
            &options,
            &ProgramSource::new("triangle_check.wgsl", COUNTING),
        )?;
        let groups = device.create_program_groups(&[
            ProgramGroupDesc::Raygen(ProgramRef::new(module, "raygen__count")),
            ProgramGroupDesc::Miss(Some(ProgramRef::new(module, "miss__none"))),
            ProgramGroupDesc::HitGroup {
                closest_hit: None,
                any_hit: Some(ProgramRef::new(module, "anyhit__count")),
                intersection: None,
                builtin: crate::BuiltinIntersector::Triangle,
            },
        ])?;
        let p = device.create_pipeline(&options, &PipelineLinkOptions::default(), &groups)?;
        pipeline = Some(p);
        let mut table = Vec::new();
        for g in &groups {
            table.extend_from_slice(&device.sbt_record_pack_header(*g)?);
        }
        let sbt = ShaderBindingTable::raygen_miss_hit(upload(table)?);
        let ray_buffer = upload(rays.iter().flat_map(|r| r.to_le_bytes()).collect())?;
        let count_buffer = upload(vec![0; 4 * n as usize])?;
        let params = words(&mut [handle[0], handle[1], n, WIDTH].into_iter());
        device.launch(
            p,
            &params,
            &[
                Resource::buffer(1, ray_buffer),
                Resource::buffer(2, count_buffer),
            ],
            &sbt,
            LaunchSize::new(WIDTH.min(n), n.div_ceil(WIDTH), 1),
        )?;
        device.synchronize()?;
        let mut raw = vec![0u8; 4 * n as usize];
        device.read_buffer(count_buffer, 0, &mut raw)?;
        Ok(raw
            .chunks_exact(4)
            .map(|w| u32::from_le_bytes([w[0], w[1], w[2], w[3]]))
            .collect())
    })();
    // Freed whatever happened (errors here only mean the device is gone).
    if let Some(p) = pipeline {
        let _ = device.destroy_pipeline(p);
    }
    if let Some(a) = accel {
        let _ = device.destroy_accel(a);
    }
    for b in buffers {
        let _ = device.destroy_buffer(b);
    }
    result
}

/// From the centre along each axis, both directions, with each sign of zero in the other two
/// components (24 rays): a test that treats `-0.0` unlike `+0.0` lets some out.
fn signed_zero_rays() -> Vec<f32> {
    let mut rays = Vec::new();
    for axis in 0..3 {
        for along in [1.0f32, -1.0] {
            for zeros in 0..4u32 {
                let mut d = [0.0f32; 3];
                d[axis] = along;
                d[(axis + 1) % 3] = if zeros & 1 == 1 { -0.0 } else { 0.0 };
                d[(axis + 2) % 3] = if zeros & 2 == 2 { -0.0 } else { 0.0 };
                rays.extend_from_slice(&[0.0, 0.0, 0.0, 0.0, d[0], d[1], d[2], f32::INFINITY]);
            }
        }
    }
    rays
}

/// The cached answer for `key`, if any.
fn cached(key: &str) -> Option<TriangleCheck> {
    if crate::cache::disabled() {
        return None;
    }
    let text = std::fs::read_to_string(crate::cache::root()?.join(CACHE_FILE)).ok()?;
    text.lines().rev().find_map(|line| {
        let mut fields = line.split('\t');
        if fields.next()? != key {
            return None;
        }
        let rays = fields.next()?.parse().ok()?;
        let leaks = fields.next()?.parse().ok()?;
        // Lines from before doubles were counted have three fields: checked again.
        let doubles = fields.next()?.parse().ok()?;
        Some(TriangleCheck {
            passed: leaks == 0 && doubles == 0,
            rays,
            leaks,
            doubles,
            cached: true,
        })
    })
}

/// Appends `result` under `key` to the cache (a failure to write only loses the cache).
fn store(key: &str, result: &TriangleCheck) {
    if crate::cache::disabled() {
        return;
    }
    let Some(dir) = crate::cache::root() else {
        return;
    };
    let _ = std::fs::create_dir_all(&dir);
    if let Ok(mut file) = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(dir.join(CACHE_FILE))
    {
        let _ = writeln!(
            file,
            "{key}\t{}\t{}\t{}",
            result.rays, result.leaks, result.doubles
        );
    }
}

#[cfg(all(test, feature = "cpu"))]
mod tests {
    use super::*;

    #[test]
    fn backends_without_a_triangle_test_of_their_own_refuse_the_check() {
        let device = crate::open_backend(crate::BackendKind::Cpu).unwrap();
        let before = device.accuracy();
        let e = check_driver_triangles(device.as_ref()).unwrap_err();
        assert_eq!(e.kind(), crate::ErrorKind::Unsupported, "{e}");
        assert_eq!(device.accuracy(), before, "the accuracy is left as it was");
    }

    #[test]
    fn signed_zero_rays_cover_every_axis_direction_and_zero_sign() {
        let rays = signed_zero_rays();
        assert_eq!(rays.len(), 24 * 8);
        let negative_zeros = rays
            .chunks_exact(8)
            .filter(|r| r[4..7].iter().any(|c| *c == 0.0 && c.is_sign_negative()))
            .count();
        assert_eq!(negative_zeros, 18);
    }

    /// On a Vulkan device (lavapipe in CI, with the validation layer): every ray of every set
    /// is traced with the driver's triangles, the verdict is "no leak", the accuracy comes
    /// back, and a second check on the same driver is answered from the cache.
    #[cfg(feature = "vulkan")]
    #[test]
    fn the_vulkan_check_traces_every_set_and_is_cached() {
        let device = match crate::open_backend(crate::BackendKind::Vulkan) {
            Ok(d) => d,
            Err(e) => {
                eprintln!("skipped: no Vulkan device here ({e})");
                return;
            }
        };
        let before = device.accuracy();
        let first = check_driver_triangles(device.as_ref()).expect("the check runs");
        if crate::backends::vulkan::VulkanOptions::from_env()
            .driver_triangles
            .is_none()
        {
            // optik::open has asked already (unless the environment decided for it): the
            // answer comes from this process.
            assert!(first.cached);
        }
        // Traced again here, whatever was remembered.
        device
            .set_accuracy(Accuracy {
                triangle: TriangleTest::Driver,
                ..before
            })
            .unwrap();
        let (rays, leaks, doubles) = trace_all(device.as_ref()).expect("every set traces");
        device.set_accuracy(before).unwrap();
        let (positions, triangles) = shapes::icosphere(SUBDIVISIONS);
        let per_inside = (positions.len() + 3 * triangles.len()) as u64;
        assert_eq!(rays, PLACES.len() as u64 * 2 * per_inside + 24);
        assert_eq!(
            (first.rays, first.leaks, first.doubles),
            (rays, leaks, doubles)
        );
        assert_eq!(first.passed, leaks == 0 && doubles == 0);
        assert!(leaks + doubles <= rays);
        assert_eq!(device.accuracy(), before, "the accuracy is set back");
        assert_eq!(device.take_diagnostics(), Vec::<String>::new());
        let second = check_driver_triangles(device.as_ref()).expect("the check runs again");
        if crate::cache::root().is_some() && !crate::cache::disabled() {
            assert!(second.cached, "the second check comes from the cache");
            assert_eq!(second, first);
        }
    }
}
