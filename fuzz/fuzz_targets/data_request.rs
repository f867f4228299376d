//! `cargo +nightly fuzz run data_request`: see rome_tests::decoders::data_request.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| rome_tests::decoders::data_request(data));
