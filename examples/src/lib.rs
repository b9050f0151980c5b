//! The OptiX 7 course (Ingo Wald's `optix7course`) as headless Rust programs on optik's API.
//!
//! Each step is a module with `run(device, options) -> Image` and a program in `src/bin/` that
//! calls it and writes the image; `tests/course.rs` runs every step at a small size and
//! compares it with a blessed EXR in `references/`. Read them in order: each adds one idea.
//!
//! | step | adds |
//! |---|---|
//! | [`ex02_pipeline`] | module, program groups, pipeline, SBT, launch (a test pattern) |
//! | [`ex04_first_mesh`] | a triangle mesh, its acceleration structure, a pinhole camera |
//! | [`ex05_sbt_data`] | per-mesh data in the SBT's hit records |
//! | [`ex06_multiple_meshes`] | several meshes, one build input and SBT record each |
//! | [`ex07_obj_model`] | an OBJ model |
//! | [`ex08_textures`] | shading normals, texture coordinates, textures and a sampler |
//! | [`ex09_shadows`] | a second ray type: shadow rays to a point light |
//! | [`ex10_soft_shadows`] | an area light, random numbers, several samples per pixel |
//! | [`ex11_accumulation`] | frames accumulated into a running mean |
//! | [`ex12_denoising`] | albedo and normal outputs, and a denoiser guided by them |

pub mod cli;
pub mod common;
pub mod ex02_pipeline;
pub mod ex04_first_mesh;
pub mod ex05_sbt_data;
pub mod ex06_multiple_meshes;
pub mod ex07_obj_model;
pub mod ex08_textures;
pub mod ex09_shadows;
pub mod ex10_soft_shadows;
pub mod ex11_accumulation;
pub mod ex12_denoising;
pub mod meshes;
pub mod scenes;

use common::{Image, Options, Result};

/// A step of the course: its name and the function that renders it.
pub struct Step {
    /// The program's name (`ex04_first_mesh`).
    pub name: &'static str,
    /// Renders the step's image.
    pub run: fn(&dyn optik::Device, &Options) -> Result<Image>,
}

/// Every step, in course order.
pub const STEPS: &[Step] = &[
    Step {
        name: "ex02_pipeline",
        run: ex02_pipeline::run,
    },
    Step {
        name: "ex04_first_mesh",
        run: ex04_first_mesh::run,
    },
    Step {
        name: "ex05_sbt_data",
        run: ex05_sbt_data::run,
    },
    Step {
        name: "ex06_multiple_meshes",
        run: ex06_multiple_meshes::run,
    },
    Step {
        name: "ex07_obj_model",
        run: ex07_obj_model::run,
    },
    Step {
        name: "ex08_textures",
        run: ex08_textures::run,
    },
    Step {
        name: "ex09_shadows",
        run: ex09_shadows::run,
    },
    Step {
        name: "ex10_soft_shadows",
        run: ex10_soft_shadows::run,
    },
    Step {
        name: "ex11_accumulation",
        run: ex11_accumulation::run,
    },
    Step {
        name: "ex12_denoising",
        run: ex12_denoising::run,
    },
];
