//! The EXR reader the conformance suite reads references and outputs with
//! (`optik_conformance::exrio::read_bytes`, over the `exr` crate).

use crate::{Outcome, Target};

/// The target.
pub const TARGET: Target = Target {
    name: "exr",
    seeds,
    dictionary: DICTIONARY,
    run,
};

const DICTIONARY: &[&[u8]] = &[
    b"\x76\x2f\x31\x01",
    b"channels\0chlist\0",
    b"compression\0compression\0",
    b"dataWindow\0box2i\0",
    b"displayWindow\0box2i\0",
    b"lineOrder\0lineOrder\0",
    b"pixelAspectRatio\0float\0",
    b"screenWindowCenter\0v2f\0",
    b"screenWindowWidth\0float\0",
    b"tiles\0tiledesc\0",
    b"type\0string\0",
    b"chunkCount\0int\0",
    b"name\0string\0",
    b"\xff\xff\xff\x7f",
    b"\x00\x00\x00\x80",
    b"\x00\x00\x00\x00",
];

/// Seeds: small references of the conformance suite (records with UINT and FLOAT channels,
/// several compressions).
fn seeds() -> Vec<Vec<u8>> {
    vec![
        include_bytes!("../../../conformance/references/sbt.gas_index_multi_record.exr").to_vec(),
        include_bytes!("../../../conformance/references/numerics.shared_edge_origin.exr").to_vec(),
        include_bytes!("../../../conformance/references/aabb.attributes_max.exr").to_vec(),
    ]
}

/// Runs one input.
pub fn run(data: &[u8]) -> Outcome {
    match optik_conformance::exrio::read_bytes(data, "fuzz.exr") {
        Ok(_) => Outcome::Accepted,
        Err(_) => Outcome::Rejected,
    }
}
