//! A version of the project as it goes up from the ground
//! (`petrel_core::mirror::upload`): its files
//! (`mirror::upload::files_bytes`) compressed with zstd, and back, bounded.
//! The core never compresses: zstd is a C library, and the decisions
//! crate builds none.

/// The most a version sent up unpacks to: a project's text.
pub const UNPACKED_AT_MOST: usize = 8 << 20;

/// A version's files packed for the uplink.
pub fn pack(files: &[(String, String)]) -> Result<Vec<u8>, String> {
    zstd::bulk::compress(&petrel_core::mirror::upload::files_bytes(files), 19)
        .map_err(|e| format!("cannot compress the version: {e}"))
}

/// [`pack`] undone, at most [`UNPACKED_AT_MOST`] bytes; paths inside a
/// project only.
pub fn unpack(bytes: &[u8]) -> Result<Vec<(String, String)>, String> {
    let raw = zstd::bulk::decompress(bytes, UNPACKED_AT_MOST).map_err(|e| {
        format!("the version's bytes do not unpack (zstd, at most {UNPACKED_AT_MOST} bytes): {e}")
    })?;
    petrel_core::mirror::upload::files_from(&raw)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_version_packs_small_and_unpacks_whole_and_a_bomb_is_refused() {
        let files = vec![
            (
                "project.toml".to_owned(),
                "[[net]]\nfile = \"n.toml\"\n".repeat(200),
            ),
            ("n.toml".to_owned(), "name = \"N\"\n".repeat(500)),
        ];
        let packed = pack(&files).expect("packs");
        assert!(packed.len() < 1_000, "{}", packed.len());
        assert_eq!(unpack(&packed), Ok(files));
        // 16 MiB of zeros: more than a project unpacks to.
        let bomb = zstd::bulk::compress(&vec![0u8; 16 << 20], 3).expect("compresses");
        assert!(unpack(&bomb).is_err_and(|e| e.contains("at most")));
        assert!(unpack(b"not zstd").is_err());
    }
}
