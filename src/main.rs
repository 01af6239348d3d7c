//! The `voxkit` command line. Thin: parsing, dispatch and exit codes live in
//! [`voxkit::cli`].

fn main() {
    std::process::exit(voxkit::cli::main());
}
