//! `cargo +nightly fuzz run serial`: see rome_tests::decoders::serial.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| rome_tests::decoders::serial(data));
