//! The renderer's Mitsuba 3 XML reader (`optik_render::scene::load`): grammar, plugins and
//! their parameters, from a file.

use super::file::with_file;
use crate::{Outcome, Target};

/// The target.
pub const TARGET: Target = Target {
    name: "mitsuba",
    seeds,
    dictionary: &[
        b"<scene version=\"3.0.0\">",
        b"</scene>",
        b"<shape type=\"rectangle\">",
        b"<shape type=\"cube\">",
        b"<shape type=\"sphere\">",
        b"<shape type=\"shapegroup\" id=\"g\">",
        b"<shape type=\"instance\"><ref id=\"g\"/></shape>",
        b"</shape>",
        b"<bsdf type=\"roughconductor\">",
        b"<bsdf type=\"twosided\">",
        b"</bsdf>",
        b"<emitter type=\"area\">",
        b"<emitter type=\"spot\"/>",
        b"<transform name=\"to_world\">",
        b"<rotate x=\"1\" angle=\"90\"/>",
        b"<scale value=\"0\"/>",
        b"<matrix value=\"1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 1\"/>",
        b"<lookat origin=\"0,0,0\" target=\"0,0,0\"/>",
        b"</transform>",
        b"<spectrum name=\"reflectance\" value=\"400:0.5, 700:0.1\"/>",
        b"<rgb name=\"radiance\" value=\"1e30\"/>",
        b"<default name=\"x\" value=\"$x\"/>",
        b"$spp",
        b"<float name=\"fov\" value=\"nan\"/>",
        b"<integer name=\"width\" value=\"-1\"/>",
        b"<alias id=\"a\" as=\"b\"/>",
    ],
    run,
};

fn seeds() -> Vec<Vec<u8>> {
    vec![
        include_bytes!("../../../render/validation/scenes/cbox.xml").to_vec(),
        br#"<scene version="0.6.0"><sensor type="perspective"><float name="fov" value="45"/><film type="hdrfilm"><integer name="width" value="4"/><integer name="height" value="4"/></film></sensor><shape type="sphere"><bsdf type="diffuse"><rgb name="diffuseReflectance" value="0.5"/></bsdf></shape><emitter type="constant"/></scene>"#.to_vec(),
    ]
}

fn run(data: &[u8]) -> Outcome {
    match with_file("xml", data, |path| optik_render::scene::load(path, &[])) {
        Some(Ok(_)) => Outcome::Accepted,
        _ => Outcome::Rejected,
    }
}
