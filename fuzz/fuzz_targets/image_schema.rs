//! `cargo +nightly fuzz run image_schema`: see rome_tests::decoders::image_schema.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| rome_tests::decoders::image_schema(data));
