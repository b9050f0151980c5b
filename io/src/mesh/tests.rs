use super::*;
use std::path::PathBuf;

fn file(dir: &tempfile::TempDir, name: &str, bytes: &[u8]) -> PathBuf {
    let p = dir.path().join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

fn err(r: Result<MeshData, IoError>) -> String {
    r.expect_err("expected an error").to_string()
}

#[test]
fn obj_merges_objects_in_file_order_and_fans_polygons() {
    let dir = tempfile::tempdir().unwrap();
    let p = file(
        &dir,
        "a.obj",
        b"o first\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\no second\nv 0 0 1\nv 1 0 1\nv 0 1 1\nf -3 -2 -1\n",
    );
    let m = read_mesh(&p).unwrap();
    assert_eq!(m.positions.len(), 7);
    assert_eq!(m.triangles.len(), 3);
    for (t, z) in m.triangles.iter().zip([0.0, 0.0, 1.0]) {
        assert!(t.iter().all(|&i| m.positions[i as usize][2] == z), "{t:?}");
    }
    // Fan order: (v0, v1, v2), (v0, v2, v3).
    let corner = |t: [u32; 3]| t.map(|i| m.positions[i as usize]);
    assert_eq!(
        corner(m.triangles[0]),
        [[0., 0., 0.], [1., 0., 0.], [1., 1., 0.]]
    );
    assert_eq!(
        corner(m.triangles[1]),
        [[0., 0., 0.], [1., 1., 0.], [0., 1., 0.]]
    );
    assert!(m.normals.is_empty() && m.uvs.is_empty());
}

#[test]
fn obj_keeps_normals_and_uvs_per_position() {
    let dir = tempfile::tempdir().unwrap();
    let p = file(
        &dir,
        "n.obj",
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nvt 0.5 0.25\nf 1/1/1 2/1/1 3/1/1\n",
    );
    let m = read_obj(&p).unwrap();
    assert_eq!(m.normals.len(), m.positions.len());
    assert_eq!(m.uvs.len(), m.positions.len());
    assert_eq!(m.normals[0], [0.0, 0.0, 1.0]);
    assert_eq!(m.uvs[2], [0.5, 0.25]);
}

#[test]
fn obj_gz_is_read() {
    use std::io::Write;
    let dir = tempfile::tempdir().unwrap();
    let mut gz = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    gz.write_all(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
        .unwrap();
    let p = file(&dir, "a.OBJ.gz", &gz.finish().unwrap());
    assert_eq!(read_mesh(&p).unwrap().triangles.len(), 1);
}

#[test]
fn obj_face_index_of_no_vertex_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    for (name, text) in [
        ("past.obj", "v 0 0 0\nf 1 2 3\n"),
        ("zero.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n"),
    ] {
        let e = err(read_obj(&file(&dir, name, text.as_bytes())));
        assert!(
            e.contains(name) && e.contains("not a valid OBJ file"),
            "{e}"
        );
    }
}

/// Found by the `obj` fuzz target: tobj multiplied huge texture-coordinate and normal indices
/// unchecked (an overflow, then an out-of-bounds index: a panic in any build).
#[test]
fn obj_face_index_past_texture_coordinates_or_normals_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    for (face, what) in [
        ("f 1/99999999999999999999 2/1 3/1", "texture coordinates"),
        ("f 1/1/9223372036854775807 2/1/1 3/1/1", "normals"),
        ("f 1/2/1 2/1/1 3/1/1", "texture coordinates"),
    ] {
        let text = format!("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\n{face}\n");
        let e = err(read_obj(&file(&dir, "big.obj", text.as_bytes())));
        assert!(e.contains("line 6") && e.contains(what), "{face}: {e}");
    }
}

#[test]
fn mesh_without_triangles_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    for (name, text) in [
        ("empty.obj", &b""[..]),
        ("comments.obj", b"# nothing here\n# at all\n"),
        ("garbage.obj", b"\x00\x01garbage that is no OBJ\nhello world\n"),
        ("points.obj", b"v 0 0 0\nv 1 0 0\n"),
        (
            "vertices.ply",
            b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n",
        ),
    ] {
        let e = err(read_mesh(&file(&dir, name, text)));
        assert!(e.contains(name) && e.contains("no triangles"), "{e}");
    }
}

#[test]
fn unknown_extension_and_missing_file_are_errors() {
    let dir = tempfile::tempdir().unwrap();
    let e = err(read_mesh(&file(&dir, "a.stl", b"solid")));
    assert!(e.contains("expected a file ending in .obj"), "{e}");
    let e = err(read_mesh(&dir.path().join("gone.ply")));
    assert!(e.contains("gone.ply: cannot open"), "{e}");
}

fn ply_ascii(vertex_props: &str, vertices: &str, faces: &str) -> Vec<u8> {
    format!(
        "ply\nformat ascii 1.0\ncomment made by hand\nelement vertex {}\n{vertex_props}element face {}\nproperty list uchar int vertex_indices\nend_header\n{vertices}{faces}",
        vertices.lines().count(),
        faces.lines().count()
    )
    .into_bytes()
}

#[test]
fn ply_ascii_with_normals_and_uvs_fans_polygons() {
    let dir = tempfile::tempdir().unwrap();
    let props = "property float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\nproperty float nz\nproperty float s\nproperty float t\n";
    let p = file(
        &dir,
        "a.ply",
        &ply_ascii(
            props,
            "0 0 0 0 0 1 0 0\n1 0 0 0 0 1 1 0\n1 1 0 0 0 1 1 1\n0 1 0 0 0 1 0 1\n",
            "4 0 1 2 3\n",
        ),
    );
    let m = read_mesh(&p).unwrap();
    assert_eq!(m.positions[2], [1.0, 1.0, 0.0]);
    assert_eq!(m.triangles, vec![[0, 1, 2], [0, 2, 3]]);
    assert_eq!(m.normals, vec![[0.0, 0.0, 1.0]; 4]);
    assert_eq!(m.uvs[3], [0.0, 1.0]);
}

