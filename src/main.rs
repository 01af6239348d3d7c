//! The `voxkit` command line. Thin: parsing, dispatch and exit codes live in
//! [`voxkit::cli`].

/// Large buffers on transparent huge pages: first touches of fresh memory
/// are a large part of a voxelization's time (see [`voxkit::alloc`]).
#[global_allocator]
static ALLOC: voxkit::alloc::HugePageAlloc = voxkit::alloc::HugePageAlloc;

fn main() {
    std::process::exit(voxkit::cli::main());
}
