//! Runs the course step `ex08_textures` (see `optik_examples::ex08_textures`); `--help` lists the options.
fn main() {
    optik_examples::cli::main("ex08_textures", optik_examples::ex08_textures::run);
}
