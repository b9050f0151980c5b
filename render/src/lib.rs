//! optik-render: a path tracer built only on optik's public API.
//!
//! Scenes come from Mitsuba 3 XML files or OBJ+MTL models ([`scene`]); the renderer derives
//! the features a scene calls for and builds its pipeline from them.

pub mod scene;
pub mod validate;
