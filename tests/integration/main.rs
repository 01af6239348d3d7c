//! One integration test binary (one link under fat LTO); a module per concept.

mod amanatides_woo;
mod batch_cli;
mod bricks;
mod conformance;
mod conservative;
mod demo;
mod formats;
mod fuzz_regressions;
mod images;
mod lattice;
mod line2d;
mod lines;
mod mesh_formats;
mod mesh_io;
mod raster;
mod render;
mod render_cli;
mod render_volume;
mod report_cli;
mod solid;
mod strategies;
mod topology;
mod triangle_index;
mod tunnels;
mod volume_io;
mod voxelize;
