//! Runs the course step `ex02_pipeline` (see `optik_examples::ex02_pipeline`); `--help` lists the options.
fn main() {
    optik_examples::cli::main("ex02_pipeline", optik_examples::ex02_pipeline::run);
}
