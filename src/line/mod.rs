//! TEMPORARY SCAFFOLD: replaced by its owner before landing.

pub mod amanatides_woo;
pub mod line2d;
