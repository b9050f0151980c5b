//! optik-render: a path tracer built only on optik's public API.
//!
//! Scenes come from Mitsuba 3 XML files or OBJ+MTL models ([`scene`]); the renderer derives
//! the features a scene calls for ([`features`]) and builds its pipeline from them: one
//! closest-hit program per BSDF kind present, a shadow ray type only where next-event
//! estimation applies, payload registers sized by the integrator. [`render()`] returns a
//! [`Frame`] with the per-pixel mean and variance; [`output`] writes EXR and PNG files;
//! [`probe`] runs the renderer's own BSDF code on given directions.

mod camera;
pub mod denoise;
mod error;
pub mod features;
pub mod geometry;
mod gpu;
pub mod material;
pub mod modes;
pub mod output;
pub mod plan;
pub mod probe;
mod programs;
mod render;
mod roughplastic;
pub mod scene;
pub mod validate;

pub use error::RenderError;
pub use features::RenderFeatures;
pub use plan::{Effects, PipelinePlan};
pub use render::{
    AovImage, Frame, Progress, RenderOptions, RenderStats, Renderer, render, render_with_progress,
};

#[cfg(test)]
mod tests;
