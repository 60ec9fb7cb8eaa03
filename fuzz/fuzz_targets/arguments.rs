//! libFuzzer entry for `yubin::fuzz_arguments` (the command line).
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| yubin::fuzz_arguments(data));
