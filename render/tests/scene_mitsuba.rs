//! The Mitsuba 3 XML loader: grammar, plugins and their defaults, errors and warnings with their
//! file:line. Each test writes its small scene into a fresh temporary folder.

use glam::{Mat3, Mat4, Vec2, Vec3};
use optik_render::scene::{
    self, AovKind, Bsdf, Emitter, Filter, FovAxis, Integrator, Microfacet, Scene, SceneError,
    Texture,
};
use std::path::{Path, PathBuf};

/// A temporary folder removed when dropped.
struct Dir(PathBuf);

impl Dir {
    fn new(tag: &str) -> Dir {
        static COUNT: std::sync::atomic::AtomicU32 = std::sync::atomic::AtomicU32::new(0);
        let n = COUNT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let d = std::env::temp_dir().join(format!("optik-scene-{tag}-{}-{n}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        Dir(d)
    }
    fn write(&self, name: &str, text: &str) -> PathBuf {
        let p = self.0.join(name);
        if let Some(parent) = p.parent() {
            std::fs::create_dir_all(parent).unwrap();
        }
        std::fs::write(&p, text).unwrap();
        p
    }
}

impl Drop for Dir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

const SENSOR: &str = r#"<sensor type="perspective"><film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="6"/></film></sensor>"#;

/// A scene whose body follows a sensor on line 2.
fn scene_text(body: &str) -> String {
    format!("<scene version=\"3.0.0\">\n{SENSOR}\n{body}\n</scene>\n")
}

fn load(dir: &Dir, body: &str) -> Result<Scene, SceneError> {
    let p = dir.write("scene.xml", &scene_text(body));
    scene::load(&p, &[])
}

fn load_ok(body: &str) -> Scene {
    let d = Dir::new("ok");
    load(&d, body).unwrap_or_else(|e| panic!("{e}"))
}

fn load_err(body: &str) -> SceneError {
    let d = Dir::new("err");
    let e = load(&d, body).expect_err("expected an error");
    assert_eq!(
        e.at.file.file_name().and_then(|f| f.to_str()),
        Some("scene.xml")
    );
    e
}

fn close(a: Vec3, b: Vec3) -> bool {
    (a - b).abs().max_element() < 1e-4
}

fn constant(t: &Texture) -> Vec3 {
    match t {
        Texture::Constant(c) => *c,
        other => panic!("expected a constant texture, got {other:?}"),
    }
}

const QUAD_OBJ: &str = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvn 0 0 1\nf 1/1/1 2/2/1 3/3/1 4/4/1\n";

// ---------- grammar ----------

#[test]
fn defaults_are_substituted_and_defines_override_them() {
    let d = Dir::new("defaults");
    let p = d.write(
        "scene.xml",
        r#"<scene version="3.0.0">
<default name="spp" value="16"/>
<default name="res" value="32"/>
<sensor type="perspective"><sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>
<film type="hdrfilm"><integer name="width" value="$res"/><integer name="height" value="$res"/></film></sensor>
</scene>"#,
    );
    let s = scene::load(&p, &[]).unwrap();
    assert_eq!((s.sampler.sample_count, s.film.width), (16, 32));
    let s = scene::load(&p, &[("spp".into(), "3".into())]).unwrap();
    assert_eq!((s.sampler.sample_count, s.film.width), (3, 32));
    // A define the scene never uses is reported.
    let s = scene::load(&p, &[("nope".into(), "1".into())]).unwrap();
    assert!(
        s.warnings.iter().any(|w| w.message.contains("nope")),
        "{:?}",
        s.warnings
    );
}

#[test]
fn unset_parameter_is_an_error_at_its_line() {
    let e = load_err(
        "<integrator type=\"path\">\n<integer name=\"max_depth\" value=\"$depth\"/></integrator>",
    );
    assert_eq!(e.at.line, 4);
    assert!(e.message.contains("$depth"), "{e}");
}

#[test]
fn version_is_required() {
    let d = Dir::new("version");
    let p = d.write("scene.xml", &format!("<scene>\n{SENSOR}\n</scene>"));
    let e = scene::load(&p, &[]).unwrap_err();
    assert_eq!(e.at.line, 1);
    assert!(e.message.contains("version"), "{e}");
}

#[test]
fn include_alias_path_and_named_refs() {
    let d = Dir::new("include");
    d.write("meshes/quad.obj", QUAD_OBJ);
    d.write(
        "parts/materials.xml",
        r#"<scene version="3.0.0">
<bsdf type="diffuse" id="red"><rgb name="reflectance" value="0.8, 0.1, 0.1"/></bsdf>
<texture type="checkerboard" id="checks"/>
</scene>"#,
    );
    let p = d.write(
        "scene.xml",
        &scene_text(
            r#"<include filename="parts/materials.xml"/>
<alias id="red" as="crimson"/>
<path value="meshes"/>
<shape type="obj"><string name="filename" value="quad.obj"/><ref id="crimson"/></shape>
<shape type="obj"><string name="filename" value="quad.obj"/>
  <bsdf type="diffuse"><ref name="reflectance" id="checks"/></bsdf></shape>"#,
        ),
    );
    let s = scene::load(&p, &[]).unwrap();
    assert_eq!(s.meshes.len(), 2);
    match &s.materials[s.meshes[0].material as usize] {
        Bsdf::Diffuse { reflectance } => {
            assert!(close(constant(reflectance), Vec3::new(0.8, 0.1, 0.1)))
        }
        b => panic!("{b:?}"),
    }
    match &s.materials[s.meshes[1].material as usize] {
        Bsdf::Diffuse {
            reflectance: Texture::Checkerboard { color0, color1, .. },
        } => {
            // Mitsuba's checkerboard defaults.
            assert!(close(*color0, Vec3::splat(0.4)) && close(*color1, Vec3::splat(0.2)));
        }
        b => panic!("{b:?}"),
    }
}

#[test]
fn unknown_ref_is_an_error_at_its_line() {
    let e = load_err("<shape type=\"rectangle\">\n<ref id=\"nothing\"/></shape>");
    assert_eq!(e.at.line, 4);
    assert!(e.message.contains("nothing"), "{e}");
}

#[test]
fn transforms_compose_by_left_multiplication() {
    let s = load_ok(
        r#"<shape type="rectangle"><transform name="to_world">
  <scale value="2"/><translate x="1"/><rotate y="1" angle="90"/>
</transform></shape>
<shape type="rectangle"><transform name="to_world"><matrix value="1 0 0 5  0 1 0 6  0 0 1 7  0 0 0 1"/></transform></shape>
<shape type="rectangle"><transform name="to_world"><matrix value="0 -1 0  1 0 0  0 0 1"/></transform></shape>"#,
    );
    // scale 2, then translate x by 1, then rotate 90° about y: (1,1,0) → (2,2,0) → (3,2,0) → (0,2,-3).
    let expected = Mat4::from_rotation_y(90f32.to_radians())
        * Mat4::from_translation(Vec3::X)
        * Mat4::from_scale(Vec3::splat(2.0));
    let corner = s.meshes[0].positions[3];
    assert!(
        close(corner, expected.transform_point3(Vec3::new(1.0, 1.0, 0.0))),
        "{corner}"
    );
    assert!(close(corner, Vec3::new(0.0, 2.0, -3.0)), "{corner}");
    // A 4×4 matrix is written row by row.
    assert!(close(s.meshes[1].positions[0], Vec3::new(4.0, 5.0, 7.0)));
    // A 3×3 matrix is the linear part: (x, y) → (-y, x).
    assert!(close(s.meshes[2].positions[1], Vec3::new(1.0, 1.0, 0.0)));
}

#[test]
fn lookat_builds_mitsubas_camera_frame() {
    let d = Dir::new("lookat");
    let p = d.write(
        "scene.xml",
        r#"<scene version="3.0.0"><sensor type="perspective">
<float name="fov" value="30"/><string name="fov_axis" value="smaller"/>
<float name="near_clip" value="0.5"/><float name="far_clip" value="50"/>
<transform name="to_world"><lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/></transform>
</sensor></scene>"#,
    );
    let s = scene::load(&p, &[]).unwrap();
    let m = s.camera.to_world;
    assert!(close(m.w_axis.truncate(), Vec3::new(0.0, 0.0, 5.0)));
    assert!(close(m.z_axis.truncate(), Vec3::NEG_Z));
    assert!(close(m.y_axis.truncate(), Vec3::Y));
    // left = up × dir = y × -z = -x.
    assert!(close(m.x_axis.truncate(), Vec3::NEG_X));
    assert_eq!(
        (s.camera.fov_degrees, s.camera.fov_axis),
        (30.0, FovAxis::Smaller)
    );
    assert_eq!((s.camera.near_clip, s.camera.far_clip), (0.5, 50.0));
    // Mitsuba's defaults: 768×576, gaussian filter, 4 spp, path.
    assert_eq!(
        (s.film.width, s.film.height, s.film.filter),
        (768, 576, Filter::Gaussian { stddev: 0.5 })
    );
    assert_eq!(s.sampler.sample_count, 4);
    assert!(
        matches!(s.integrator, Integrator::Path(p) if p.max_depth.is_none() && p.rr_depth == 5)
    );
}

#[test]
fn focal_length_is_a_diagonal_field_of_view() {
    let d = Dir::new("focal");
    let p = d.write(
        "scene.xml",
        r#"<scene version="3.0.0"><sensor type="perspective"><string name="focal_length" value="28mm"/></sensor></scene>"#,
    );
    let s = scene::load(&p, &[]).unwrap();
    let expected = 2.0
        * ((36f32 * 36.0 + 24.0 * 24.0).sqrt() / 56.0)
            .atan()
            .to_degrees();
    assert!((s.camera.fov_degrees - expected).abs() < 1e-3);
    assert_eq!(s.camera.fov_axis, FovAxis::Diagonal);
}

#[test]
fn colours_points_and_spectra() {
    let s = load_ok(
        r#"<shape type="sphere"><point name="center" x="1" y="2" z="3"/><float name="radius" value="0.5"/>
  <bsdf type="diffuse"><spectrum name="reflectance" value="400:0.1, 500:0.5, 600:0.8, 700:0.2"/></bsdf>
  <emitter type="area"><spectrum name="radiance" value="2"/></emitter></shape>
<shape type="sphere"><point name="center" value="0, 0, 0"/><bsdf type="diffuse"><rgb name="reflectance" value="0.25"/></bsdf></shape>"#,
    );
    assert_eq!(s.spheres.len(), 2);
    assert!(close(s.spheres[0].center, Vec3::new(1.0, 2.0, 3.0)));
    assert_eq!(s.spheres[0].radius, 0.5);
    let refl = match &s.materials[s.spheres[0].material as usize] {
        Bsdf::Diffuse { reflectance } => constant(reflectance),
        b => panic!("{b:?}"),
    };
    // Mitsuba 3.9.1 scalar_rgb: spectrum_list_to_srgb(..., bounded, d65).
    assert!(
        (refl - Vec3::new(0.731215, 0.646851, 0.271934))
            .abs()
            .max_element()
            < 2e-4,
        "{refl}"
    );
    // A uniform spectrum in an emitter is value · xyz_to_srgb(1,1,1), as in Mitsuba.
    let e = constant(s.spheres[0].emission.as_ref().unwrap());
    assert!(
        (e - Vec3::new(2.40958, 1.896582, 1.817832))
            .abs()
            .max_element()
            < 1e-4,
        "{e}"
    );
    match &s.materials[s.spheres[1].material as usize] {
        Bsdf::Diffuse { reflectance } => assert!(close(constant(reflectance), Vec3::splat(0.25))),
        b => panic!("{b:?}"),
    }
}

#[test]
fn version_0_5_files_are_upgraded() {
    let d = Dir::new("v05");
    d.write("tex.png", "");
    let p = d.write(
        "scene.xml",
        r#"<scene version="0.5.0">
<integrator type="path"><integer name="maxDepth" value="7"/><integer name="rrDepth" value="3"/></integrator>
<sensor type="perspective"><float name="fov" value="60"/><string name="fovAxis" value="y"/>
  <sampler type="independent"><integer name="sampleCount" value="9"/></sampler></sensor>
<bsdf type="diffuse" id="a"><rgb name="diffuseReflectance" value="0.3"/></bsdf>
<bsdf type="plastic" id="b"><float name="intIOR" value="1.7"/>
  <texture type="checkerboard" name="diffuseReflectance"><float name="uscale" value="4"/><float name="voffset" value="0.5"/></texture></bsdf>
<shape type="rectangle"><ref id="a"/></shape>
<shape type="rectangle"><ref id="b"/></shape>
</scene>"#,
    );
    let s = scene::load(&p, &[]).unwrap();
    assert!(
        matches!(s.integrator, Integrator::Path(p) if p.max_depth == Some(7) && p.rr_depth == 3)
    );
    assert_eq!((s.camera.fov_axis, s.sampler.sample_count), (FovAxis::Y, 9));
    match &s.materials[s.meshes[0].material as usize] {
        Bsdf::Diffuse { reflectance } => assert!(close(constant(reflectance), Vec3::splat(0.3))),
        b => panic!("{b:?}"),
    }
    match &s.materials[s.meshes[1].material as usize] {
        Bsdf::Plastic {
            int_ior,
            diffuse_reflectance: Texture::Checkerboard { to_uv, .. },
            ..
        } => {
            assert_eq!(*int_ior, 1.7);
            // to_uv = scale(uscale, vscale) · translate(uoffset, voffset).
            let uv = *to_uv * Vec3::new(0.25, 0.0, 1.0);
            assert!(close(uv, Vec3::new(1.0, 0.5, 1.0)), "{uv}");
        }
        b => panic!("{b:?}"),
    }
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
}

// ---------- plugins ----------

#[test]
fn integrators() {
    let s = load_ok(
        r#"<integrator type="direct"><integer name="emitter_samples" value="3"/><boolean name="hide_emitters" value="true"/></integrator>"#,
    );
    match s.integrator {
        Integrator::Direct(d) => assert_eq!(
            (d.emitter_samples, d.bsdf_samples, d.hide_emitters),
            (3, 1, true)
        ),
        i => panic!("{i:?}"),
    }
    let s = load_ok(
        r#"<integrator type="aov"><string name="aovs" value="albedo:albedo, nn:sh_normal,dd:depth,uv:uv"/></integrator>"#,
    );
    match &s.integrator {
        Integrator::Aov(a) => {
            let got: Vec<_> = a.iter().map(|a| (a.name.as_str(), a.kind)).collect();
            assert_eq!(
                got,
                [
                    ("albedo", AovKind::Albedo),
                    ("nn", AovKind::ShadingNormal),
                    ("dd", AovKind::Depth)
                ]
            );
        }
        i => panic!("{i:?}"),
    }
    assert!(
        s.warnings
            .iter()
            .any(|w| w.message.contains("\"uv\"") && w.at.line == 3),
        "{:?}",
        s.warnings
    );
    let s = load_ok(
        r#"<integrator type="moment"><integrator type="path"><integer name="max_depth" value="2"/><boolean name="hide_emitters" value="true"/></integrator></integrator>"#,
    );
    assert!(
        matches!(s.integrator, Integrator::Path(p) if p.max_depth == Some(2) && p.hide_emitters)
    );
    assert!(s.warnings.iter().any(|w| w.message.contains("moment")));
}

#[test]
fn films_filters_and_samplers() {
    let d = Dir::new("film");
    for (filter, expected) in [
        ("<rfilter type=\"box\"/>", Filter::Box),
        ("<rfilter type=\"tent\"/>", Filter::Tent { radius: 1.0 }),
        (
            "<rfilter type=\"gaussian\"><float name=\"stddev\" value=\"0.25\"/></rfilter>",
            Filter::Gaussian { stddev: 0.25 },
        ),
    ] {
        let p = d.write(
            "scene.xml",
            &format!(
                r#"<scene version="3.0.0"><sensor type="perspective"><film type="hdrfilm"><integer name="width" value="20"/><integer name="height" value="10"/>{filter}</film>
<sampler type="stratified"><integer name="sample_count" value="5"/><integer name="seed" value="7"/></sampler></sensor></scene>"#
            ),
        );
        let s = scene::load(&p, &[]).unwrap();
        assert_eq!(
            (s.film.width, s.film.height, s.film.filter),
            (20, 10, expected)
        );
        assert_eq!((s.sampler.sample_count, s.sampler.seed), (5, 7));
        assert!(s.warnings.iter().any(|w| w.message.contains("stratified")));
    }
}

#[test]
fn mesh_shapes_read_files_transform_and_flags() {
    let d = Dir::new("meshes");
    d.write("quad.obj", QUAD_OBJ);
    let p = d.write(
        "scene.xml",
        &scene_text(
            r#"<shape type="obj" id="q"><string name="filename" value="quad.obj"/>
  <transform name="to_world"><translate z="2"/></transform></shape>
<shape type="obj"><string name="filename" value="quad.obj"/><boolean name="face_normals" value="true"/>
  <boolean name="flip_normals" value="true"/><boolean name="flip_tex_coords" value="false"/></shape>
<shape type="cube"/>
<shape type="disk"/>"#,
        ),
    );
    let s = scene::load(&p, &[]).unwrap();
    let q = &s.meshes[0];
    assert_eq!(
        (q.name.as_str(), q.positions.len(), q.indices.len()),
        ("q", 4, 2)
    );
    assert!(close(q.positions[2], Vec3::new(1.0, 1.0, 2.0)));
    assert_eq!(q.normals.len(), 4);
    // Mitsuba flips v by default.
    assert_eq!(q.uvs[0], Vec2::new(0.0, 1.0));
    let flat = &s.meshes[1];
    assert!(flat.normals.is_empty() && flat.flip_normals);
    assert_eq!(flat.uvs[0], Vec2::new(0.0, 0.0));
    assert_eq!(s.meshes[2].indices.len(), 12);
    assert!(s.meshes[3].indices.len() >= 64);
    // No BSDF: Mitsuba's default diffuse 0.5, shared.
    assert_eq!(q.material, flat.material);
    assert!(
        matches!(&s.materials[q.material as usize], Bsdf::Diffuse { reflectance } if close(constant(reflectance), Vec3::splat(0.5)))
    );
}

#[test]
fn ply_meshes_are_read_through_optik_io() {
    let d = Dir::new("ply");
    d.write(
        "tri.ply",
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
         element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
    );
    let p = d.write(
        "scene.xml",
        &scene_text(
            r#"<shape type="ply"><string name="filename" value="tri.ply"/>
  <transform name="to_world"><scale value="2"/></transform></shape>"#,
        ),
    );
    let s = scene::load(&p, &[]).unwrap();
    assert_eq!(s.meshes[0].indices, vec![[0, 1, 2]]);
    assert_eq!(s.meshes[0].positions[2], Vec3::new(0.0, 2.0, 0.0));
    let e =
        load_err("<shape type=\"ply\">\n<string name=\"filename\" value=\"none.ply\"/></shape>");
    assert_eq!(e.at.line, 4);
}

#[test]
fn output_formats_are_accepted_quietly() {
    let d = Dir::new("formats");
    let p = d.write(
        "scene.xml",
        r#"<scene version="3.0.0"><sensor type="perspective"><film type="hdrfilm">
<string name="pixel_format" value="rgb"/><string name="component_format" value="float32"/>
<string name="file_format" value="png"/>
</film></sensor></scene>"#,
    );
    let s = scene::load(&p, &[]).unwrap();
    assert_eq!(s.warnings.len(), 1, "{:?}", s.warnings);
    assert_eq!(s.warnings[0].at.line, 3);
}

#[test]
fn missing_mesh_file_is_an_error_at_its_line() {
    let e =
        load_err("<shape type=\"obj\">\n<string name=\"filename\" value=\"nowhere.obj\"/></shape>");
    assert_eq!(e.at.line, 4);
    assert!(e.message.contains("nowhere.obj"), "{e}");
}

#[test]
fn spheres_keep_similarity_transforms_and_tessellate_otherwise() {
    let s = load_ok(
        r#"<shape type="sphere"><float name="radius" value="2"/><transform name="to_world"><rotate x="1" angle="30"/><scale value="3"/><translate x="1"/></transform></shape>
<shape type="sphere"><transform name="to_world"><scale x="1" y="2" z="1"/></transform></shape>"#,
    );
    assert_eq!(s.spheres.len(), 1);
    assert!((s.spheres[0].radius - 6.0).abs() < 1e-5);
    assert!(close(s.spheres[0].center, Vec3::new(1.0, 0.0, 0.0)));
    assert_eq!(s.meshes.len(), 1);
    let (lo, hi) = scene::shapes::bounds(&s.meshes[0].positions);
    assert!(close(hi - lo, Vec3::new(2.0, 4.0, 2.0)), "{lo} {hi}");
    assert!(
        s.warnings
            .iter()
            .any(|w| w.at.line == 4 && w.message.contains("tessellated"))
    );
}

#[test]
fn shapegroups_and_instances() {
    let s = load_ok(
        r#"<shape type="shapegroup" id="g"><shape type="cube"/><shape type="sphere"/></shape>
<shape type="instance"><ref id="g"/><transform name="to_world"><translate x="5"/></transform></shape>
<shape type="instance"><ref id="g"/></shape>"#,
    );
    assert_eq!(s.groups.len(), 1);
    assert_eq!(
        (s.groups[0].meshes.len(), s.groups[0].spheres.len()),
        (1, 1)
    );
    assert_eq!(s.instances.len(), 2);
    assert_eq!(
        s.instances[0].to_world,
        Mat4::from_translation(Vec3::new(5.0, 0.0, 0.0))
    );
    assert!(s.meshes.is_empty() && s.spheres.is_empty());
    assert_eq!(s.placed_shapes().count(), 4);
}

#[test]
fn bsdfs_with_mitsubas_defaults() {
    let s = load_ok(
        r#"<shape type="cube"><bsdf type="conductor"/></shape>
<shape type="cube"><bsdf type="conductor"><string name="material" value="Au"/></bsdf></shape>
<shape type="cube"><bsdf type="roughconductor"><rgb name="eta" value="1, 2, 3"/><float name="k" value="4"/>
  <string name="distribution" value="ggx"/><float name="alpha_u" value="0.1"/><float name="alpha_v" value="0.3"/>
  <boolean name="sample_visible" value="false"/></bsdf></shape>
<shape type="cube"><bsdf type="dielectric"><string name="int_ior" value="water"/><float name="ext_ior" value="1.1"/></bsdf></shape>
<shape type="cube"><bsdf type="thindielectric"/></shape>
<shape type="cube"><bsdf type="roughdielectric"/></shape>
<shape type="cube"><bsdf type="plastic"/></shape>
<shape type="cube"><bsdf type="roughplastic"><float name="alpha" value="0.2"/><boolean name="nonlinear" value="true"/></bsdf></shape>
<shape type="cube"><bsdf type="mask"><float name="opacity" value="0.25"/><bsdf type="twosided"><bsdf type="diffuse"/></bsdf></bsdf></shape>
<shape type="cube"><bsdf type="twosided"><bsdf type="diffuse"/><bsdf type="conductor"/></bsdf></shape>"#,
    );
    let m: Vec<&Bsdf> = s
        .meshes
        .iter()
        .map(|m| &s.materials[m.material as usize])
        .collect();
    match m[0] {
        Bsdf::Conductor {
            eta,
            k,
            specular_reflectance,
        } => {
            assert_eq!((*eta, *k), (Vec3::ZERO, Vec3::ONE));
            assert_eq!(constant(specular_reflectance), Vec3::ONE);
        }
        b => panic!("{b:?}"),
    }
    match m[1] {
        // Mitsuba 3.9.1 scalar_rgb, conductor material="Au".
        Bsdf::Conductor { eta, k, .. } => {
            assert!(
                (*eta - Vec3::new(0.143036, 0.375307, 1.442045))
                    .abs()
                    .max_element()
                    < 1e-5,
                "{eta}"
            );
            assert!(
                (*k - Vec3::new(3.982997, 2.385556, 1.603359))
                    .abs()
                    .max_element()
                    < 1e-5,
                "{k}"
            );
        }
        b => panic!("{b:?}"),
    }
    match m[2] {
        Bsdf::RoughConductor {
            eta,
            k,
            roughness,
            sample_visible,
            ..
        } => {
            assert_eq!(
                (*eta, *k, *sample_visible),
                (Vec3::new(1.0, 2.0, 3.0), Vec3::splat(4.0), false)
            );
            assert_eq!(
                (roughness.distribution, roughness.alpha_u, roughness.alpha_v),
                (Microfacet::Ggx, 0.1, 0.3)
            );
        }
        b => panic!("{b:?}"),
    }
    match m[3] {
        Bsdf::Dielectric {
            int_ior, ext_ior, ..
        } => assert_eq!((*int_ior, *ext_ior), (1.333, 1.1)),
        b => panic!("{b:?}"),
    }
    match m[4] {
        Bsdf::ThinDielectric {
            int_ior, ext_ior, ..
        } => assert_eq!((*int_ior, *ext_ior), (1.5046, 1.000277)),
        b => panic!("{b:?}"),
    }
    match m[5] {
        Bsdf::RoughDielectric {
            roughness,
            sample_visible,
            ..
        } => {
            assert_eq!(
                (roughness.distribution, roughness.alpha_u, *sample_visible),
                (Microfacet::Beckmann, 0.1, true)
            );
        }
        b => panic!("{b:?}"),
    }
    match m[6] {
        Bsdf::Plastic {
            diffuse_reflectance,
            int_ior,
            nonlinear,
            ..
        } => {
            assert_eq!(
                (constant(diffuse_reflectance), *int_ior, *nonlinear),
                (Vec3::splat(0.5), 1.49, false)
            );
        }
        b => panic!("{b:?}"),
    }
    match m[7] {
        Bsdf::RoughPlastic {
            roughness,
            nonlinear,
            ..
        } => assert_eq!((roughness.alpha_u, *nonlinear), (0.2, true)),
        b => panic!("{b:?}"),
    }
    match m[8] {
        Bsdf::Mask { opacity, inner } => {
            assert_eq!(constant(opacity), Vec3::splat(0.25));
            assert!(matches!(**inner, Bsdf::TwoSided { .. }));
        }
        b => panic!("{b:?}"),
    }
    match m[9] {
        Bsdf::TwoSided { front, back } => {
            assert!(
                matches!(**front, Bsdf::Diffuse { .. }) && matches!(**back, Bsdf::Conductor { .. })
            );
        }
        b => panic!("{b:?}"),
    }
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
}

#[test]
fn bad_bsdf_parameters_are_errors() {
    let e = load_err(
        "<shape type=\"cube\"><bsdf type=\"dielectric\">\n<string name=\"int_ior\" value=\"unobtainium\"/></bsdf></shape>",
    );
    assert_eq!(e.at.line, 4);
    let e = load_err(
        "<shape type=\"cube\"><bsdf type=\"conductor\">\n<string name=\"material\" value=\"Kryptonite\"/></bsdf></shape>",
    );
    assert_eq!(e.at.line, 4);
}

#[test]
fn an_unknown_wrap_mode_is_an_error() {
    let d = Dir::new("wrap");
    image::RgbImage::from_raw(1, 1, vec![1, 2, 3])
        .unwrap()
        .save(d.0.join("t.png"))
        .unwrap();
    let p = d.write(
        "scene.xml",
        &scene_text(
            "<shape type=\"cube\"><bsdf type=\"diffuse\"><texture type=\"bitmap\" name=\"reflectance\">\n<string name=\"filename\" value=\"t.png\"/>\n<string name=\"wrap_mode\" value=\"tile\"/></texture></bsdf></shape>",
        ),
    );
    let e = scene::load(&p, &[]).unwrap_err();
    assert!(e.message.contains("repeat, mirror, clamp"), "{e}");
}

#[test]
fn textures_bitmap_and_checkerboard() {
    let d = Dir::new("tex");
    let png = d.0.join("t.png");
    image::RgbImage::from_raw(2, 2, vec![255, 0, 0, 0, 255, 0, 0, 0, 255, 128, 128, 128])
        .unwrap()
        .save(&png)
        .unwrap();
    let p = d.write(
        "scene.xml",
        &scene_text(
            r#"<shape type="cube"><bsdf type="diffuse"><texture type="bitmap" name="reflectance">
  <string name="filename" value="t.png"/><string name="filter_type" value="nearest"/>
  <transform name="to_uv"><scale x="2" y="3"/><translate x="0.5"/></transform></texture></bsdf></shape>
<shape type="cube"><bsdf type="diffuse"><texture type="bitmap" name="reflectance">
  <string name="filename" value="t.png"/><boolean name="raw" value="true"/><string name="wrap_mode" value="mirror"/></texture></bsdf></shape>
<shape type="cube"><bsdf type="diffuse"><texture type="bitmap" name="reflectance">
  <string name="filename" value="t.png"/></texture></bsdf></shape>
<shape type="cube"><bsdf type="diffuse"><texture type="checkerboard" name="reflectance">
  <rgb name="color0" value="1, 0, 0"/><rgb name="color1" value="0, 0, 1"/></texture></bsdf></shape>"#,
        ),
    );
    let s = scene::load(&p, &[]).unwrap();
    let tex = |i: usize| match &s.materials[s.meshes[i].material as usize] {
        Bsdf::Diffuse { reflectance } => reflectance.clone(),
        b => panic!("{b:?}"),
    };
    let Texture::Bitmap {
        image,
        to_uv,
        bilinear,
        wrap,
    } = tex(0)
    else {
        panic!()
    };
    assert!(!bilinear);
    assert_eq!(wrap, optik_render::scene::WrapMode::Repeat);
    assert_eq!(
        to_uv,
        Mat3::from_cols(
            Vec3::new(2.0, 0.0, 0.0),
            Vec3::new(0.0, 3.0, 0.0),
            Vec3::new(0.5, 0.0, 1.0)
        )
    );
    let img = &s.images[image as usize];
    assert_eq!((img.width, img.height), (2, 2));
    assert!(
        (img.texels[3].x - 0.215861).abs() < 1e-4,
        "sRGB 128 → linear"
    );
    let Texture::Bitmap {
        image: raw,
        bilinear,
        wrap,
        ..
    } = tex(1)
    else {
        panic!()
    };
    assert!(bilinear);
    assert_eq!(wrap, optik_render::scene::WrapMode::Mirror);
    assert!((s.images[raw as usize].texels[3].x - 128.0 / 255.0).abs() < 1e-6);
    // The same file with the same decoding is loaded once.
    let Texture::Bitmap { image: again, .. } = tex(2) else {
        panic!()
    };
    assert_eq!(again, image);
    assert_eq!(s.images.len(), 2);
    let Texture::Checkerboard { color0, color1, .. } = tex(3) else {
        panic!()
    };
    assert_eq!((color0, color1), (Vec3::X, Vec3::Z));
}

#[test]
fn emitters() {
    let d = Dir::new("emitters");
    let hdr = d.0.join("sky.hdr");
    image::Rgb32FImage::from_raw(2, 1, vec![1.0, 2.0, 3.0, 0.5, 0.5, 0.5])
        .unwrap()
        .save(&hdr)
        .unwrap();
    let p = d.write(
        "scene.xml",
        &scene_text(
            r#"<emitter type="point"><point name="position" value="1, 2, 3"/><rgb name="intensity" value="10, 20, 30"/></emitter>
<emitter type="point"><transform name="to_world"><translate y="4"/></transform></emitter>
<emitter type="spot"><float name="cutoff_angle" value="40"/><transform name="to_world"><lookat origin="0,5,0" target="0,0,0"/></transform></emitter>
<emitter type="directional"><vector name="direction" value="0, -2, 0"/><float name="irradiance" value="3"/></emitter>
<emitter type="directional"><transform name="to_world"><rotate x="1" angle="90"/></transform></emitter>
<emitter type="constant"><rgb name="radiance" value="0.5"/></emitter>
<emitter type="envmap"><string name="filename" value="sky.hdr"/><float name="scale" value="2"/></emitter>
<shape type="rectangle"><emitter type="area"><rgb name="radiance" value="5, 6, 7"/></emitter></shape>"#,
        ),
    );
    let s = scene::load(&p, &[]).unwrap();
    let e = &s.emitters;
    assert_eq!(e.len(), 7);
    assert_eq!(
        e[0],
        Emitter::Point {
            position: Vec3::new(1.0, 2.0, 3.0),
            intensity: Vec3::new(10.0, 20.0, 30.0)
        }
    );
    assert_eq!(
        e[1],
        Emitter::Point {
            position: Vec3::new(0.0, 4.0, 0.0),
            intensity: Vec3::ONE
        }
    );
    match &e[2] {
        Emitter::Spot {
            to_world,
            cutoff_angle,
            beam_width,
            intensity,
        } => {
            assert_eq!(
                (*cutoff_angle, *beam_width, *intensity),
                (40.0, 30.0, Vec3::ONE)
            );
            assert!(close(to_world.z_axis.truncate(), Vec3::NEG_Y));
        }
        x => panic!("{x:?}"),
    }
    assert_eq!(
        e[3],
        Emitter::Directional {
            direction: Vec3::NEG_Y,
            irradiance: Vec3::splat(3.0)
        }
    );
    match &e[4] {
        Emitter::Directional { direction, .. } => assert!(close(*direction, Vec3::NEG_Y)),
        x => panic!("{x:?}"),
    }
    assert_eq!(
        e[5],
        Emitter::Constant {
            radiance: Vec3::splat(0.5)
        }
    );
    match &e[6] {
        Emitter::EnvMap { image, scale, .. } => {
            assert_eq!(*scale, 2.0);
            assert_eq!(
                s.images[*image as usize].texels[0],
                Vec3::new(1.0, 2.0, 3.0)
            );
        }
        x => panic!("{x:?}"),
    }
    assert_eq!(
        constant(s.meshes[0].emission.as_ref().unwrap()),
        Vec3::new(5.0, 6.0, 7.0)
    );
}

// ---------- errors and warnings ----------

#[test]
fn no_sensor_is_an_error() {
    let d = Dir::new("nosensor");
    let p = d.write(
        "scene.xml",
        "<scene version=\"3.0.0\">\n<shape type=\"cube\"/>\n</scene>",
    );
    let e = scene::load(&p, &[]).unwrap_err();
    assert_eq!(e.at.line, 1);
    assert!(e.message.contains("sensor"), "{e}");
}

#[test]
fn malformed_numbers_are_errors_at_their_line() {
    for body in [
        "<integrator type=\"path\">\n<integer name=\"max_depth\" value=\"2.5\"/></integrator>",
        "<shape type=\"sphere\">\n<float name=\"radius\" value=\"one\"/></shape>",
        "<shape type=\"sphere\">\n<point name=\"center\" value=\"1, 2\"/></shape>",
        "<shape type=\"cube\"><bsdf type=\"diffuse\">\n<rgb name=\"reflectance\" value=\"1, 2\"/></bsdf></shape>",
        "<shape type=\"cube\"><transform name=\"to_world\">\n<matrix value=\"1 2 3\"/></transform></shape>",
        "<shape type=\"cube\"><bsdf type=\"diffuse\">\n<spectrum name=\"reflectance\" value=\"400:x, 500:1\"/></bsdf></shape>",
    ] {
        let e = load_err(body);
        assert_eq!(e.at.line, 4, "{body}: {e}");
    }
}

#[test]
fn malformed_xml_is_an_error_at_its_line() {
    let e = load_err("<shape type=\"cube\">\n<float name=\"x\" value=\"1\"></shape>");
    assert_eq!(e.at.line, 4, "{e}");
}

#[test]
fn unsupported_plugins_and_unused_properties_are_warnings_at_their_line() {
    let s = load_ok(
        r#"<emitter type="sunsky"/>
<shape type="cube"><float name="banana" value="1"/></shape>
<shape type="cylinder"/>
<shape type="cube"><bsdf type="phong"/></shape>
<medium type="homogeneous"/>"#,
    );
    let at = |line: u32, needle: &str| {
        assert!(
            s.warnings.iter().any(|w| w.at.line == line
                && w.message.contains(needle)
                && w.at.file.ends_with("scene.xml")),
            "no warning on line {line} about {needle}: {:?}",
            s.warnings
        )
    };
    at(3, "sunsky");
    at(4, "banana");
    at(5, "cylinder");
    at(6, "phong");
    at(7, "medium");
    assert_eq!(s.meshes.len(), 2);
}

// ---------- real scenes ----------

/// The Breakfast Room's scene.mitsuba.xml names one OBJ per mesh (models/MeshNNN.obj); the
/// shared folder keeps them merged in breakfast_room.obj, one `o MeshNNN` per file. The test
/// splits them back (re-basing indices) next to a copy of the XML, then loads it.
#[test]
fn breakfast_room_xml_loads_with_warnings() {
    let src = Path::new("/work/shared/scenes/breakfast-room");
    if !src.join("scene.mitsuba.xml").exists() {
        eprintln!(
            "skipped: {} is absent (shared scenes are optional, DESIGN.md §9)",
            src.display()
        );
        return;
    }
    let d = Dir::new("breakfast");
    let merged = std::fs::read_to_string(src.join("breakfast_room.obj")).unwrap();
    split_objects(&merged, &d.0.join("models"));
    std::os::unix::fs::symlink(src.join("textures"), d.0.join("textures")).unwrap();
    std::fs::copy(src.join("scene.mitsuba.xml"), d.0.join("scene.xml")).unwrap();
    let s = scene::load(&d.0.join("scene.xml"), &[]).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!((s.film.width, s.film.height), (1280, 720));
    assert_eq!(s.camera.fov_degrees, 60.0);
    assert!(matches!(s.film.filter, Filter::Tent { .. }));
    assert!(matches!(s.integrator, Integrator::Path(p) if p.max_depth == Some(65)));
    assert_eq!(s.sampler.sample_count, 64);
    // 52 OBJ shapes and one rectangle (whose two triangles the merged file also holds).
    assert_eq!(s.meshes.len(), 53);
    let triangles: usize = s.meshes.iter().map(|m| m.indices.len()).sum();
    assert_eq!(triangles, 269_538);
    assert_eq!(s.materials.len(), 15);
    assert_eq!(s.images.len(), 3);
    // The sun and sky are not supported: no emitter, and a warning saying so.
    assert!(s.emitters.is_empty());
    let warned = |needle: &str| s.warnings.iter().any(|w| w.message.contains(needle));
    assert!(warned("sunsky"), "{:?}", s.warnings);
    assert!(
        warned("strict_normals") && warned("ldrfilm") && warned("sobol") && warned("trilinear")
    );
    let gold = s.materials.iter().find(|m| {
        matches!(m, Bsdf::TwoSided { front, .. } if matches!(**front, Bsdf::RoughConductor { eta, .. } if (eta.x - 0.143119).abs() < 1e-6))
    });
    assert!(gold.is_some());
}

/// Writes each `o NAME` object of a merged OBJ as NAME.obj with its own 1-based indices.
fn split_objects(merged: &str, dir: &Path) {
    std::fs::create_dir_all(dir).unwrap();
    let mut counts = [0i64; 3];
    let mut base = [0i64; 3];
    let mut current: Option<(String, String)> = None;
    let flush = |cur: &mut Option<(String, String)>| {
        if let Some((name, text)) = cur.take() {
            std::fs::write(dir.join(format!("{name}.obj")), text).unwrap();
        }
    };
    for line in merged.lines() {
        if let Some(name) = line.strip_prefix("o ") {
            flush(&mut current);
            base = counts;
            current = Some((name.trim().to_string(), String::new()));
            continue;
        }
        let Some((_, text)) = current.as_mut() else {
            continue;
        };
        let kind = line.split_whitespace().next().unwrap_or("");
        match kind {
            "v" => counts[0] += 1,
            "vt" => counts[1] += 1,
            "vn" => counts[2] += 1,
            "f" => {
                text.push('f');
                for corner in line.split_whitespace().skip(1) {
                    let parts: Vec<String> = corner
                        .split('/')
                        .enumerate()
                        .map(|(k, p)| {
                            if p.is_empty() {
                                String::new()
                            } else {
                                (p.parse::<i64>().unwrap() - base[k]).to_string()
                            }
                        })
                        .collect();
                    text.push(' ');
                    text.push_str(&parts.join("/"));
                }
                text.push('\n');
                continue;
            }
            _ => {}
        }
        text.push_str(line);
        text.push('\n');
    }
    flush(&mut current);
}

/// The committed Breakfast Room scene (render/validation/make_breakfast_room.py).
fn breakfast_room_xml() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("validation/scenes/breakfast_room.xml")
}

/// The committed per-material PLY meshes load through the XML as the scene's 18 meshes with
/// every triangle of the source OBJ (269 538 `f` lines in shared/scenes/breakfast-room, all
/// triangles; the per-material OBJs loaded to the same count), flat-shaded meshes without
/// normals and smooth ones with one normal and one uv per vertex.
#[test]
fn breakfast_room_loads_from_committed_ply_meshes() {
    let scene = scene::load(&breakfast_room_xml(), &[]).expect("the Breakfast Room loads");
    assert_eq!(scene.meshes.len(), 18, "one mesh per (material, shading)");
    let triangles: usize = scene.meshes.iter().map(|m| m.indices.len()).sum();
    assert_eq!(triangles, 269_538);
    let flat = scene.meshes.iter().filter(|m| m.normals.is_empty()).count();
    assert_eq!(flat, 8, "the _flat meshes (face_normals) carry no normals");
    for m in &scene.meshes {
        assert!(!m.indices.is_empty(), "{} has triangles", m.name);
        assert!(
            m.normals.is_empty() || m.normals.len() == m.positions.len(),
            "{}: one normal per vertex",
            m.name
        );
        assert_eq!(
            m.uvs.len(),
            m.positions.len(),
            "{}: one uv per vertex",
            m.name
        );
        let n = m.positions.len() as u32;
        assert!(m.indices.iter().flatten().all(|&i| i < n), "{}", m.name);
    }
}

/// Bit for bit, the PLY meshes hold what the per-material OBJs they replaced (from which the
/// references were rendered) load to: positions, normals, uvs (the OBJ's flipped v), triangles
/// and materials, through the same XML. Ignored because the OBJs (25 MB) are not committed.
#[test]
#[ignore = "needs the per-material OBJs: python3 render/validation/make_breakfast_room.py \
            --obj-dir DIR, then OPTIK_BREAKFAST_ROOM_OBJ=DIR"]
fn breakfast_room_ply_matches_obj() {
    let obj_dir =
        PathBuf::from(std::env::var("OPTIK_BREAKFAST_ROOM_OBJ").expect(
            "OPTIK_BREAKFAST_ROOM_OBJ names the folder of make_breakfast_room.py --obj-dir",
        ));
    let xml = breakfast_room_xml();
    let meshes = xml.parent().unwrap().join("breakfast_room");
    let text = std::fs::read_to_string(&xml).unwrap();
    let mut obj_xml = String::new();
    for line in text.lines() {
        let line = if let Some(name) = line
            .split("value=\"breakfast_room/")
            .nth(1)
            .and_then(|rest| rest.strip_suffix(".ply\"/>"))
        {
            format!(
                "<string name=\"filename\" value=\"{}\"/>",
                obj_dir.join(format!("{name}.obj")).display()
            )
        } else {
            line.replace("<shape type=\"ply\">", "<shape type=\"obj\">")
                .replace(
                    "value=\"breakfast_room/",
                    &format!("value=\"{}/", meshes.display()),
                )
        };
        obj_xml.push_str(&line);
        obj_xml.push('\n');
    }
    assert!(
        !obj_xml.contains(".ply"),
        "every mesh now refers to its OBJ"
    );
    let dir = Dir::new("breakfast-obj");
    let obj = scene::load(&dir.write("breakfast_room_obj.xml", &obj_xml), &[]).unwrap();
    let ply = scene::load(&xml, &[]).unwrap();
    assert_eq!(obj.meshes.len(), ply.meshes.len());
    let v3 = |v: &[Vec3]| -> Vec<[u32; 3]> {
        v.iter().map(|p| p.to_array().map(f32::to_bits)).collect()
    };
    let v2 = |v: &[Vec2]| -> Vec<[u32; 2]> {
        v.iter().map(|p| p.to_array().map(f32::to_bits)).collect()
    };
    for (o, p) in obj.meshes.iter().zip(&ply.meshes) {
        assert_eq!(v3(&o.positions), v3(&p.positions), "{} positions", p.name);
        assert_eq!(v3(&o.normals), v3(&p.normals), "{} normals", p.name);
        assert_eq!(v2(&o.uvs), v2(&p.uvs), "{} uvs", p.name);
        assert_eq!(o.indices, p.indices, "{} triangles", p.name);
        assert_eq!(o.material, p.material, "{} material", p.name);
    }
}
