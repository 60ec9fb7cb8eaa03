//! libFuzzer entry for `yubin_scene::fuzzing::xml`.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| yubin_scene::fuzzing::xml(data));
