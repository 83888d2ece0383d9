//! Writing result files whole or not at all: every file is written to a temporary file in the
//! destination folder and renamed into place only once complete.

use anyhow::{Context, Result};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// Creates `dir` (and parents) if needed.
pub fn ensure_dir(dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create output folder {}", dir.display()))
}

fn parent_of(path: &Path) -> &Path {
    match path.parent() {
        Some(parent) if !parent.as_os_str().is_empty() => parent,
        _ => Path::new("."),
    }
}

/// Result files are ordinary files (rw-r--r--), not the 0600 of a temporary file.
fn readable_by_all() -> std::fs::Permissions {
    use std::os::unix::fs::PermissionsExt;
    std::fs::Permissions::from_mode(0o644)
}

/// Writes `path` through `write` into a temporary sibling, then renames it into place.
pub fn write_atomic(path: &Path, write: impl FnOnce(&mut dyn Write) -> Result<()>) -> Result<()> {
    let parent = parent_of(path);
    ensure_dir(parent)?;
    let temporary = tempfile::Builder::new()
        .prefix(".chessarm-")
        .suffix(".part")
        .permissions(readable_by_all())
        .tempfile_in(parent)
        .with_context(|| format!("cannot create a temporary file in {}", parent.display()))?;
    {
        let mut writer = BufWriter::new(temporary.as_file());
        write(&mut writer).with_context(|| format!("while writing {}", path.display()))?;
        writer.flush().with_context(|| format!("while writing {}", path.display()))?;
    }
    temporary.persist(path).with_context(|| format!("cannot move the finished file to {}", path.display()))?;
    Ok(())
}

/// Renders a file whose writer needs a path with the right extension (e.g. a PNG from
/// plotters): `render` writes to a temporary sibling path, which is then renamed into place.
pub fn render_atomic(path: &Path, render: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
    let parent = parent_of(path);
    ensure_dir(parent)?;
    let extension = path.extension().map(|e| format!(".{}", e.to_string_lossy())).unwrap_or_default();
    let temporary = tempfile::Builder::new()
        .prefix(".chessarm-")
        .suffix(&extension)
        .permissions(readable_by_all())
        .tempfile_in(parent)
        .with_context(|| format!("cannot create a temporary file in {}", parent.display()))?;
    let temporary_path: PathBuf = temporary.path().to_path_buf();
    render(&temporary_path).with_context(|| format!("while rendering {}", path.display()))?;
    temporary.persist(path).with_context(|| format!("cannot move the finished file to {}", path.display()))?;
    Ok(())
}

/// Writes a CSV file with a header and numeric rows.
pub fn write_csv<I, R>(path: &Path, header: &[String], rows: I) -> Result<()>
where
    I: IntoIterator<Item = R>,
    R: AsRef<[f64]>,
{
    write_atomic(path, |writer| {
        let mut csv = csv::Writer::from_writer(writer);
        csv.write_record(header)?;
        let mut buffer: Vec<String> = Vec::new();
        for row in rows {
            buffer.clear();
            // Debug formatting is the shortest round-trip form, in exponent notation when tiny.
            buffer.extend(row.as_ref().iter().map(|v| format!("{v:?}")));
            csv.write_record(&buffer)?;
        }
        csv.flush()?;
        Ok(())
    })
}

/// Writes pretty JSON.
pub fn write_json(path: &Path, value: &serde_json::Value) -> Result<()> {
    write_atomic(path, |writer| {
        serde_json::to_writer_pretty(&mut *writer, value)?;
        writeln!(writer)?;
        Ok(())
    })
}

/// Column names `prefix1 .. prefixN`.
pub fn numbered(prefix: &str, count: usize) -> impl Iterator<Item = String> + '_ {
    (1..=count).map(move |i| format!("{prefix}{i}"))
}

/// Deletes result files left by an earlier run, so a failed run cannot leave them looking
/// like its own.
pub fn remove_stale(paths: &[PathBuf]) -> Result<()> {
    for path in paths {
        match std::fs::remove_file(path) {
            Ok(()) => {}
            Err(error) if error.kind() == std::io::ErrorKind::NotFound => {}
            Err(error) => return Err(error).with_context(|| format!("cannot remove the old {}", path.display())),
        }
    }
    Ok(())
}
