//! One run per output folder: a run holds an exclusive lock on `.chessarm-lock` in every folder
//! it writes into (its `--out` from its start, the others before its first write or removal
//! there), so that a second run into the same folder, or into a folder inside it, stops with an
//! error naming the first instead of mixing its files with the other's or deleting them.
//!
//! The lock is the kernel's (`flock`): it is released when the run ends or its process dies,
//! however it dies, so a crashed run never leaves a folder locked. The file stays in the folder
//! once the run has written there; it holds the process id and command line of the run that
//! last locked it, for the message. A lock file is only ever removed by the run that holds it,
//! and a run checks after locking that the file it locked is still the one at that path (so a
//! lock file removed in between cannot give two runs one folder).

use anyhow::{Context, Result, bail};
use std::collections::HashMap;
use std::fs::File;
use std::io::{Read, Seek, Write};
use std::os::unix::fs::MetadataExt;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard, PoisonError};

/// The lock file's name in a locked folder.
pub const LOCK_FILE: &str = ".chessarm-lock";

/// The list, in every folder chessarm writes results into, of the files it wrote there (one
/// name a line). A file is only ever replaced or removed when this list names it
/// ([`crate::app::output`] keeps it; a run that ends having written nothing leaves no lock).
pub const WRITTEN_LIST: &str = ".chessarm-written";

/// Attempts at a lock that another run's brief check may hold for an instant.
const ATTEMPTS: u32 = 5;

/// The folders the current run has locked (canonical paths), with their open lock files.
static HELD: Mutex<Option<HashMap<PathBuf, File>>> = Mutex::new(None);

fn held() -> MutexGuard<'static, Option<HashMap<PathBuf, File>>> {
    HELD.lock().unwrap_or_else(PoisonError::into_inner)
}

/// Who holds a lock, as its file says.
fn holder(file: &mut File) -> String {
    let mut text = String::new();
    let _ = file.rewind();
    let _ = file.take(4096).read_to_string(&mut text);
    let text = crate::app::text::escape_controls(text.trim());
    if text.is_empty() { "its lock file does not say which".to_string() } else { text }
}

fn in_use(dir: &Path, file: &mut File) -> anyhow::Error {
    anyhow::anyhow!(
        "{} is in use by another chessarm run ({}): wait for it to end or choose another --out; nothing was \
         written",
        dir.display(),
        holder(file)
    )
}

/// Whether the open `file` is the file at `path` now (not a symbolic link, the same inode).
fn is_the_file_at(file: &File, path: &Path) -> bool {
    match (file.metadata(), std::fs::symlink_metadata(path)) {
        (Ok(open), Ok(there)) => there.file_type().is_file() && open.dev() == there.dev() && open.ino() == there.ino(),
        _ => false,
    }
}

/// `try` a lock a few times, 20 ms apart: another run's check holds a shared lock for an instant.
fn try_a_few_times(
    mut attempt: impl FnMut() -> Result<(), std::fs::TryLockError>,
) -> Result<(), std::fs::TryLockError> {
    let mut tries = 1;
    loop {
        match attempt() {
            Err(std::fs::TryLockError::WouldBlock) if tries < ATTEMPTS => {
                tries += 1;
                std::thread::sleep(std::time::Duration::from_millis(20));
            }
            other => return other,
        }
    }
}

/// Fails when `dir`'s lock is held by another run (it is not taken). Folders this run holds
/// are not checked.
fn refuse_if_held_elsewhere(dir: &Path) -> Result<()> {
    if let Ok(canonical) = dir.canonicalize()
        && held().as_ref().is_some_and(|mine| mine.contains_key(&canonical))
    {
        return Ok(());
    }
    let path = dir.join(LOCK_FILE);
    if std::fs::symlink_metadata(&path).is_ok_and(|m| m.file_type().is_file())
        && let Ok(mut file) = File::open(&path)
        && is_the_file_at(&file, &path)
    {
        match try_a_few_times(|| file.try_lock_shared()) {
            Ok(()) => drop(file),
            Err(std::fs::TryLockError::WouldBlock) => return Err(in_use(dir, &mut file)),
            Err(std::fs::TryLockError::Error(_)) => {}
        }
    }
    Ok(())
}

