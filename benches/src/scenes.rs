//! The throughput benchmark's scenes and ray sets: the Stanford bunny and the Breakfast Room,
//! each with camera rays and incoherent rays (all with `tmin = 0`, which the Embree peer
//! needs).
//!
//! The scene files are not part of the repository. They are looked for in `$OPTIK_SCENES`,
//! else in `../shared/scenes` next to the repository root (where the project keeps them);
//! [`find`] says where it looked when a file is missing, so benchmarks can skip with a clear
//! message.

use crate::mesh::Mesh;
use crate::rays;
use std::path::{Path, PathBuf};

/// The environment variable naming the scenes folder.
pub const SCENES_ENV: &str = "OPTIK_SCENES";

/// A benchmark scene: a mesh file and how to make its camera rays.
#[derive(Clone, Copy, Debug)]
pub struct Scene {
    /// Short name for tables.
    pub name: &'static str,
    /// The mesh, relative to the scenes folder.
    pub file: &'static str,
    /// The camera rays.
    pub camera: Camera,
}

/// How a scene's camera rays are made.
#[derive(Clone, Copy, Debug)]
pub enum Camera {
    /// From outside the bounding box along this direction, framing the box
    /// ([`rays::camera`]).
    Framing([f32; 3]),
    /// A pinhole at `eye` looking along `view` with `up` roughly up and this horizontal field of
    /// view in degrees ([`rays::camera_at`]): the scene's own camera.
    At {
        /// Position.
        eye: [f32; 3],
        /// Viewing direction.
        view: [f32; 3],
        /// Up.
        up: [f32; 3],
        /// Horizontal field of view, degrees.
        fov: f32,
    },
}

/// The Stanford bunny (69 451 triangles), seen from the front.
pub const BUNNY: Scene = Scene {
    name: "bunny",
    file: "stanford-bunny/stanford-bunny.obj",
    camera: Camera::Framing([0.0, -0.2, -1.0]),
};

/// The Breakfast Room (269 538 triangles) through the camera of its Mitsuba scene (inside the
/// room; `scene.mitsuba.xml`'s sensor: 60° horizontal field of view).
pub const BREAKFAST_ROOM: Scene = Scene {
    name: "breakfast room",
    file: "breakfast-room/breakfast_room.obj",
    camera: Camera::At {
        eye: [-0.587317, 2.7623, 9.71429],
        view: [0.013058, -0.063863, -0.997873],
        up: [0.000835626, 0.997959, -0.0638576],
        fov: 60.0,
    },
};

/// Both benchmark scenes.
pub const ALL: [Scene; 2] = [BUNNY, BREAKFAST_ROOM];

/// Camera image size: 640 × 360.
pub const CAMERA_SIZE: (u32, u32) = (640, 360);
/// Incoherent rays per set (as many as the camera's).
pub const INCOHERENT_RAYS: usize = 640 * 360;

/// The scenes folder: `$OPTIK_SCENES`, else `../shared/scenes` next to the repository root.
pub fn folder() -> PathBuf {
    match std::env::var_os(SCENES_ENV) {
        Some(dir) => PathBuf::from(dir),
        None => Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/scenes"),
    }
}

/// The file of `scene`, or a message saying where it was looked for and how to point there.
pub fn find(scene: &Scene) -> Result<PathBuf, String> {
    let path = folder().join(scene.file);
    if path.is_file() {
        Ok(path)
    } else {
        Err(format!(
            "{} not found at {}; set {SCENES_ENV} to the folder holding {}",
            scene.name,
            path.display(),
            scene.file
        ))
    }
}

/// A set of rays (`RAY_FLOATS` floats each).
#[derive(Clone, Debug)]
pub struct RaySet {
    /// `camera` or `incoherent`.
    pub name: &'static str,
    /// The rays.
    pub rays: Vec<f32>,
}

/// The camera rays of `scene` over `mesh` at `width` × `height`: what `bench-cpu` traces (at
/// [`CAMERA_SIZE`]) and `optik bench-report` too (at its own size), so both measure the same
/// views.
pub fn camera_rays(scene: &Scene, mesh: &Mesh, width: u32, height: u32) -> Vec<f32> {
    match scene.camera {
        Camera::Framing(view) => rays::camera(mesh, width, height, view),
        Camera::At { eye, view, up, fov } => {
            rays::camera_at(eye, view, up, fov.to_radians(), width, height)
        }
    }
}

/// The camera and incoherent rays of `scene` over `mesh`.
pub fn ray_sets(scene: &Scene, mesh: &Mesh) -> [RaySet; 2] {
    let (w, h) = CAMERA_SIZE;
    [
        RaySet {
            name: "camera",
            rays: camera_rays(scene, mesh, w, h),
        },
        RaySet {
            name: "incoherent",
            rays: rays::incoherent(mesh, INCOHERENT_RAYS, 7),
        },
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn missing_scenes_say_where_they_were_looked_for() {
        let bogus = Scene {
            name: "nothing",
            file: "no/such/file.obj",
            camera: Camera::Framing([0.0, 0.0, -1.0]),
        };
        let message = find(&bogus).unwrap_err();
        assert!(
            message.contains("no/such/file.obj") && message.contains(SCENES_ENV),
            "{message}"
        );
    }

    #[test]
    fn ray_sets_start_at_zero() {
        let m = Mesh {
            positions: vec![[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 1.0]],
            triangles: vec![[0, 1, 2]],
            ..Mesh::default()
        };
        for scene in ALL {
            for set in ray_sets(&scene, &m) {
                assert!(
                    set.rays.chunks_exact(8).all(|r| r[3] == 0.0),
                    "{}",
                    set.name
                );
                assert_eq!(set.rays.len() / 8, INCOHERENT_RAYS);
            }
        }
    }
}
