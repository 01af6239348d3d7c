//! TEMPORARY SCAFFOLD: replaced by its owner before landing.
