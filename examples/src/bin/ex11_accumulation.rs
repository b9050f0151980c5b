//! Runs the course step `ex11_accumulation` (see `optik_examples::ex11_accumulation`); `--help` lists the options.
fn main() {
    optik_examples::cli::main("ex11_accumulation", optik_examples::ex11_accumulation::run);
}
