//! Fuzzes the render-pass list parser behind `lumo render --aov`, Python's `lumo.render(aov=…)`
//! and the pass names of partial-film headers with arbitrary bytes. It may not panic, and:
//! - a list that parses prints (as `--aov` and headers print it) and parses back to itself;
//! - every pass of a parsed list is named in the input, and an input naming no pass (only
//!   commas, spaces and `none`) is the empty set;
//! - a list that fails names the offending pass and the choices.
//!
//! Seed corpus: `corpus/aov_list/`.
#![no_main]

use libfuzzer_sys::fuzz_target;
use lumo::aov::{Aov, AovSet};

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    match text.parse::<AovSet>() {
        Ok(set) => {
            let printed = set.to_string();
            assert_eq!(printed.parse::<AovSet>().as_ref(), Ok(&set), "{printed:?}");
            let named: Vec<&str> = text.split(',').map(str::trim).collect();
            for aov in set.iter() {
                assert!(named.contains(&aov.name()), "{aov} from {text:?}");
            }
            if named.iter().all(|n| n.is_empty() || *n == "none") {
                assert!(set.is_empty(), "{text:?} gave {set}");
            }
        }
        Err(message) => {
            assert!(message.starts_with("unknown render pass `"), "{message}");
            for aov in Aov::ALL {
                assert!(message.contains(aov.name()), "{message}");
            }
        }
    }
});
