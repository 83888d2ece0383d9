//! Writing result files whole or not at all: every file is written to a temporary file in the
//! destination folder and renamed into place only once complete.
//!
//! Temporary files are named `.chessarm-<pid>-<random>.part[.ext]` and registered while they
//! exist: on SIGINT, SIGTERM or SIGHUP [`remove_on_signal`] (run by the signal handler)
//! deletes them before the program exits (a rename in progress finishes first, so a final file
//! is never truncated), and the first write into a folder deletes the temporary files that
//! earlier runs, no longer alive, left there (a `kill -9` cannot be caught).

pub mod folder_lock;

use anyhow::{Context, Result, anyhow, bail};
use std::collections::hash_map::Entry;
use std::collections::{HashMap, HashSet};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard, PoisonError};

/// Temporary files of this process not yet renamed into place.
static PENDING: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());
/// Folders already swept of stale temporary files by this process.
static SWEPT: Mutex<Option<HashSet<PathBuf>>> = Mutex::new(None);

/// Files this process made that must not outlive it (the person's input socket): removed when
/// their owner is dropped, and by the signal handler.
static REMOVE_AT_EXIT: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

fn remove_at_exit_list() -> MutexGuard<'static, Vec<PathBuf>> {
    REMOVE_AT_EXIT.lock().unwrap_or_else(PoisonError::into_inner)
}

/// Registers `path` for removal if a signal ends the program.
pub fn remove_at_exit(path: &Path) {
    remove_at_exit_list().push(path.to_path_buf());
}

/// Removes `path` (if there) and forgets it.
pub fn remove_now(path: &Path) {
    let mut list = remove_at_exit_list();
    let _ = std::fs::remove_file(path);
    list.retain(|p| p != path);
}

fn pending() -> MutexGuard<'static, Vec<PathBuf>> {
    PENDING.lock().unwrap_or_else(PoisonError::into_inner)
}

/// What a signal does to this room's files ([`crate::app::shutdown`]'s [`Stage::Files`]): the
/// temporary files and those registered with [`remove_at_exit`] removed. The lock of the
/// temporary files is kept until the process exits, so that no rename can start after the
/// files are gone and the main thread, which may see the engines die, waits in
/// [`await_signal_handler`] instead of exiting first with an error of its own.
///
/// [`Stage::Files`]: crate::app::shutdown::Stage::Files
pub fn remove_on_signal() {
    let files = pending();
    for file in files.iter().chain(remove_at_exit_list().iter()) {
        let _ = std::fs::remove_file(file);
    }
    std::mem::forget(files);
}

/// Returns at once unless the signal handler has started, in which case it never returns: the
/// handler holds the lock of the temporary files until it exits.
/// Called before the program reports its result, so that an error the signal caused (an engine
/// the handler killed) is not printed and does not replace the signal's exit code.
pub fn await_signal_handler() {
    drop(pending());
}

const TEMPORARY_PREFIX: &str = ".chessarm-";

fn temporary_prefix() -> String {
    format!("{TEMPORARY_PREFIX}{}-", std::process::id())
}

/// Deletes, once per folder and process, the temporary files in `dir` that no live run holds:
/// every run holds an exclusive lock on its temporary files while it writes them (released by
/// the kernel when the run dies, however it dies), so a file whose lock can be taken was left
/// by a run that is gone. Works across process namespaces and machines sharing the folder.
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
        if !(name.starts_with(TEMPORARY_PREFIX) && name.contains(".part")) {
            continue;
        }
        if !entry.file_type().is_ok_and(|t| t.is_file()) {
            continue;
        }
        let Ok(file) = std::fs::File::open(entry.path()) else { continue };
        if file.try_lock().is_ok() {
            let _ = std::fs::remove_file(entry.path());
        }
    }
}

