#![no_main]

// Built only with `--features uci` (`required-features` in Cargo.toml).
libfuzzer_sys::fuzz_target!(|data: &[u8]| chessarm_fuzz::check_uci_line(data));