/// Locks `dir` (which exists) for the current run, once; refuses when another run holds it or
/// a folder containing it.
///
/// # Errors
///
/// A lock held elsewhere (naming that run), or a lock file that cannot be created.
pub fn lock(dir: &Path) -> Result<()> {
    let canonical = dir.canonicalize().with_context(|| format!("cannot find output folder {}", dir.display()))?;
    if held().as_ref().is_some_and(|mine| mine.contains_key(&canonical)) {
        return Ok(());
    }
    for folder in canonical.ancestors().skip(1) {
        refuse_if_held_elsewhere(folder)?;
    }
    let path = canonical.join(LOCK_FILE);
    if std::fs::symlink_metadata(&path).is_ok_and(|m| !m.file_type().is_file()) {
        bail!("{} is not a plain file; chessarm locks its folder only with one", path.display());
    }
    let mut file = match std::fs::OpenOptions::new().read(true).write(true).create(true).truncate(false).open(&path) {
        Ok(file) => file,
        // A folder no run can write into needs no lock: the first write says why it fails.
        Err(error)
            if matches!(
                error.kind(),
                std::io::ErrorKind::PermissionDenied | std::io::ErrorKind::ReadOnlyFilesystem
            ) =>
        {
            return Ok(());
        }
        Err(error) => return Err(error).with_context(|| format!("cannot create {}", path.display())),
    };
    match try_a_few_times(|| file.try_lock()) {
        Ok(()) => {}
        Err(std::fs::TryLockError::WouldBlock) => return Err(in_use(dir, &mut file)),
        Err(std::fs::TryLockError::Error(error)) => {
            return Err(error).with_context(|| format!("cannot lock {}", path.display()));
        }
    }
    // Locked: is it still the file at the path (not removed or replaced, not a link)?
    if !is_the_file_at(&file, &path) {
        bail!("{} changed while chessarm locked it: is another run starting? Try again", path.display());
    }
    let command: Vec<String> = std::env::args_os().map(|a| a.to_string_lossy().into_owned()).collect();
    let about = format!("pid {}: {}", std::process::id(), command.join(" "));
    file.set_len(0)
        .and_then(|()| file.rewind())
        .and_then(|()| writeln!(file, "{about}"))
        .and_then(|()| file.flush())
        .with_context(|| format!("cannot write {}", path.display()))?;
    held().get_or_insert_with(HashMap::new).insert(canonical, file);
    Ok(())
}

/// Releases every folder the current run locked (at the end of a run; a process's end does it
/// too).
pub fn release_all() {
    *held() = None;
}

/// A run's output folder, locked from the start of the run to its end: a second run into it (or
/// into a folder inside it) is refused before it does any work. Dropping it (the run ended, or
/// a panic unwound it) releases every lock the run took.
#[derive(Debug)]
pub struct RunFolder {
    /// The folders this run created, outermost first.
    created: Vec<PathBuf>,
    dir: PathBuf,
}

impl RunFolder {
    /// Creates `dir` if needed (one folder at a time, remembering which) and locks it.
    ///
    /// # Errors
    ///
    /// Another run holds it (or a folder containing it), or it cannot be created.
    pub fn take(dir: &Path) -> Result<Self> {
        // Whatever an earlier run in this process left (a panic) is not this run's.
        release_all();
        // The folders that exist, checked before anything is created inside another run's.
        // Absolute, so that the working folder and those above it are checked too.
        let absolute =
            std::path::absolute(dir).with_context(|| format!("cannot find output folder {}", dir.display()))?;
        for folder in absolute.ancestors().filter(|a| a.is_dir()) {
            refuse_if_held_elsewhere(folder)?;
        }
        let mut folder = Self { created: Vec::new(), dir: dir.to_path_buf() };
        let mut missing: Vec<&Path> =
            dir.ancestors().filter(|a| !a.as_os_str().is_empty()).take_while(|a| !a.is_dir()).collect();
        missing.reverse();
        for path in missing {
            match std::fs::create_dir(path) {
                Ok(()) => folder.created.push(path.to_path_buf()),
                Err(error) if error.kind() == std::io::ErrorKind::AlreadyExists && path.is_dir() => {}
                Err(error) => {
                    folder.end(false);
                    return Err(error).with_context(|| format!("cannot create output folder {}", path.display()));
                }
            }
        }
        match lock(dir) {
            Ok(()) => Ok(folder),
            Err(error) => {
                folder.end(false);
                Err(error)
            }
        }
    }

    /// Ends the run: when it failed (`ok == false`) having written nothing in its folder (no list
    /// of written files there), removes its lock file (only if this run holds it) and the folders
    /// it created; then releases every lock it took.
    pub fn end(self, ok: bool) {
        let wrote = self.dir.join(WRITTEN_LIST).exists();
        if !ok && !wrote {
            let holds = self
                .dir
                .canonicalize()
                .is_ok_and(|canonical| held().as_ref().is_some_and(|mine| mine.contains_key(&canonical)));
            if holds {
                // Removed while held: no other run can have locked it since (and one that opened
                // it before sees, once it has the lock, that it is no longer the file there).
                let _ = std::fs::remove_file(self.dir.join(LOCK_FILE));
            }
            release_all();
            // Only the folders this run made, innermost first, and only while empty.
            for created in self.created.iter().rev() {
                if std::fs::remove_dir(created).is_err() {
                    break;
                }
            }
        }
        // Dropping `self` releases the locks.
    }
}

impl Drop for RunFolder {
    fn drop(&mut self) {
        release_all();
    }
}
