//! TEMPORARY SCAFFOLD: replaced by its owner before landing.

pub mod tunnels;

pub use tunnels::{
    PatchVerdict, TunnelVerdict, closed_surface_tunnels, count_empty_components,
    patch_sides_connected, tunnel_path,
};
