//! Runs the course step `ex05_sbt_data` (see `optik_examples::ex05_sbt_data`); `--help` lists the options.
fn main() {
    optik_examples::cli::main("ex05_sbt_data", optik_examples::ex05_sbt_data::run);
}
