//! Benchmark entry point (written later in this file).
