//! Runs the course step `ex10_soft_shadows` (see `optik_examples::ex10_soft_shadows`); `--help` lists the options.
fn main() {
    optik_examples::cli::main("ex10_soft_shadows", optik_examples::ex10_soft_shadows::run);
}
