//! The tokenizer and parser on arbitrary bytes: never panic, never hang, bounded memory.
#![no_main]

use libfuzzer_sys::fuzz_target;
use lumo_converters::legacy;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        let _ = legacy::parse(text);
    }
});
