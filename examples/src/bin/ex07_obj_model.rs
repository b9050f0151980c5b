//! Runs the course step `ex07_obj_model` (see `optik_examples::ex07_obj_model`); `--help` lists the options.
fn main() {
    optik_examples::cli::main("ex07_obj_model", optik_examples::ex07_obj_model::run);
}
