//! One integration test binary (one link under fat LTO); a module per concept.

mod lines;
mod topology;
