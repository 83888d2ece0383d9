#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| chessarm_fuzz::check_bus_feetech(data));
