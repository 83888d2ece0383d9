//! PGN game files, read as a stream up to the game asked for.

use anyhow::{Context, Result};
use std::path::Path;

/// Game `number` (1-based) of the PGN file at `path`, read as a stream: the file is read only
/// up to the end of that game, and one game may hold at most
/// [`chessarm_chess::notation::MAX_PGN_GAME_BYTES`].
///
/// # Errors
///
/// The file cannot be read, or holds no such game, or the game is not valid.
pub fn read_pgn_game(path: &Path, number: usize) -> Result<chessarm_chess::notation::GameRecord> {
    let file = std::fs::File::open(path).with_context(|| format!("cannot read PGN file {}", path.display()))?;
    chessarm_chess::notation::read_game(file, number).with_context(|| format!("PGN file {}", path.display()))
}
