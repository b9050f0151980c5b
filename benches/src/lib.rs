//! optik-benches: criterion benches and the benchmark report. Not implemented yet.
