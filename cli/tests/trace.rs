//! `optik trace` on the CPU backend: its inputs checked before any work, its outputs written
//! atomically, its JSON line and exit codes (0 success, 1 failed work, 2 usage error).

use optik_io::array;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn optik(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_optik"))
        .args(args)
        .output()
        .expect("run optik")
}

/// `optik trace --backend cpu --mesh MESH --rays RAYS --out OUT`.
fn trace(mesh: &Path, rays: &Path, out: &Path) -> Output {
    optik(&[
        "trace",
        "--backend",
        "cpu",
        "--mesh",
        &mesh.to_string_lossy(),
        "--rays",
        &rays.to_string_lossy(),
        "--out",
        &out.to_string_lossy(),
    ])
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A failure that is reported, not a crash.
fn assert_fails(o: &Output, code: i32, message: &str) {
    let e = stderr(o);
    assert_eq!(o.status.code(), Some(code), "{e}");
    assert!(!e.contains("panicked"), "{e}");
    assert!(e.contains(message), "expected {message:?} in: {e}");
}

struct Files {
    dir: tempfile::TempDir,
}

impl Files {
    fn new() -> Files {
        Files {
            dir: tempfile::tempdir().expect("temp dir"),
        }
    }
    fn path(&self, name: &str) -> PathBuf {
        self.dir.path().join(name)
    }
    fn write(&self, name: &str, bytes: &[u8]) -> PathBuf {
        let p = self.path(name);
        std::fs::write(&p, bytes).expect("write fixture");
        p
    }
    /// One triangle in the plane z = 1 over (0,0)-(1,0)-(0,1).
    fn triangle(&self) -> PathBuf {
        self.write("tri.obj", b"v 0 0 1\nv 1 0 1\nv 0 1 1\nf 1 2 3\n")
    }
    fn rays(&self, name: &str, rays: &[[f32; 8]]) -> PathBuf {
        let p = self.path(name);
        let flat: Vec<f32> = rays.iter().flatten().copied().collect();
        array::write_npy(&p, &[rays.len(), 8], &flat).expect("write rays");
        p
    }
}

fn json_line(o: &Output) -> serde_json::Value {
    assert_eq!(o.status.code(), Some(0), "{}", stderr(o));
    serde_json::from_slice(&o.stdout).expect("one JSON line on stdout")
}

#[test]
fn empty_ray_file_traces_to_an_empty_npz() {
    let f = Files::new();
    let rays = f.rays("none.npy", &[]);
    let out = f.path("hits.npz");
    let j = json_line(&trace(&f.triangle(), &rays, &out));
    assert_eq!((j["rays"].as_u64(), j["hits"].as_u64()), (Some(0), Some(0)));
    let mut npz = array::read_npz(&out).expect("an npz");
    for name in ["t", "u", "v"] {
        assert_eq!(npz.array::<f32>(name).unwrap().shape, vec![0]);
    }
    for name in ["prim", "inst"] {
        assert_eq!(npz.array::<u32>(name).unwrap().shape, vec![0]);
    }
}

#[test]
fn json_line_counts_triangles_hits_misses_and_invalid_rays() {
    let f = Files::new();
    let inf = f32::INFINITY;
    let rays = f.rays(
        "rays.npy",
        &[
            [0.25, 0.5, 0.0, 0.0, 0.0, 0.0, 2.0, inf],
            [5.0, 5.0, 0.0, 0.0, 0.0, 0.0, 1.0, inf],
            [0.25, 0.25, 0.0, 1.0, 0.0, 0.0, 1.0, 0.5],
            [f32::NAN, 0.25, 0.0, 0.0, 0.0, 0.0, 1.0, inf],
        ],
    );
    let out = f.path("hits.npz");
    let j = json_line(&trace(&f.triangle(), &rays, &out));
    assert_eq!(j["triangles"], 1);
    assert_eq!(j["rays"], 4);
    assert_eq!(j["hits"], 1);
    assert_eq!(j["misses"], 3);
    assert_eq!(j["invalid_rays"], 2);
    let mut npz = array::read_npz(&out).unwrap();
    assert_eq!(npz.array::<f32>("t").unwrap().data, [0.5, inf, inf, inf]);
    assert_eq!(
        npz.array::<u32>("prim").unwrap().data,
        [0, u32::MAX, u32::MAX, u32::MAX]
    );
    assert_eq!(
        npz.array::<u32>("inst").unwrap().data,
        [0, u32::MAX, u32::MAX, u32::MAX]
    );
    assert_eq!(npz.array::<f32>("u").unwrap().data, [0.25, 0.0, 0.0, 0.0]);
    assert_eq!(npz.array::<f32>("v").unwrap().data, [0.5, 0.0, 0.0, 0.0]);
}

#[test]
fn ply_with_a_huge_face_count_fails_without_panicking() {
    let f = Files::new();
    let mesh = f.write(
        "huge.ply",
        b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 4000000000\nproperty list uint int vertex_indices\nend_header\n",
    );
    let rays = f.rays("rays.npy", &[[0.0; 8]]);
    let o = trace(&mesh, &rays, &f.path("hits.npz"));
    assert_fails(&o, 1, "claims 4000000000 `face` elements");
}

#[test]
fn ply_face_index_of_minus_one_fails() {
    let f = Files::new();
    let mesh = f.write(
        "neg.ply",
        b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 1\n1 0 1\n0 1 1\n3 -1 1 2\n",
    );
    let rays = f.rays("rays.npy", &[[0.0; 8]]);
    let o = trace(&mesh, &rays, &f.path("hits.npz"));
    assert_fails(&o, 1, "uses vertex index -1");
}

#[test]
fn npy_shape_that_overflows_fails() {
    let f = Files::new();
    let header = "{'descr': '<f4', 'fortran_order': False, 'shape': (2305843009213693953, 8), }\n";
    let mut bytes = b"\x93NUMPY\x01\x00".to_vec();
    bytes.extend_from_slice(&(header.len() as u16).to_le_bytes());
    bytes.extend_from_slice(header.as_bytes());
    bytes.extend_from_slice(&[0; 32]);
    let rays = f.write("hostile.npy", &bytes);
    let o = trace(&f.triangle(), &rays, &f.path("hits.npz"));
    assert_fails(&o, 1, "hostile.npy");
}

#[test]
fn mesh_without_triangles_fails() {
    let f = Files::new();
    let rays = f.rays("rays.npy", &[[0.0; 8]]);
    for (name, text) in [
        ("empty.obj", ""),
        ("comments.obj", "# nothing\n"),
        ("junk.obj", "hello\n"),
    ] {
        let o = trace(&f.write(name, text.as_bytes()), &rays, &f.path("hits.npz"));
        assert_fails(&o, 1, "no triangles");
    }
}

#[test]
fn out_equal_to_an_input_is_a_usage_error() {
    let f = Files::new();
    let rays = f.rays("rays.npy", &[[0.25, 0.25, 0.0, 0.0, 0.0, 0.0, 1.0, 9.0]]);
    let before = std::fs::read(&rays).unwrap();
    let o = trace(&f.triangle(), &rays, &rays);
    assert_fails(&o, 2, "is the --rays input");
    assert_eq!(
        std::fs::read(&rays).unwrap(),
        before,
        "the input was overwritten"
    );
}

#[test]
fn out_in_a_missing_folder_fails_before_any_work() {
    let f = Files::new();
    // The inputs do not exist either: the output is checked first, before reading anything.
    let o = trace(
        &f.path("no.obj"),
        &f.path("no.npy"),
        &f.path("missing/dir/x.npz"),
    );
    assert_fails(&o, 2, "does not exist");
}

#[test]
fn failed_run_keeps_the_previous_output() {
    let f = Files::new();
    let out = f.write("hits.npz", b"previous good output");
    let bad = f.write("bad.npy", b"not numpy");
    let o = trace(&f.triangle(), &bad, &out);
    assert_fails(&o, 1, "magic");
    assert_eq!(std::fs::read(&out).unwrap(), b"previous good output");
}

#[test]
fn bad_flag_value_is_a_usage_error() {
    let f = Files::new();
    let rays = f.rays("rays.npy", &[[0.0; 8]]);
    let o = optik(&[
        "trace",
        "--backend",
        "nope",
        "--mesh",
        &f.triangle().to_string_lossy(),
        "--rays",
        &rays.to_string_lossy(),
        "--out",
        &f.path("o.npz").to_string_lossy(),
    ]);
    assert_fails(&o, 2, "--backend \"nope\"");
}

#[test]
fn trace_help_documents_formats_misses_and_exit_codes() {
    let o = optik(&["trace", "--help"]);
    assert!(o.status.success());
    let help = String::from_utf8_lossy(&o.stdout);
    for needle in [
        "float32",
        "(N, 8)",
        "uint32",
        "0xFFFFFFFF",
        "+inf",
        "barycentric",
        "(1 - u - v) * v0 + u * v1 + v * v2",
        "invalid ray",
        "Exit status: 0 success; 1",
        "2 a usage error",
        "invalid_rays",
    ] {
        assert!(
            help.contains(needle),
            "`optik trace --help` lacks {needle:?}:\n{help}"
        );
    }
}

#[test]
fn zero_or_unbounded_counts_are_usage_errors() {
    let f = Files::new();
    let (mesh, rays) = (f.triangle(), f.rays("r.npy", &[[0.0; 8]]));
    let out = f.path("hits.npz");
    for (flag, value, message) in [
        ("--repeat", "0", "at least 1"),
        ("--threads", "0", "thread count from 1"),
        ("--threads", "100000000", "thread count from 1"),
    ] {
        let o = optik(&[
            "trace",
            "--backend",
            "cpu",
            flag,
            value,
            "--mesh",
            &mesh.to_string_lossy(),
            "--rays",
            &rays.to_string_lossy(),
            "--out",
            &out.to_string_lossy(),
        ]);
        assert_fails(&o, 2, message);
        assert!(!out.exists(), "{flag} {value}: no work is done");
    }
}

#[test]
fn threads_on_a_gpu_backend_are_a_warning() {
    let f = Files::new();
    let (mesh, rays) = (f.triangle(), f.rays("r.npy", &[[0.0; 8]]));
    let out = f.path("hits.npz");
    let o = optik(&[
        "trace",
        "--backend",
        "wgpu",
        "--threads",
        "2",
        "--mesh",
        &mesh.to_string_lossy(),
        "--rays",
        &rays.to_string_lossy(),
        "--out",
        &out.to_string_lossy(),
    ]);
    if o.status.code() == Some(1) && stderr(&o).contains("wgpu") && !out.exists() {
        eprintln!("SKIPPED: wgpu cannot run here: {}", stderr(&o));
        return;
    }
    json_line(&o);
    assert!(
        stderr(&o).contains("warning: the thread count (2) is ignored"),
        "{}",
        stderr(&o)
    );
}
