//! One run per output folder: a run holds an exclusive lock on `.chessarm-lock` in every folder
//! it writes into (taken before its first write or removal there), so that a second run into
//! the same folder, or into a folder inside it, stops with an error naming the first instead of
//! mixing its files with the other's or deleting them.
//!
//! The lock is the kernel's (`flock`): it is released when the run ends or its process dies,
//! however it dies, so a crashed run never leaves a folder locked. The file stays in the folder
//! (removing it would let a third run lock a new file while a second holds the old one); it
//! holds the process id and command line of the run that last locked it, for the message.

use anyhow::{Context, Result, bail};
use std::collections::HashMap;
use std::fs::File;
use std::io::{Read, Seek, Write};
use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard, PoisonError};

/// The lock file's name in a locked folder.
pub const LOCK_FILE: &str = ".chessarm-lock";

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
    let text = crate::escape_controls(text.trim());
    if text.is_empty() { "another chessarm run".to_string() } else { text }
}

fn in_use(dir: &Path, file: &mut File) -> anyhow::Error {
    anyhow::anyhow!(
        "{} is in use by another chessarm run ({}): wait for it to end or choose another --out; nothing was \
         written",
        dir.display(),
        holder(file)
    )
}

/// Fails when `dir`'s lock is held by another run (it is not taken).
fn refuse_if_held_elsewhere(dir: &Path) -> Result<()> {
    let path = dir.join(LOCK_FILE);
    if std::fs::symlink_metadata(&path).is_ok_and(|m| m.file_type().is_file())
        && let Ok(mut file) = File::open(&path)
    {
        match file.try_lock_shared() {
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
    let mut mine = held();
    let mine = mine.get_or_insert_with(HashMap::new);
    if mine.contains_key(&canonical) {
        return Ok(());
    }
    for folder in canonical.ancestors().skip(1) {
        if mine.contains_key(folder) {
            break;
        }
        refuse_if_held_elsewhere(folder)?;
    }
    let path = canonical.join(LOCK_FILE);
    if std::fs::symlink_metadata(&path).is_ok_and(|m| m.file_type().is_symlink()) {
        bail!("{} is a symbolic link; chessarm locks its folder only with a plain file", path.display());
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
    match file.try_lock() {
        Ok(()) => {}
        Err(std::fs::TryLockError::WouldBlock) => return Err(in_use(dir, &mut file)),
        Err(std::fs::TryLockError::Error(error)) => {
            return Err(error).with_context(|| format!("cannot lock {}", path.display()));
        }
    }
    let command: Vec<String> = std::env::args().collect();
    let about = format!("pid {}: {}", std::process::id(), command.join(" "));
    file.set_len(0)
        .and_then(|()| file.rewind())
        .and_then(|()| writeln!(file, "{about}"))
        .and_then(|()| file.flush())
        .with_context(|| format!("cannot write {}", path.display()))?;
    mine.insert(canonical, file);
    Ok(())
}

/// Releases every folder the current run locked (at the end of a run; a process's end does it
/// too).
pub fn release_all() {
    *held() = None;
}

/// A run's output folder, locked from the start of the run to its end: a second run into it (or
/// into a folder inside it) is refused before it does any work.
#[derive(Debug)]
pub struct RunFolder {
    /// The outermost folder this run created (with what is below it), if it created any.
    created: Option<PathBuf>,
    dir: PathBuf,
}

impl RunFolder {
    /// Creates `dir` if needed and locks it.
    ///
    /// # Errors
    ///
    /// Another run holds it (or a folder containing it), or it cannot be created.
    pub fn take(dir: &Path) -> Result<Self> {
        // The folders that exist, checked before anything is created inside another run's.
        for folder in dir.ancestors().filter(|a| a.is_dir()) {
            refuse_if_held_elsewhere(folder)?;
        }
        let created =
            dir.ancestors().filter(|a| !a.as_os_str().is_empty() && !a.exists()).last().map(Path::to_path_buf);
        crate::output::ensure_dir(dir)?;
        let folder = Self { created, dir: dir.to_path_buf() };
        match lock(dir) {
            Ok(()) => Ok(folder),
            Err(error) => {
                folder.end(false);
                Err(error)
            }
        }
    }

    /// Ends the run: releases every lock it took and, when it failed (`ok == false`) having
    /// written nothing in the folder (no list of written files there), removes its lock file
    /// and the folders it created, so a refused run leaves no trace.
    pub fn end(self, ok: bool) {
        let wrote = self.dir.join(crate::output::WRITTEN_LIST).exists();
        if !ok && !wrote {
            // Still held: no other run can have taken it since.
            let _ = std::fs::remove_file(self.dir.join(LOCK_FILE));
        }
        release_all();
        if ok || wrote {
            return;
        }
        let Some(created) = &self.created else { return };
        // Only empty folders go: `remove_dir` refuses any other.
        for folder in self.dir.ancestors() {
            if std::fs::remove_dir(folder).is_err() || folder == created {
                break;
            }
        }
    }
}
