#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| chessarm_fuzz::check_live_request(data));
