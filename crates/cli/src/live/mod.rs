//! The live loop's pieces (`play --human`): the person's input ([`input`]), the live page
//! ([`page`]), the real arm ([`arm`]), and the game's PGN record kept as it is played.

pub mod input;
pub mod page;

use anyhow::{Context, Result};
use chessarm_chess::notation::write_pgn;
use chessarm_chess::shakmaty::{Chess, Color, Move, Position, Role};
use std::path::Path;

/// The game as PGN keeps it: its headers, start, and every move with its comment.
#[derive(Debug, Clone)]
pub struct PgnGame {
    pub headers: Vec<(String, String)>,
    pub start: Chess,
    pub moves: Vec<(Move, Option<String>)>,
}

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
        let record = crate::app::formats::pgn::read_pgn_game(path, 1)?;
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

    /// The position after the moves.
    pub fn position(&self) -> Chess {
        let mut position = self.start.clone();
        for (m, _) in &self.moves {
            position.play_unchecked(*m);
        }
        position
    }
}

/// Material in pawns (pawn 1, knight and bishop 3, rook 5, queen 9) of `color` less the other's.
pub fn material_balance(position: &Chess, color: Color) -> i32 {
    let value = |role: Role| match role {
        Role::Pawn => 1,
        Role::Knight | Role::Bishop => 3,
        Role::Rook => 5,
        Role::Queen => 9,
        Role::King => 0,
    };
    position
        .board()
        .iter()
        .map(|(_, piece)| if piece.color == color { value(piece.role) } else { -value(piece.role) })
        .sum()
}

/// Whether the arm accepts the person's draw offer: when it is not ahead in material. (A
/// UCI engine's protocol has no draw offers; one rule for both engines, said in docs/live.md.)
pub fn accepts_draw(position: &Chess, robot: Color) -> bool {
    material_balance(position, robot) <= 0
}
