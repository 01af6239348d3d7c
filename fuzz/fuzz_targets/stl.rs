#![no_main]
// See voxkit::fuzz_entry::stl.
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let _ = voxkit::fuzz_entry::stl(data);
});
