//! PGN game files: read as a stream up to the game asked for; a person's game written after
//! every ply and read back to go on with it.

pub use crate::app::studies::person::PgnGame;
use anyhow::{Context, Result};
use chessarm_chess::notation::write_pgn;
use chessarm_chess::shakmaty::Color;
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

/// The record of a person's game saved and read back (`play --human`, `--resume`).
impl PgnGame {
    /// The game saved at `path` (`play --human --resume`).
    ///
    /// # Errors
    ///
    /// The file cannot be read, or is not a game chessarm can go on with.
    pub fn resume(path: &Path, person: Color) -> Result<Self> {
        if !path.is_file() {
            anyhow::bail!("--resume: there is no {} to go on with", path.display());
        }
        let record = read_pgn_game(path, 1)?;
        if let Some(result) = record.header("Result").filter(|r| *r != "*") {
            anyhow::bail!(
                "--resume: the game in {} is over ({result}); start a new one without --resume",
                path.display()
            );
        }
        // The person plays the side the saved game says they played.
        let (side, other) = if person == Color::White { ("White", "Black") } else { ("Black", "White") };
        if record.header(other) == Some("person") && record.header(side) != Some("person") {
            anyhow::bail!(
                "--resume: in {} the person plays {}; give --human {}",
                path.display(),
                other.to_lowercase(),
                other.to_lowercase()
            );
        }
        let comments = record.comments.clone().into_iter().chain(std::iter::repeat(None));
        let moves = record.moves.iter().copied().zip(comments).collect();
        Ok(Self { headers: record.headers, start: record.start, moves })
    }

    /// Writes the game to `path` (whole, then renamed into place) with `result`.
    ///
    /// # Errors
    ///
    /// The file cannot be written.
    pub fn save(&self, path: &Path, result: &str) -> Result<()> {
        let mut headers: Vec<(String, String)> = self.headers.iter().filter(|(k, _)| k != "Result").cloned().collect();
        headers.retain(|(k, _)| k != "PlyCount");
        headers.push(("PlyCount".to_string(), self.moves.len().to_string()));
        let text = write_pgn(&headers, &self.start, &self.moves, result);
        crate::app::output::write_atomic(path, |out| out.write_all(text.as_bytes()).context("writing the PGN"))
    }
}
