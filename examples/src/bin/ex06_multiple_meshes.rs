//! Runs the course step `ex06_multiple_meshes` (see `optik_examples::ex06_multiple_meshes`); `--help` lists the options.
fn main() {
    optik_examples::cli::main(
        "ex06_multiple_meshes",
        optik_examples::ex06_multiple_meshes::run,
    );
}
