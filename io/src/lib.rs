//! optik-io: reading and writing the files optik's command, renderer and benches share.
