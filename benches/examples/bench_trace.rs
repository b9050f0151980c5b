//! Times primary and incoherent rays (default 1920×1080) on the wgpu backend with GPU
//! timestamps, counts the bytes its kernel reads per ray, probes the memory bandwidth, and
//! runs the same rays on the Vulkan backend (default accuracy and the driver's triangles).
//!
//! `bench_trace [mesh.obj | mesh.obj.gz] [width height] [repeats] [--no-vulkan]
//! [--bandwidth-mib N] [--camera ex ey ez vx vy vz fov]`
//!
//! `--camera` places the primary rays' pinhole camera (eye, view direction, horizontal
//! field of view in degrees); without it the camera frames the mesh from outside, as
//! `optik bench-report`'s camera rays do. The Breakfast Room's own camera (its
//! `scene.mitsuba.xml`) is `--camera -0.587317 2.7623 9.71429 0.013058 -0.063863 -0.997873 60`.
//!
//! Without a mesh it traces a generated bumpy sphere of about 1M triangles. A mesh is a
//! Wavefront OBJ file, optionally gzipped (`v` and `f` lines; polygons are fanned into
//! triangles), for example `shared/scenes/breakfast-room/breakfast_room.obj`.
//! `OPTIK_WGPU_ADAPTER` picks the wgpu adapter (a part of its name), `OPTIK_VULKAN_DEVICE`
//! the Vulkan device; `OPTIK_ACCURACY` (`robust`, `fast`, `watertight+plain`, ...) the wgpu
//! backend's triangle and box tests.

use optik::backends::wgpu::bench::BenchConfig;
use optik_api::{Accuracy, BoxTest, TriangleTest};

/// Vertices and triangles.
type Mesh = (Vec<[f32; 3]>, Vec<[u32; 3]>);

/// A mesh file (OBJ, gzipped OBJ or PLY) through optik-io.
fn load_obj(path: &str) -> Result<Mesh, String> {
    let mesh = optik_io::mesh::read_mesh(std::path::Path::new(path)).map_err(|e| e.to_string())?;
    Ok((mesh.positions, mesh.triangles))
}

fn fail(message: String) -> ! {
    eprintln!("{message}");
    std::process::exit(2)
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut mesh = None;
    let mut numbers = Vec::new();
    let mut vulkan = true;
    let mut bandwidth_mib = 1024u64;
    let mut camera = None;
    let mut it = args.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--no-vulkan" => vulkan = false,
            "--bandwidth-mib" => {
                bandwidth_mib = it
                    .next()
                    .and_then(|s| s.parse().ok())
                    .unwrap_or_else(|| fail("--bandwidth-mib needs a number of MiB".into()))
            }
            "--camera" => {
                let v: Vec<f32> = it.by_ref().take(7).filter_map(|s| s.parse().ok()).collect();
                if v.len() != 7 {
                    fail("--camera needs eye x y z, view x y z and a field of view in degrees".into());
                }
                camera = Some(optik::backends::wgpu::bench::Camera {
                    eye: [v[0], v[1], v[2]],
                    view: [v[3], v[4], v[5]],
                    horizontal_fov_degrees: v[6],
                });
            }
            s if s.ends_with(".obj") || s.ends_with(".obj.gz") => mesh = Some(s.to_string()),
            s => numbers.push(s.parse::<u32>().unwrap_or_else(|_| {
                fail(format!(
                    "`{s}`: expected a mesh (.obj or .obj.gz), width height repeats, --no-vulkan, --bandwidth-mib N or --camera ..."
                ))
            })),
        }
    }
    let num = |i: usize, default: u32| numbers.get(i).copied().unwrap_or(default);
    let config = BenchConfig {
        width: num(0, 1920),
        height: num(1, 1080),
        repeats: num(2, 10),
        accuracy: std::env::var("OPTIK_ACCURACY")
            .ok()
            .and_then(|s| Accuracy::parse(&s))
            .unwrap_or_default(),
        bandwidth_bytes: bandwidth_mib << 20,
        traffic: true,
        camera,
    };
    let (vertices, indices) = match &mesh {
        Some(path) => load_obj(path).unwrap_or_else(|e| fail(e)),
        None => optik::backends::wgpu::bench::bumpy_sphere(512),
    };
    println!(
        "mesh             {}",
        mesh.as_deref().unwrap_or("generated bumpy sphere")
    );
    println!("launch           {} x {}", config.width, config.height);
    println!("\n== wgpu, accuracy {:?}", config.accuracy);
    let mut summary = Vec::new();
    match optik::backends::wgpu::bench::bench_trace(&vertices, &indices, &config) {
        Ok(report) => {
            print!("{report}");
            summary.push(("wgpu, GPU timestamps".to_string(), report.clone(), false));
            summary.push(("wgpu, wall clock".to_string(), report, true));
        }
        Err(e) => {
            eprintln!("bench_trace failed on wgpu: {e}");
            std::process::exit(1);
        }
    }
    if vulkan {
        vulkan_reports(&vertices, &indices, &config, &mut summary);
    }
    println!("\n== summary (Grays/s: primary, incoherent)");
    for (name, report, wall) in &summary {
        let rate = |k: usize| {
            report.timings.get(k).map_or(0.0, |t| {
                let seconds = if *wall { t.wall_seconds } else { t.seconds() };
                t.rays as f64 / seconds / 1e9
            })
        };
        println!("{name:<36} {:>8.3} {:>8.3}", rate(0), rate(1));
    }
}

/// The Vulkan backend on the same rays, with the default accuracy and with the driver's
/// triangles (wall clock around launch + synchronize).
fn vulkan_reports(
    vertices: &[[f32; 3]],
    indices: &[[u32; 3]],
    config: &BenchConfig,
    summary: &mut Vec<(String, optik::backends::wgpu::bench::BenchReport, bool)>,
) {
    let driver = Accuracy {
        triangle: TriangleTest::Driver,
        box_test: BoxTest::Conservative,
    };
    for (name, accuracy) in [("robust", Accuracy::ROBUST), ("driver triangles", driver)] {
        println!("\n== Vulkan, accuracy {accuracy:?}");
        // A fresh device per accuracy, so each builds and compiles as a new user would.
        let result = optik::backends::vulkan::open().and_then(|dev| {
            optik::backends::wgpu::bench::bench_device(
                dev.as_ref(),
                vertices,
                indices,
                &BenchConfig {
                    accuracy,
                    ..*config
                },
            )
        });
        match result {
            Ok(report) => {
                print!("{report}");
                summary.push((format!("Vulkan {name}, wall clock"), report, true));
            }
            Err(e) => println!("not measured: {e}"),
        }
    }
}
