//! `cargo +nightly fuzz run stickrep`: see rome_tests::decoders::stickrep.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| rome_tests::decoders::stickrep(data));
