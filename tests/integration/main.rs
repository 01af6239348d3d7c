//! One integration test binary (one link under fat LTO); a module per concept.

mod amanatides_woo;
mod line2d;
mod lines;
mod topology;
