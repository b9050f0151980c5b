//! The `.npy` reader `optik trace` reads rays with (`optik_io::array::parse_npy`, over npyz
//! with its header's sizes checked first).

use crate::{Outcome, Target};

/// The target.
pub const TARGET: Target = Target {
    name: "npy",
    seeds,
    dictionary: &[
        b"\x93NUMPY",
        b"'descr': '<f4'",
        b"'descr': '>f8'",
        b"'fortran_order': True",
        b"'shape': (",
        b"2305843009213693953",
        b"18446744073709551615",
        b", 8)",
        b"}",
    ],
    run,
};

fn seeds() -> Vec<Vec<u8>> {
    let rays: Vec<f32> = (0..16).map(|i| i as f32).collect();
    let empty: Vec<f32> = Vec::new();
    [(&[2usize, 8][..], &rays[..]), (&[0, 8][..], &empty[..])]
        .into_iter()
        .filter_map(|(shape, data)| optik_io::array::npy_bytes(shape, data).ok())
        .collect()
}

fn run(data: &[u8]) -> Outcome {
    match optik_io::array::parse_npy::<f32>(data) {
        Ok(array) => {
            let count = array
                .shape
                .iter()
                .try_fold(1usize, |a, &d| a.checked_mul(d));
            if count != Some(array.data.len()) {
                return Outcome::Finding(format!(
                    "shape {:?} but {} values",
                    array.shape,
                    array.data.len()
                ));
            }
            Outcome::Accepted
        }
        Err(_) => Outcome::Rejected,
    }
}
