//! Content hashes: SHA-256 of bytes and of files, as lower-case hexadecimal. Scene content
//! hashes ([`crate::load::Loaded::content_hash`]), partial films' seals and build ids
//! ([`crate::partial_film`]) all use these.

use std::io::Read;
use std::path::Path;

use sha2::Digest;

/// SHA-256 of some bytes.
pub fn sha256(bytes: &[u8]) -> [u8; 32] {
    sha2::Sha256::digest(bytes).into()
}

/// SHA-256 of a file's bytes, streamed through a small buffer (a big mesh is not held in memory
/// a second time). Errors name the file.
pub fn sha256_file(path: &Path) -> std::io::Result<[u8; 32]> {
    let named =
        |e: std::io::Error| std::io::Error::new(e.kind(), format!("{}: {e}", path.display()));
    let mut file = std::fs::File::open(path).map_err(named)?;
    let mut hasher = sha2::Sha256::new();
    let mut buf = vec![0u8; 1 << 20];
    loop {
        match file.read(&mut buf) {
            Ok(0) => break,
            Ok(n) => hasher.update(&buf[..n]),
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(named(e)),
        }
    }
    Ok(hasher.finalize().into())
}

/// Lower-case hexadecimal.
pub fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn known_digest() {
        // FIPS 180-2, appendix B.1.
        assert_eq!(
            hex(&sha256(b"abc")),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
    }

    #[test]
    fn file_digest_is_the_bytes_digest() {
        let dir = tempfile::tempdir().expect("temp dir");
        let path = dir.path().join("f.bin");
        let bytes: Vec<u8> = (0..3_000_000u32).map(|i| (i * 7 % 251) as u8).collect();
        std::fs::write(&path, &bytes).expect("write");
        assert_eq!(sha256_file(&path).expect("read"), sha256(&bytes));
        let missing = sha256_file(&dir.path().join("nope")).expect_err("missing file");
        assert!(missing.to_string().contains("nope"), "{missing}");
    }
}