fn ply_binary(big_endian: bool) -> Vec<u8> {
    let format = if big_endian { "big" } else { "little" };
    let mut bin = format!(
        "ply\nformat binary_{format}_endian 1.0\nelement vertex 3\nproperty double x\nproperty double y\nproperty double z\nelement edge 1\nproperty int a\nelement face 1\nproperty uchar flags\nproperty list uchar uint vertex_index\nend_header\n"
    )
    .into_bytes();
    let put = |bin: &mut Vec<u8>, le: &[u8]| {
        let mut b = le.to_vec();
        if big_endian {
            b.reverse();
        }
        bin.extend_from_slice(&b);
    };
    for v in [[0.0f64, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.5]] {
        for c in v {
            put(&mut bin, &c.to_le_bytes());
        }
    }
    put(&mut bin, &7i32.to_le_bytes());
    bin.extend_from_slice(&[9, 3]);
    for i in [0u32, 1, 2] {
        put(&mut bin, &i.to_le_bytes());
    }
    bin
}

#[test]
fn ply_binary_both_endiannesses_skip_other_elements() {
    let dir = tempfile::tempdir().unwrap();
    for big in [false, true] {
        let p = file(&dir, "b.ply", &ply_binary(big));
        let m = read_ply(&p).unwrap();
        assert_eq!(m.positions[2], [0.0, 2.0, 0.5], "big endian: {big}");
        assert_eq!(m.triangles, vec![[0, 1, 2]]);
        let mut short = ply_binary(big);
        short.truncate(short.len() - 2);
        let e = err(read_ply(&file(&dir, "short.ply", &short)));
        assert!(e.contains("short.ply: the `face` data"), "{e}");
    }
}

#[test]
fn ply_huge_counts_are_refused_without_allocating() {
    let dir = tempfile::tempdir().unwrap();
    let vertex = "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n";
    // A face count the 200-byte file cannot hold.
    let huge = format!(
        "ply\nformat binary_little_endian 1.0\n{vertex}element face 4294967295\nproperty list uchar int vertex_indices\nend_header\n"
    );
    let e = err(read_ply(&file(&dir, "huge.ply", huge.as_bytes())));
    assert!(e.contains("claims 4294967295 `face` elements"), "{e}");
    // A list whose count claims 2^32-1 entries, and a float count type.
    let mut list = format!(
        "ply\nformat binary_little_endian 1.0\n{vertex}element face 1\nproperty list uint int vertex_indices\nend_header\n"
    )
    .into_bytes();
    list.extend_from_slice(&[0; 36]);
    list.extend_from_slice(&u32::MAX.to_le_bytes());
    list.extend_from_slice(&[0; 8]);
    let e = err(read_ply(&file(&dir, "list.ply", &list)));
    assert!(e.contains("the `face` data"), "{e}");
    let float_count = format!(
        "ply\nformat ascii 1.0\n{vertex}element face 1\nproperty list float int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n1e30 0 1 2\n"
    );
    let e = err(read_ply(&file(&dir, "float.ply", float_count.as_bytes())));
    assert!(e.contains("float.ply"), "{e}");
    let no_props =
        format!("ply\nformat binary_little_endian 1.0\n{vertex}element nothing 100\nend_header\n");
    let e = err(read_ply(&file(
        &dir,
        "empty-element.ply",
        no_props.as_bytes(),
    )));
    assert!(e.contains("no properties"), "{e}");
}

#[test]
fn ply_negative_or_fractional_face_index_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let xyz = "property float x\nproperty float y\nproperty float z\n";
    let verts = "0 0 0\n1 0 0\n0 1 0\n";
    let e = err(read_ply(&file(
        &dir,
        "neg.ply",
        &ply_ascii(xyz, verts, "3 -1 1 2\n"),
    )));
    assert!(e.contains("face 0 uses vertex index -1"), "{e}");
    let e = err(read_ply(&file(
        &dir,
        "past.ply",
        &ply_ascii(xyz, verts, "3 0 1 3\n"),
    )));
    assert!(
        e.contains("vertex index 3; expected a whole number from 0 to 2"),
        "{e}"
    );
    let float_index = format!(
        "ply\nformat ascii 1.0\nelement vertex 3\n{xyz}element face 1\nproperty list uchar float vertex_indices\nend_header\n{verts}3 0.7 1 2\n"
    );
    let e = err(read_ply(&file(&dir, "frac.ply", float_index.as_bytes())));
    assert!(e.contains("vertex index 0.7"), "{e}");
    let e = err(read_ply(&file(
        &dir,
        "two.ply",
        &ply_ascii(xyz, verts, "2 0 1\n"),
    )));
    assert!(e.contains("face 0 has 2 vertices"), "{e}");
}

#[test]
fn ply_vertex_without_a_coordinate_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let p = file(
        &dir,
        "noz.ply",
        &ply_ascii(
            "property float x\nproperty float y\n",
            "0 0\n1 0\n0 1\n",
            "3 0 1 2\n",
        ),
    );
    let e = err(read_ply(&p));
    assert!(e.contains("the vertex element has no z property"), "{e}");
    let p = file(
        &dir,
        "noface.ply",
        b"ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\nproperty float z\nelement face 0\nproperty uchar n\nend_header\n",
    );
    let e = err(read_ply(&p));
    assert!(e.contains("no vertex_indices"), "{e}");
}
