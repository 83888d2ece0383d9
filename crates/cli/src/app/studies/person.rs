//! A person against the arm: whose turn it is, what each of the person's actions does to the
//! game (a move played by hand, a take-back, a resignation, a draw offered, a stop) and the
//! arm's replies chosen by its engine, with the game's PGN record kept as it is played. How the
//! person's actions arrive and what is shown are the caller's (the terminal, a file, a socket,
//! the live page).

use crate::app::setup::file::Setup;
use anyhow::{Context, Result};
use chessarm_chess::board::BoardGeometry;
use chessarm_chess::opponent::Opponent;
use chessarm_chess::play::{Game, Handling, MoveReport, Mover};
use chessarm_chess::shakmaty::Square;
use chessarm_chess::shakmaty::{Chess, Color, Move, Position, Role};
use chessarm_chess::table::Location;
use std::path::Path;

/// The game as PGN keeps it: its headers, start, and every move with its comment.
#[derive(Debug, Clone)]
pub struct PgnGame {
    pub headers: Vec<(String, String)>,
    pub start: Chess,
    pub moves: Vec<(Move, Option<String>)>,
}

impl PgnGame {
    /// The position after the moves.
    pub fn position(&self) -> Chess {
        let mut position = self.start.clone();
        for (m, _) in &self.moves {
            position.play_unchecked(*m);
        }
        position
    }
}

/// A person's game as it stands.
#[derive(Debug, Clone)]
pub struct PersonGame {
    /// The side the person plays.
    pub person: Color,
    /// The game's record: its headers, start and moves (the arm's with a comment).
    pub pgn: PgnGame,
    /// The moves resumed from a saved game (played by hand at the start: the board shows them).
    pub resumed: usize,
    /// Per ply of the record, the pieces it moved (from, to), for take-backs.
    pub relocations: Vec<Vec<(Location, Location)>>,
    /// How it ended (result and reason), when the person resigned, a draw was agreed or the
    /// person stopped; `None` while it goes on or the rules end it.
    pub ended: Option<(String, String)>,
}

/// What a take-back undid.
#[derive(Debug, Clone)]
pub struct TakenBack {
    /// Plies taken back (the person's last move and the arm's reply to it).
    pub plies: usize,
    /// The record's moves kept.
    pub kept: usize,
    /// The pieces put back.
    pub handled: Vec<Handling>,
}

impl PersonGame {
    /// A game of `person` from the record `pgn`, whose moves are all resumed ones.
    pub fn new(person: Color, pgn: PgnGame) -> Self {
        let resumed = pgn.moves.len();
        Self { person, pgn, resumed, relocations: Vec::new(), ended: None }
    }

    /// The side the arm plays.
    pub fn robot(&self) -> Color {
        !self.person
    }

    /// Plays the resumed move `k` by hand.
    ///
    /// # Errors
    ///
    /// The move cannot be played on the board as it stands.
    pub fn play_resumed(&mut self, game: &mut Game, k: usize) -> Result<MoveReport> {
        let report = game.play(&self.pgn.moves[k].0, Mover::Opponent)?;
        self.relocations.push(report.handled.iter().map(|h| (h.from, h.to)).collect());
        Ok(report)
    }

    /// The person's move `m`, played by hand.
    ///
    /// # Errors
    ///
    /// The move cannot be played on the board as it stands.
    pub fn person_moves(&mut self, game: &mut Game, m: Move) -> Result<MoveReport> {
        let report = game.play(&m, Mover::Opponent)?;
        self.relocations.push(report.handled.iter().map(|h| (h.from, h.to)).collect());
        self.pgn.moves.push((m, None));
        Ok(report)
    }

    /// Takes back the person's last move and the arm's reply to it (on the person's turn the
    /// last move is the arm's); `None` before the person has moved.
    ///
    /// # Errors
    ///
    /// The pieces cannot be put back.
    pub fn take_back(&mut self, game: &mut Game) -> Result<Option<TakenBack>> {
        let plies = 2;
        if self.pgn.moves.len() < plies {
            return Ok(None);
        }
        let kept = self.pgn.moves.len() - plies;
        let moved: Vec<_> = self.relocations[kept..].concat();
        let mut earlier = self.pgn.clone();
        earlier.moves.truncate(kept);
        let handled = game.take_back(plies, &moved, earlier.position())?;
        self.relocations.truncate(kept);
        self.pgn.moves.truncate(kept);
        Ok(Some(TakenBack { plies, kept, handled }))
    }

    /// The person resigns.
    pub fn resign(&mut self) {
        let result = if self.person == Color::White { "0-1" } else { "1-0" };
        self.ended = Some((result.into(), format!("{} (the person) resigned", side_name(self.person))));
    }

    /// The person offers a draw in `position`: agreed when the arm is not ahead in material
    /// ([`accepts_draw`]), else declined with the arm's lead in pawns.
    ///
    /// # Errors
    ///
    /// The draw declined: the arm's lead in material, pawns.
    pub fn offer_draw(&mut self, position: &Chess) -> Result<(), i32> {
        if accepts_draw(position, self.robot()) {
            self.ended = Some(("1/2-1/2".into(), "draw agreed".into()));
            return Ok(());
        }
        Err(material_balance(position, self.robot()))
    }

