//! `cargo +nightly fuzz run robot_command`: see rome_tests::decoders::robot_command.
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| rome_tests::decoders::robot_command(data));
