//! Runs the course step `ex12_denoising` (see `optik_examples::ex12_denoising`); `--help` lists the options.
fn main() {
    optik_examples::cli::main("ex12_denoising", optik_examples::ex12_denoising::run);
}