    /// The person stops; the game goes on with `--resume` from the record in `folder`.
    pub fn stop(&mut self, folder: &Path) {
        self.ended =
            Some(("*".into(), format!("the person stopped; go on with --resume (game.pgn in {})", folder.display())));
    }

    /// The arm's reply in `position`, chosen by `engine` and played by the arm, with the
    /// engine's thinking time, s.
    ///
    /// # Errors
    ///
    /// The engine fails, or the arm cannot make the move.
    pub fn arm_moves(&mut self, game: &mut Game, engine: &mut dyn Opponent) -> Result<(MoveReport, f64)> {
        let position = game.position().clone();
        let thinking_started = std::time::Instant::now();
        let m = engine
            .choose_move(&position)
            .with_context(|| format!("the arm's move after {} plies", self.pgn.moves.len()))?;
        let thinking = thinking_started.elapsed().as_secs_f64();
        let report = game.play(&m, Mover::Robot)?;
        self.relocations.push(report.handled.iter().map(|h| (h.from, h.to)).collect());
        self.pgn.moves.push((m, Some(robot_comment(&report))));
        Ok((report, thinking))
    }
}

/// The board as the person sits at it, across from the arm: their first rank must stand
/// farther from the arm's base than their last (the arm reaches in from its own side). When the
/// setup's board has it the other way, its squares are turned half a turn on the table
/// ([`BoardGeometry::squares_turned`]): the graveyards, the reserves and the home point stay
/// where the arm serves them, and the 64 square centres are the same points, so a board the
/// pre-flight accepts is accepted turned. Returns the board and a line for the terminal.
pub fn seat(setup: &Setup, person: Color) -> (BoardGeometry, String) {
    let board = setup.board;
    let base = setup.arm.base().xy();
    let distance = |board: &BoardGeometry, square: Square| (board.square_center(square).xy() - base).norm();
    let (own, far) = match person {
        Color::White => (Square::E1, Square::E8),
        Color::Black => (Square::E8, Square::E1),
    };
    let side = side_name(person);
    if distance(&board, own) >= distance(&board, far) - 1e-9 {
        return (
            board,
            format!("seat: the person plays {side} from across the board, their first rank farthest from the arm\n"),
        );
    }
    let turned = BoardGeometry { squares_turned: !board.squares_turned, ..board };
    (
        turned,
        format!(
            "seat: the squares turned half a turn from the setup's (now [board] squares_turned = {}) so that {side}'s \
             first rank faces the person across from the arm; the graveyards and reserves stay where they were\n",
            turned.squares_turned
        ),
    )
}

/// `white` or `black`.
pub fn side_name(color: Color) -> &'static str {
    if color == Color::White { "white" } else { "black" }
}

/// The PGN comment of the arm's move: its time, how well it placed, its clearance.
pub fn robot_comment(report: &MoveReport) -> String {
    let mut comment = format!("robot {:.2} s", report.duration);
    if let Some(worst) = report.place_errors.iter().copied().reduce(f64::max) {
        comment.push_str(&format!(", placed within {:.2} mm", worst * 1e3));
    }
    if let Some(c) = &report.clearance {
        comment.push_str(&format!(", clearance {:.1} mm", c.distance * 1e3));
    }
    comment
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

#[cfg(test)]
mod tests {
    use super::*;

    fn game_of(person: Color) -> PersonGame {
        PersonGame::new(person, PgnGame { headers: Vec::new(), start: Chess::default(), moves: Vec::new() })
    }

    #[test]
    fn the_arm_agrees_a_draw_unless_it_is_ahead_in_material() {
        let mut even = game_of(Color::White);
        assert_eq!(even.offer_draw(&Chess::default()), Ok(()));
        assert_eq!(even.ended, Some(("1/2-1/2".to_string(), "draw agreed".to_string())));
        // Black (the arm) has a queen more: White's queen is gone.
        let fen = "rnbqkbnr/pppppppp/8/8/8/8/PPPPPPPP/RNB1KBNR w KQkq - 0 1";
        let position = chessarm_chess::notation::parse_fen(fen).expect("a legal position");
        let mut behind = game_of(Color::White);
        assert_eq!(behind.offer_draw(&position), Err(9));
        assert_eq!(behind.ended, None);
        // Where the person is the one ahead, the arm agrees.
        let mut ahead = game_of(Color::Black);
        assert_eq!(material_balance(&position, Color::Black), 9);
        assert_eq!(ahead.offer_draw(&position), Ok(()));
    }

    #[test]
    fn a_resignation_gives_the_arm_the_game_and_a_stop_leaves_it_open() {
        let mut white = game_of(Color::White);
        white.resign();
        assert_eq!(white.ended, Some(("0-1".to_string(), "white (the person) resigned".to_string())));
        let mut black = game_of(Color::Black);
        black.resign();
        assert_eq!(black.ended.as_ref().map(|(r, _)| r.as_str()), Some("1-0"));
        black.stop(Path::new("out/play"));
        assert_eq!(black.ended.as_ref().map(|(r, _)| r.as_str()), Some("*"));
        assert!(black.ended.as_ref().is_some_and(|(_, why)| why.contains("--resume") && why.contains("out/play")));
        assert_eq!(black.robot(), Color::White);
    }
}
