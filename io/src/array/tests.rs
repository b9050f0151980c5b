use super::*;

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

/// A `.npy` file with a hand-written header (what a hostile or broken writer could make).
fn npy_with_header(dict: &str, body: &[u8]) -> Vec<u8> {
    let mut header = dict.to_string();
    header.push('\n');
    let mut out = b"\x93NUMPY\x01\x00".to_vec();
    out.extend_from_slice(&(header.len() as u16).to_le_bytes());
    out.extend_from_slice(header.as_bytes());
    out.extend_from_slice(body);
    out
}

#[test]
fn npz_written_by_numpy_1_and_2_is_read() {
    for major in [1, 2] {
        for kind in ["hits", "compressed"] {
            let path = data(&format!("numpy{major}-{kind}.npz"));
            let mut npz = read_npz(&path).unwrap();
            assert_eq!(npz.names(), vec!["t", "prim"], "{}", path.display());
            let t = npz.array::<f32>("t").unwrap();
            assert_eq!(t.shape, vec![3]);
            assert_eq!(t.data, vec![1.5, f32::INFINITY, 0.25]);
            let prim = npz.array::<u32>("prim").unwrap();
            assert_eq!(prim.data, vec![7, u32::MAX, 0]);
            let e = npz.array::<u32>("t").unwrap_err().to_string();
            assert!(e.contains("t.npy: dtype is '<f4'; expected uint32"), "{e}");
            let e = npz.array::<f32>("u").unwrap_err().to_string();
            assert!(e.contains("has no array \"u\""), "{e}");
        }
    }
}

#[test]
fn npy_written_by_numpy_1_and_2_is_read() {
    for major in [1, 2] {
        let rays = read_npy::<f32>(&data(&format!("numpy{major}-rays.npy"))).unwrap();
        assert_eq!(rays.shape, vec![2, 8]);
        assert_eq!(rays.data, (0..16).map(|i| i as f32).collect::<Vec<_>>());
        let empty = read_npy::<f32>(&data(&format!("numpy{major}-empty.npy"))).unwrap();
        assert_eq!((empty.shape, empty.data.len()), (vec![0, 8], 0));
    }
}

#[test]
fn npz_round_trip_through_the_writer() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("out.npz");
    let t = [0.5f32, f32::INFINITY];
    let prim = [3u32, u32::MAX];
    write_npz(
        &path,
        &[
            Member::new("t", &[2], &t).unwrap(),
            Member::new("prim", &[2], &prim).unwrap(),
            Member::new("none", &[0], &[] as &[f32]).unwrap(),
        ],
    )
    .unwrap();
    let mut npz = read_npz(&path).unwrap();
    assert_eq!(npz.array::<f32>("t").unwrap().data, t);
    assert_eq!(npz.array::<u32>("prim").unwrap().data, prim);
    assert_eq!(npz.array::<f32>("none").unwrap().shape, vec![0]);
    assert!(Member::new("bad", &[3], &t).is_err());
}

#[test]
fn npy_shape_overflow_is_refused() {
    // (2^61 + 1) * 8 elements wraps to 8 in 64 bits: the old reader took it for one ray.
    let bytes = npy_with_header(
        "{'descr': '<f4', 'fortran_order': False, 'shape': (2305843009213693953, 8), }",
        &[0; 32],
    );
    let e = parse_npy::<f32>(&bytes).unwrap_err();
    assert!(e.contains("more elements than fit"), "{e}");
    // Zero rows do not excuse an overflowing remainder (npyz computes strides from it).
    let bytes = npy_with_header(
        "{'descr': '<f4', 'fortran_order': False, 'shape': (0, 4294967296, 4294967296), }",
        &[],
    );
    assert!(parse_npy::<f32>(&bytes).is_err());
}

#[test]
fn npy_shape_needing_more_data_than_held_is_refused() {
    let bytes = npy_with_header(
        "{'descr': '<f4', 'fortran_order': False, 'shape': (1000000000000, 8), }",
        &[0; 32],
    );
    let e = parse_npy::<f32>(&bytes).unwrap_err();
    assert!(
        e.contains("needs 32000000000000 bytes of data but the file holds 32"),
        "{e}"
    );
    for (dict, want) in [
        (
            "{'descr': '<f4', 'fortran_order': False, 'shape': (-1, 8), }",
            "whole numbers",
        ),
        (
            "{'descr': '<f4', 'fortran_order': True, 'shape': (2, 2), }",
            "Fortran-order",
        ),
        ("not a dict", "not a Python dict literal"),
    ] {
        let e = parse_npy::<f32>(&npy_with_header(dict, &[0; 16])).unwrap_err();
        assert!(e.contains(want), "{dict}: {e}");
    }
    let e = parse_npy::<f32>(b"PK\x03\x04 not numpy at all").unwrap_err();
    assert!(e.contains("magic"), "{e}");
}

/// Found by the `npy` fuzz target: a header naming 'shape' twice gave the checked shape and
/// npyz's shape apart (the array came back as shape (2, 8) with no values, or (0, 8) with 16).
#[test]
fn npy_header_with_two_shapes_is_refused() {
    for (first, second, data) in [("(2, 8)", "(0, 8)", 0), ("(0, 8)", "(2, 8)", 64)] {
        let header = format!(
            "{{'descr': '<f4', 'fortran_order': False, 'shape': {first}, 'shape': {second}, }}"
        );
        let e = parse_npy::<f32>(&npy_with_header(&header, &vec![0; data])).unwrap_err();
        assert!(
            e.contains("two shapes") || e.contains("needs"),
            "{first} {second}: {e}"
        );
    }
}
