//! Runs the course step `ex09_shadows` (see `optik_examples::ex09_shadows`); `--help` lists the options.
fn main() {
    optik_examples::cli::main("ex09_shadows", optik_examples::ex09_shadows::run);
}