/// Test hooks: the variable `name` (in ms) makes a step pause that long, so tests can
/// interrupt it at a known point: `CHESSARM_TEST_SLOW_WRITES_MS` every file write once its
/// temporary file exists.
fn test_pause(name: &str) {
    if let Some(ms) = std::env::var(name).ok().and_then(|v| v.parse::<u64>().ok()) {
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
    // Held until the file is renamed or deleted: tells other runs' sweeps that it is alive.
    temporary.as_file().lock().with_context(|| format!("cannot lock {}", temporary.path().display()))?;
    files.push(temporary.path().to_path_buf());
    Ok(temporary)
}

/// Ends a write: a finished temporary file is synced and renamed into place, a failed one
/// deleted; either way it is forgotten (under the lock, so a signal either deletes the
/// temporary file or finds the final file whole).
fn finish(temporary: tempfile::NamedTempFile, path: &Path, written: Result<()>) -> Result<()> {
    // On disk before it gets its final name: a late write error (quota, NFS) is reported here,
    // and a crash cannot leave an empty file under the final name.
    let written = written
        .and_then(|()| temporary.as_file().sync_all().with_context(|| format!("while writing {}", path.display())));
    let mut files = pending();
    let temporary_path = temporary.path().to_path_buf();
    let done = match written {
        Ok(()) => temporary
            .persist(path)
            .map(drop)
            .with_context(|| format!("cannot move the finished file to {}", path.display())),
        Err(error) => {
            drop(temporary);
            Err(error)
        }
    };
    files.retain(|file| *file != temporary_path);
    done
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

pub use crate::app::output::folder_lock::WRITTEN_LIST;

/// The names listed in each folder, as read or written by this process.
static LISTED: Mutex<Option<HashMap<PathBuf, HashSet<String>>>> = Mutex::new(None);

fn refuse_symlink(path: &Path) -> Result<()> {
    if std::fs::symlink_metadata(path).is_ok_and(|m| m.file_type().is_symlink()) {
        bail!("{} is a symbolic link; chessarm writes its list there only as a plain file", path.display());
    }
    Ok(())
}

/// The names of `dir`'s list (empty when there is none).
fn read_list(dir: &Path) -> Result<HashSet<String>> {
    let list = dir.join(WRITTEN_LIST);
    refuse_symlink(&list)?;
    match std::fs::read_to_string(&list) {
        Ok(text) => Ok(text.lines().filter(|name| is_plain_name(name)).map(str::to_owned).collect()),
        Err(error) if error.kind() == std::io::ErrorKind::NotFound => Ok(HashSet::new()),
        Err(error) => Err(error).with_context(|| format!("cannot read {}", list.display())),
    }
}

/// Reads `dir`'s list before a run's work, so that a list chessarm cannot read (damaged: not
/// text, or a link) stops the run before it simulates anything rather than at its first write.
///
/// # Errors
///
/// The list cannot be read, naming it and what to do.
pub fn check_list(dir: &Path) -> Result<()> {
    read_list(dir).map(drop).with_context(|| {
        format!(
            "{}'s {WRITTEN_LIST} (chessarm's list of the files it wrote there) is damaged; remove it if the folder \
             holds only chessarm's results, or choose another --out; nothing was changed",
            dir.display()
        )
    })
}

/// Refuses `path` before a run's work if a file is there that chessarm did not write (its
/// folder's list does not name it): the run would stop at its first write there. The
/// message advises another `flag` (the one that named the path).
///
/// # Errors
///
/// Such a file, or a list that cannot be read.
pub fn refuse_if_not_ours(path: &Path, flag: &str) -> Result<()> {
    if std::fs::symlink_metadata(path).is_err() {
        return Ok(());
    }
    let (dir, name) = split(path)?;
    if read_list(&dir)?.contains(&name) { Ok(()) } else { Err(not_ours_for(path, flag)) }
}

/// A file name without folders, so a damaged list cannot reach outside its folder.
fn is_plain_name(name: &str) -> bool {
    !name.is_empty()
        && name != "."
        && name != ".."
        && name != WRITTEN_LIST
        && name != crate::app::output::folder_lock::LOCK_FILE
        && !name.contains(['/', '\\', '\0'])
}

/// Forgets the lists read so far (they are read again when next needed).
pub fn forget_listed() {
    *listed() = None;
}

fn listed() -> MutexGuard<'static, Option<HashMap<PathBuf, HashSet<String>>>> {
    LISTED.lock().unwrap_or_else(PoisonError::into_inner)
}

/// `path`'s folder and file name.
fn split(path: &Path) -> Result<(PathBuf, String)> {
    let name = path
        .file_name()
        .and_then(|name| name.to_str())
        .filter(|name| is_plain_name(name))
        .ok_or_else(|| anyhow!("{} is not a file name chessarm writes", path.display()))?;
    Ok((parent_of(path).to_path_buf(), name.to_owned()))
}

fn not_ours(path: &Path) -> anyhow::Error {
    not_ours_for(path, "--out")
}

/// The refusal of `path`, a file chessarm did not write, advising another `flag`.
fn not_ours_for(path: &Path, flag: &str) -> anyhow::Error {
    anyhow!(
        "{} exists and was not written by chessarm (its folder's {WRITTEN_LIST} does not list it): move it away \
         or choose another {flag}; nothing was changed",
        path.display()
    )
}

/// Claims `path` for a result file: allowed when nothing is there yet (the name is then listed,
/// before anything is written) or when the folder's list names it; refused when something else
/// is there, which is then never touched.
///
/// # Errors
///
/// A file there that chessarm did not write, or a list that cannot be read or written.
pub fn claim(path: &Path) -> Result<()> {
    let (dir, name) = split(path)?;
    ensure_dir(&dir)?;
    crate::app::output::folder_lock::lock(&dir)?;
    let mut guard = listed();
    let names = match guard.get_or_insert_with(HashMap::new).entry(dir.clone()) {
        Entry::Occupied(entry) => entry.into_mut(),
        Entry::Vacant(entry) => entry.insert(read_list(&dir)?),
    };
    if names.contains(&name) {
        return Ok(());
    }
    if std::fs::symlink_metadata(path).is_ok() {
        return Err(not_ours(path));
    }
    let list = dir.join(WRITTEN_LIST);
    refuse_symlink(&list)?;
    let mut file = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(&list)
        .with_context(|| format!("cannot write {}", list.display()))?;
    writeln!(file, "{name}").and_then(|()| file.flush()).with_context(|| format!("cannot write {}", list.display()))?;
    names.insert(name);
    Ok(())
}

/// Creates `path` (claimed as [`claim`] does; with `append`, goes on after what it holds) for a
/// log written as things happen (the bus's packets): it holds what happened so far, never more.
///
/// # Errors
///
/// A file there chessarm did not write, or the file cannot be created.
pub fn create_log(path: &Path, append: bool) -> Result<std::fs::File> {
    claim(path)?;
    std::fs::OpenOptions::new()
        .create(true)
        .write(true)
        .append(append)
        .truncate(!append)
        .open(path)
        .with_context(|| format!("cannot create {}", path.display()))
}

/// Writes `path` through `write` into a temporary sibling, then renames it into place.
pub fn write_atomic(path: &Path, write: impl FnOnce(&mut dyn Write) -> Result<()>) -> Result<()> {
    claim(path)?;
    let temporary = temporary_in(parent_of(path), ".part")?;
    test_pause("CHESSARM_TEST_SLOW_WRITES_MS");
    let written = (|| {
        let mut writer = BufWriter::new(temporary.as_file());
        write(&mut writer).with_context(|| format!("while writing {}", path.display()))?;
        writer.flush().with_context(|| format!("while writing {}", path.display()))
    })();
    finish(temporary, path, written)
}

/// Renders a file whose writer needs a path with the right extension (e.g. a PNG from
/// plotters): `render` writes to a temporary sibling path, which is then renamed into place.
pub fn render_atomic(path: &Path, render: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
    claim(path)?;
    let extension = path.extension().map(|e| format!(".part.{}", e.to_string_lossy())).unwrap_or(".part".into());
    let temporary = temporary_in(parent_of(path), &extension)?;
    test_pause("CHESSARM_TEST_SLOW_WRITES_MS");
    let rendered = render(temporary.path()).with_context(|| format!("while rendering {}", path.display()));
    finish(temporary, path, rendered)
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
/// like its own: only files their folder's list names.
///
/// # Errors
///
/// A file there that chessarm did not write (nothing is deleted then), or one that cannot be
/// removed.
pub fn remove_stale(paths: &[PathBuf]) -> Result<()> {
    for path in paths {
        if std::fs::symlink_metadata(path).is_err() {
            continue;
        }
        let (dir, name) = split(path)?;
        crate::app::output::folder_lock::lock(&dir)?;
        if !read_list(&dir)?.contains(&name) {
            return Err(not_ours(path));
        }
    }
    paths.iter().try_for_each(|path| remove_file_if_there(path))
}

/// Deletes every file `dir`'s list names (an earlier run's results; nothing else in the
/// folder is touched).
///
/// # Errors
///
/// A list or a file that cannot be read or removed.
pub fn remove_listed_in(dir: &Path) -> Result<()> {
    if dir.is_dir() {
        crate::app::output::folder_lock::lock(dir)?;
    }
    for name in read_list(dir)? {
        remove_file_if_there(&dir.join(name))?;
    }
    Ok(())
}

/// Removes `path` if it is there.
pub fn remove_file_if_there(path: &Path) -> Result<()> {
    match std::fs::remove_file(path) {
        Ok(()) => Ok(()),
        Err(error) if error.kind() == std::io::ErrorKind::NotFound => Ok(()),
        Err(error) => Err(error).with_context(|| format!("cannot remove the old {}", path.display())),
    }
}

/// Refuses, before any work, a folder holding a file that chessarm might write (`might_write`
/// of its name) but did not (its list does not name it): otherwise the run would stop there
/// later, half done.
///
/// # Errors
///
/// The first such file, or a folder or list that cannot be read.
pub fn refuse_unlisted(dir: &Path, might_write: impl Fn(&str) -> bool) -> Result<()> {
    let names = read_list(dir)?;
    let Ok(entries) = std::fs::read_dir(dir) else { return Ok(()) };
    for entry in entries.flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        if might_write(&name) && !names.contains(&name) {
            return Err(not_ours(&dir.join(name)));
        }
    }
    Ok(())
}

/// `word` as one shell word for a command printed for the user to paste: as it is when it
/// holds only characters no shell treats specially, else in single quotes (a quote inside as
/// `'\''`).
pub fn shell_word(word: &str) -> String {
    let plain = !word.is_empty()
        && word
            .chars()
            .all(|c| c.is_alphanumeric() || matches!(c, '/' | '.' | '-' | '_' | ',' | ':' | '=' | '+' | '@'));
    if plain { word.to_string() } else { format!("'{}'", word.replace('\'', "'\\''")) }
}

#[cfg(test)]
mod tests {
    use super::shell_word;

    #[test]
    fn a_printed_path_is_one_shell_word() {
        assert_eq!(shell_word("out/robustness/worst-pd"), "out/robustness/worst-pd");
        assert_eq!(shell_word("my study/worst-pd"), "'my study/worst-pd'");
        assert_eq!(shell_word("it's"), r"'it'\''s'");
        assert_eq!(shell_word(""), "''");
        assert_eq!(shell_word("$HOME;rm"), "'$HOME;rm'");
    }
}
