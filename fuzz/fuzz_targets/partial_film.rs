//! Fuzzes the partial-film reader (`lumo merge`, `--resume`) with arbitrary bytes: it must return
//! an error or a film, never panic or allocate without bound. Each input is read twice: as a
//! file (whole-file checksum first) and as a bare archive (past the checksum, which random bytes
//! never match, so that the zip, .npy and header checks are exercised). Seed corpus:
//! `corpus/partial_film/` (small films written by `lumo render --samples … --film`).
#![no_main]

use libfuzzer_sys::fuzz_target;
use lumo::partial_film::PartialFilm;

fuzz_target!(|data: &[u8]| {
    let _ = PartialFilm::from_bytes(data);
    if let Ok(film) = PartialFilm::from_archive_bytes(data) {
        // A film that parses is consistent: every pixel holds the samples the header lists.
        let spp = film.header.spp();
        assert!(film
            .film
            .counts()
            .iter()
            .all(|&c| u64::from(c) == spp));
    }
});
