//! Rules that hold on every backend and that no catalog case checks, each tested once, on a
//! fresh device of every backend (`kit::rig::on_every_backend`; a backend that cannot run
//! here is skipped and named). Modules are named after the catalog groups whose rules they
//! extend. Launches are tiny and pipelines few: lavapipe compiles each pipeline slowly.

mod aabb;
mod call;
mod exc;
mod inst;
mod launch;
mod motion;
mod prim;
mod sbt;
