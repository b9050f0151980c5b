//! OBJ+MTL models as scenes: the material mapping, the framing camera and the default light,
//! and the Cornell box from the shared scenes.

use glam::Vec3;
use optik_render::scene::{self, Bsdf, Emitter, FovAxis, Microfacet, Texture};
use std::path::{Path, PathBuf};

struct Dir(PathBuf);

impl Dir {
    fn new(tag: &str) -> Dir {
        let d = std::env::temp_dir().join(format!("optik-scene-obj-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        Dir(d)
    }
    fn write(&self, name: &str, text: &str) -> PathBuf {
        let p = self.0.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }
}

impl Drop for Dir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// Strips the two-sided wrapper every non-refracting OBJ material gets.
fn front(b: &Bsdf) -> &Bsdf {
    match b {
        Bsdf::TwoSided { front, back } => {
            assert_eq!(front, back);
            front
        }
        other => panic!("expected a two-sided material, got {other:?}"),
    }
}

#[test]
fn mtl_materials_map_to_mitsuba_bsdfs() {
    let d = Dir::new("mtl");
    image::RgbImage::from_raw(1, 1, vec![255, 255, 255])
        .unwrap()
        .save(d.0.join("wood.png"))
        .unwrap();
    d.write(
        "m.mtl",
        "newmtl matte\nKd 0.5 0.25 0.125\n\
         newmtl textured\nKd 1 1 1\nmap_Kd wood.png\n\
         newmtl glossy\nKd 0.2 0.2 0.2\nKs 0.04 0.04 0.04\nNs 98\nNi 1.5\n\
         newmtl metal\nKd 0 0 0\nKs 0.9 0.8 0.7\nNs 100000\n\
         newmtl glass\nKd 0 0 0\nNi 1.33\nillum 7\n\
         newmtl veil\nKd 0.7 0.7 0.7\nd 0.25\n\
         newmtl lamp\nKd 0.5 0.5 0.5\nKe 4 3 2\n",
    );
    let mut obj = String::from("mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n");
    for (i, m) in [
        "matte", "textured", "glossy", "metal", "glass", "veil", "lamp",
    ]
    .iter()
    .enumerate()
    {
        obj.push_str(&format!("o part{i}\nusemtl {m}\nf 1 2 3 4\n"));
    }
    let s = scene::load(&d.write("m.obj", &obj), &[]).unwrap();
    assert_eq!(s.meshes.len(), 7);
    assert!(
        s.meshes.iter().all(|m| m.indices.len() == 2),
        "quads are triangulated"
    );
    let mat = |i: usize| &s.materials[s.meshes[i].material as usize];
    assert_eq!(
        front(mat(0)),
        &Bsdf::Diffuse {
            reflectance: Texture::Constant(Vec3::new(0.5, 0.25, 0.125))
        }
    );
    assert!(matches!(
        front(mat(1)),
        Bsdf::Diffuse {
            reflectance: Texture::Bitmap { .. }
        }
    ));
    match front(mat(2)) {
        Bsdf::RoughPlastic {
            diffuse_reflectance,
            specular_reflectance,
            int_ior,
            roughness,
            ..
        } => {
            assert_eq!(*diffuse_reflectance, Texture::Constant(Vec3::splat(0.2)));
            // Ks 0.04 is the coating's own Fresnel reflectance at normal incidence for Ni 1.5.
            let spec = match specular_reflectance {
                Texture::Constant(c) => *c,
                t => panic!("{t:?}"),
            };
            assert!((spec - Vec3::ONE).abs().max_element() < 1e-5, "{spec}");
            assert_eq!(*int_ior, 1.5);
            // alpha = sqrt(2 / (Ns + 2)) = sqrt(0.02).
            assert_eq!(roughness.distribution, Microfacet::Beckmann);
            assert!((roughness.alpha_u - 0.02f32.sqrt()).abs() < 1e-6);
        }
        b => panic!("{b:?}"),
    }
    assert_eq!(
        front(mat(3)),
        &Bsdf::Conductor {
            eta: Vec3::ZERO,
            k: Vec3::ONE,
            specular_reflectance: Texture::Constant(Vec3::new(0.9, 0.8, 0.7))
        }
    );
    assert!(matches!(mat(4), Bsdf::Dielectric { int_ior, .. } if *int_ior == 1.33));
    match mat(5) {
        Bsdf::Mask { opacity, inner } => {
            assert_eq!(*opacity, Texture::Constant(Vec3::splat(0.25)));
            assert!(matches!(front(inner), Bsdf::Diffuse { .. }));
        }
        b => panic!("{b:?}"),
    }
    assert_eq!(
        s.meshes[6].emission,
        Some(Texture::Constant(Vec3::new(4.0, 3.0, 2.0)))
    );
    assert!(s.meshes[..6].iter().all(|m| m.emission.is_none()));
    // An emitting material lights the model: no environment is added.
    assert!(s.emitters.is_empty());
}

#[test]
fn a_model_without_lights_gets_a_constant_environment_and_a_framing_camera() {
    let d = Dir::new("frame");
    let p = d.write(
        "box.obj",
        "v -1 0 -2\nv 3 0 -2\nv 3 2 -2\nv -1 2 -2\nf 1 2 3 4\n",
    );
    let s = scene::load(&p, &[]).unwrap();
    assert_eq!(
        s.emitters,
        vec![Emitter::Constant {
            radiance: Vec3::ONE
        }]
    );
    // No MTL: grey diffuse.
    let m = front(&s.materials[s.meshes[0].material as usize]);
    assert_eq!(
        m,
        &Bsdf::Diffuse {
            reflectance: Texture::Constant(Vec3::splat(0.5))
        }
    );
    let c = &s.camera;
    assert_eq!((c.fov_degrees, c.fov_axis), (45.0, FovAxis::Smaller));
    let eye = c.to_world.w_axis.truncate();
    let centre = Vec3::new(1.0, 1.0, -2.0);
    assert_eq!(c.to_world.z_axis.truncate(), Vec3::NEG_Z);
    assert!((eye.x - centre.x).abs() < 1e-6 && (eye.y - centre.y).abs() < 1e-6 && eye.z > centre.z);
    // The bounding sphere (radius √5) just fits the 45° view.
    let dist = eye.z - centre.z;
    assert!(((5f32.sqrt() / dist).asin().to_degrees() - 22.5).abs() < 1e-3);
    assert!(
        c.near_clip > 0.0
            && c.near_clip <= dist - 5f32.sqrt() + 1e-4
            && c.far_clip >= dist + 5f32.sqrt()
    );
}

#[test]
fn bad_inputs_are_errors() {
    let d = Dir::new("bad");
    let e = scene::load(&d.0.join("none.obj"), &[]).unwrap_err();
    assert!(e.message.contains("does not exist"), "{e}");
    let p = d.write("empty.obj", "v 0 0 0\n");
    assert!(
        scene::load(&p, &[])
            .unwrap_err()
            .message
            .contains("no triangles")
    );
    let p = d.write("x.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    assert!(
        scene::load(&p, &[("a".into(), "1".into())]).is_err(),
        "OBJ models take no defines"
    );
    let e = scene::load(&d.write("s.pbrt", ""), &[]).unwrap_err();
    assert!(
        e.message.contains(".xml") && e.message.contains(".obj"),
        "{e}"
    );
}

#[test]
fn cornell_box_loads_with_its_light() {
    let path = Path::new("/work/shared/scenes/cornell-box/CornellBox-Original.obj");
    if !path.exists() {
        eprintln!(
            "skipped: {} is absent (shared scenes are optional, DESIGN.md §9)",
            path.display()
        );
        return;
    }
    let s = scene::load(path, &[]).unwrap();
    let triangles: usize = s.meshes.iter().map(|m| m.indices.len()).sum();
    assert_eq!(triangles, 36);
    let lights: Vec<_> = s.meshes.iter().filter(|m| m.emission.is_some()).collect();
    assert_eq!(lights.len(), 1);
    assert_eq!(
        lights[0].emission,
        Some(Texture::Constant(Vec3::new(17.0, 12.0, 4.0)))
    );
    // The light faces down into the box: its winding's normal points to -y.
    let l = lights[0];
    let [a, b, c] = l.indices[0].map(|i| l.positions[i as usize]);
    assert!(
        (b - a).cross(c - a).y < 0.0,
        "the light must emit downwards"
    );
    assert!(s.emitters.is_empty());
    // The camera looks into the open side (+z) of the box.
    let eye = s.camera.to_world.w_axis.truncate();
    assert!(eye.z > 1.0 && eye.y > 0.5 && eye.y < 1.5);
    let red = s.materials.iter().any(|m| {
        matches!(m, Bsdf::TwoSided { front, .. } if **front == Bsdf::Diffuse { reflectance: Texture::Constant(Vec3::new(0.63, 0.065, 0.05)) })
    });
    assert!(red);
}
