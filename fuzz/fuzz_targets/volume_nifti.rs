#![no_main]
// See voxkit::fuzz_entry::volume_nifti.
libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let _ = voxkit::fuzz_entry::volume_nifti(data);
});
