//! Writing result files whole or not at all: every file is written to a temporary file in the
//! destination folder and renamed into place only once complete.
//!
//! Temporary files are named `.chessarm-<pid>-<random>.part[.ext]` and registered while they
//! exist: on SIGINT, SIGTERM or SIGHUP the handler installed by [`remove_temporaries_on_signal`]
//! deletes them before the program exits (a rename in progress finishes first, so a final file
//! is never truncated), and the first write into a folder deletes the temporary files that
//! earlier runs, no longer alive, left there (a `kill -9` cannot be caught).

use anyhow::{Context, Result};
use std::collections::HashSet;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard, PoisonError};

/// Temporary files of this process not yet renamed into place.
static PENDING: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());
/// Folders already swept of stale temporary files by this process.
static SWEPT: Mutex<Option<HashSet<PathBuf>>> = Mutex::new(None);

fn pending() -> MutexGuard<'static, Vec<PathBuf>> {
    PENDING.lock().unwrap_or_else(PoisonError::into_inner)
}

/// Exit code after a termination signal (128 + SIGINT, the shell's convention for Ctrl-C).
pub const SIGNAL_EXIT_CODE: i32 = 130;

/// Installs the handler that deletes this process's temporary files on SIGINT, SIGTERM or
/// SIGHUP and exits with [`SIGNAL_EXIT_CODE`].
///
/// # Errors
///
/// When the handler cannot be installed.
pub fn remove_temporaries_on_signal() -> Result<()> {
    ctrlc::set_handler(|| {
        // Engines run in process groups of their own, which the terminal's Ctrl-C misses.
        chessarm_chess::opponent::kill_all_engines();
        // Holding the lock until exit: no rename can start after the files are gone.
        let files = pending();
        for file in files.iter() {
            let _ = std::fs::remove_file(file);
        }
        std::process::exit(SIGNAL_EXIT_CODE);
    })
    .context("cannot install the signal handler")
}

const TEMPORARY_PREFIX: &str = ".chessarm-";

fn temporary_prefix() -> String {
    format!("{TEMPORARY_PREFIX}{}-", std::process::id())
}

/// Whether process `pid` is alive (Linux: it has a `/proc` entry).
fn process_alive(pid: u32) -> bool {
    Path::new("/proc").join(pid.to_string()).exists()
}

/// Deletes, once per folder and process, the temporary files in `dir` that a run no longer
/// alive left behind (interrupted by a signal that cannot be caught). Files of live runs and
/// every other file stay.
fn sweep_stale_temporaries(dir: &Path) {
    {
        let mut swept = SWEPT.lock().unwrap_or_else(PoisonError::into_inner);
        if !swept.get_or_insert_with(HashSet::new).insert(dir.to_path_buf()) {
            return;
        }
    }
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    for entry in entries.flatten() {
        let name = entry.file_name();
        let Some(name) = name.to_str() else { continue };
        let Some(rest) = name.strip_prefix(TEMPORARY_PREFIX) else { continue };
        if !rest.contains(".part") {
            continue;
        }
        // `<pid>-<random>.part…`; names without a pid come from older chessarm versions.
        let owner = rest.split_once('-').and_then(|(pid, _)| pid.parse::<u32>().ok());
        let stale = owner.is_none_or(|pid| pid != std::process::id() && !process_alive(pid));
        if stale && entry.file_type().is_ok_and(|t| t.is_file()) {
            let _ = std::fs::remove_file(entry.path());
        }
    }
}

/// Test hook: `CHESSARM_TEST_SLOW_WRITES_MS` makes every file write pause that long after its
/// temporary file exists, so tests can interrupt a write at a known point.
fn test_pause() {
    if let Some(ms) = std::env::var("CHESSARM_TEST_SLOW_WRITES_MS").ok().and_then(|v| v.parse::<u64>().ok()) {
        std::thread::sleep(std::time::Duration::from_millis(ms));
    }
}

/// A registered temporary file in `parent` with `suffix`.
fn temporary_in(parent: &Path, suffix: &str) -> Result<tempfile::NamedTempFile> {
    ensure_dir(parent)?;
    sweep_stale_temporaries(parent);
    let mut files = pending();
    let temporary = tempfile::Builder::new()
        .prefix(&temporary_prefix())
        .suffix(suffix)
        .permissions(readable_by_all())
        .tempfile_in(parent)
        .with_context(|| format!("cannot create a temporary file in {}", parent.display()))?;
    files.push(temporary.path().to_path_buf());
    Ok(temporary)
}

/// Renames a finished temporary file into place and forgets it (under the lock, so a signal
/// either deletes the temporary file or finds the final file whole).
fn finish(temporary: tempfile::NamedTempFile, path: &Path) -> Result<()> {
    let mut files = pending();
    let temporary_path = temporary.path().to_path_buf();
    let persisted = temporary.persist(path);
    files.retain(|file| *file != temporary_path);
    persisted.with_context(|| format!("cannot move the finished file to {}", path.display()))?;
    Ok(())
}

/// Forgets a temporary file that is being dropped (deleted) after a failed write.
fn forget(temporary: tempfile::NamedTempFile) {
    let mut files = pending();
    let temporary_path = temporary.path().to_path_buf();
    drop(temporary);
    files.retain(|file| *file != temporary_path);
}

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
    let temporary = temporary_in(parent_of(path), ".part")?;
    test_pause();
    let written = (|| {
        let mut writer = BufWriter::new(temporary.as_file());
        write(&mut writer).with_context(|| format!("while writing {}", path.display()))?;
        writer.flush().with_context(|| format!("while writing {}", path.display()))
    })();
    match written {
        Ok(()) => finish(temporary, path),
        Err(error) => {
            forget(temporary);
            Err(error)
        }
    }
}

/// Renders a file whose writer needs a path with the right extension (e.g. a PNG from
/// plotters): `render` writes to a temporary sibling path, which is then renamed into place.
pub fn render_atomic(path: &Path, render: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
    let extension = path.extension().map(|e| format!(".part.{}", e.to_string_lossy())).unwrap_or(".part".into());
    let temporary = temporary_in(parent_of(path), &extension)?;
    test_pause();
    let temporary_path: PathBuf = temporary.path().to_path_buf();
    match render(&temporary_path).with_context(|| format!("while rendering {}", path.display())) {
        Ok(()) => finish(temporary, path),
        Err(error) => {
            forget(temporary);
            Err(error)
        }
    }
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
