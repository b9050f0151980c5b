//! Times primary and incoherent rays at 1920×1080 on the wgpu backend with GPU timestamps.
//!
//! `cargo run --release -p optik-wgpu --example bench_trace -- [mesh.obj] [width height] [repeats]`
//!
//! Without a mesh it traces a generated bumpy sphere of about 1M triangles. A mesh is a
//! Wavefront OBJ file (`v` and `f` lines; polygons are fanned into triangles), for example
//! the Stanford bunny or the Breakfast Room from the project's `scenes/` folder (not shipped
//! with the crate). `OPTIK_WGPU_ADAPTER` picks the adapter; `OPTIK_ACCURACY` (`robust`,
//! `fast`, `watertight+plain`, ...) the triangle and box tests.

use optik_api::Accuracy;

/// Vertices and triangles.
type Mesh = (Vec<[f32; 3]>, Vec<[u32; 3]>);

fn load_obj(path: &str) -> Result<Mesh, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{path}: {e}"))?;
    let mut vertices = Vec::new();
    let mut indices = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => {
                let v: Vec<f32> = words.take(3).filter_map(|w| w.parse().ok()).collect();
                if v.len() != 3 {
                    return Err(format!("{path}:{}: a vertex needs three numbers", n + 1));
                }
                vertices.push([v[0], v[1], v[2]]);
            }
            Some("f") => {
                let face: Vec<u32> = words
                    .filter_map(|w| w.split('/').next()?.parse::<i64>().ok())
                    .map(|i| if i < 0 { vertices.len() as i64 + i } else { i - 1 } as u32)
                    .collect();
                for k in 1..face.len().saturating_sub(1) {
                    indices.push([face[0], face[k], face[k + 1]]);
                }
            }
            _ => {}
        }
    }
    if indices
        .iter()
        .flatten()
        .any(|&i| i as usize >= vertices.len())
    {
        return Err(format!("{path}: a face names a vertex that does not exist"));
    }
    Ok((vertices, indices))
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (mesh, rest) = match args.first() {
        Some(p) if p.ends_with(".obj") => (Some(p.as_str()), &args[1..]),
        _ => (None, &args[..]),
    };
    let num = |i: usize, default: u32| rest.get(i).and_then(|s| s.parse().ok()).unwrap_or(default);
    let (width, height, repeats) = (num(0, 1920), num(1, 1080), num(2, 10));
    let (vertices, indices) = match mesh {
        Some(path) => load_obj(path).unwrap_or_else(|e| {
            eprintln!("{e}");
            std::process::exit(2)
        }),
        None => optik_wgpu::bench::bumpy_sphere(512),
    };
    let accuracy = std::env::var("OPTIK_ACCURACY")
        .ok()
        .and_then(|s| Accuracy::parse(&s))
        .unwrap_or_default();
    println!(
        "mesh             {}",
        mesh.unwrap_or("generated bumpy sphere")
    );
    println!("accuracy         {accuracy:?}");
    match optik_wgpu::bench::bench_trace(&vertices, &indices, width, height, repeats, accuracy) {
        Ok(report) => print!("{report}"),
        Err(e) => {
            eprintln!("bench_trace failed: {e}");
            std::process::exit(1);
        }
    }
}
