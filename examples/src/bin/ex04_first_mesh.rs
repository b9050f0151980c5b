//! Runs the course step `ex04_first_mesh` (see `optik_examples::ex04_first_mesh`); `--help` lists the options.
fn main() {
    optik_examples::cli::main("ex04_first_mesh", optik_examples::ex04_first_mesh::run);
}
