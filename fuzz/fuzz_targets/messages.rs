//! `cargo +nightly fuzz run messages`: see rome_tests::decoders::messages.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| rome_tests::decoders::messages(data));
