//! Reading the user's input files with a bound on their size, so that a wrong path
//! (`/dev/zero`, a video, a 400 MB generated file) is one clear error rather than memory
//! filled or a parser aborting.

use anyhow::{Context, Result, bail};
use std::io::Read;
use std::path::Path;

/// Largest setup, uncertainty or sensor file, bytes (1 MB): the report's setup is 6 kB.
pub const MAX_SETUP_BYTES: u64 = 1_000_000;

/// Largest URDF file, bytes (16 MB): the official descriptions of small arms are 5–60 kB, and
/// a robot with meshes keeps them in files of their own.
pub const MAX_URDF_BYTES: u64 = 16_000_000;

/// The text of the file at `path`, at most `max_bytes` long; `what` names it in the messages
/// (`arm file`, `--uncertainty`).
///
/// Reads at most `max_bytes + 1` bytes whatever the file claims (a device such as `/dev/zero`
/// has no length), so memory stays bounded.
///
/// # Errors
///
/// The file cannot be opened or read, is a folder, is longer than `max_bytes`, or is not UTF-8.
pub fn read_text(what: &str, path: &Path, max_bytes: u64) -> Result<String> {
    let file = std::fs::File::open(path).with_context(|| format!("{what} {}: cannot read", path.display()))?;
    if file.metadata().is_ok_and(|m| m.is_dir()) {
        bail!("{what} {}: is a folder, not a file", path.display());
    }
    let mut bytes = Vec::new();
    file.take(max_bytes + 1)
        .read_to_end(&mut bytes)
        .with_context(|| format!("{what} {}: cannot read", path.display()))?;
    if bytes.len() as u64 > max_bytes {
        bail!(
            "{what} {}: longer than {} (the most chessarm reads of such a file); is it the right file?",
            path.display(),
            crate::app::resources::show_bytes(max_bytes as f64)
        );
    }
    String::from_utf8(bytes).map_err(|e| {
        anyhow::anyhow!("{what} {}: not UTF-8 text (from byte offset {})", path.display(), e.utf8_error().valid_up_to())
    })
}
