//! The person's move read off the board as a sensor sees it: which squares hold a piece (reed
//! switches or Hall sensors under the squares, or a camera program), resolved against the
//! legal moves.
//!
//! A reading is the whole board as it stands: 64 characters `0`/`1` from a1, b1, … h1, a2, … to
//! h8 (spaces and `/` between them ignored), a 64-bit bitboard in hexadecimal (`0x…`, bit 0 =
//! a1, bit 63 = h8), or a FEN board field (`rnbqkbnr/pppppppp/8/…`, rank 8 first), whose letters
//! also say which piece stands where. A reader sends one when the board settles (after the
//! person's move, and may send some while the person moves). The move is the legal move after
//! which the board reads the same. Castling (four changes) and en passant (the captured pawn's
//! square emptied) are told apart by occupancy alone. A capture is not, when the same piece
//! could take on several squares (only its own square empties: Nxc6, Nxd7 and Nxf7 read
//! alike): a reading taken while the captured piece was off the board (its square seen empty)
//! tells which; without one the person is asked. A promotion is asked too (the squares are the
//! same whatever the pawn becomes) unless the reading names the pieces. A reading with pieces
//! only lifted (squares emptied, none filled) that no legal move gives is a move in progress, and
//! so is a rook's move from its corner while castling that side is legal (the king may follow:
//! the same reading again plays the rook's move);
//! one that fills a square no legal move fills is refused with what changed and what was legal
//! from the squares that changed; nothing is played.

use shakmaty::{Bitboard, Board, Chess, Move, Position, Square};
use std::fmt::Write as _;

/// What a sensor reported: occupied squares, or (a FEN board field) the pieces too.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Reading {
    Occupied(Bitboard),
    Pieces(Board),
}

impl Reading {
    pub fn occupied(&self) -> Bitboard {
        match self {
            Self::Occupied(bits) => *bits,
            Self::Pieces(board) => board.occupied(),
        }
    }
}

/// Why a reading gives no move.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum OccupancyError {
    #[error(
        "'{0}' is not a board reading: give 64 characters 0/1 from a1 to h8, a bitboard as 0x and 16 hex digits, or a FEN board field"
    )]
    Unreadable(String),
    #[error(
        "the board reads {seen}; no legal move leaves it so; {expected}; nothing was played — put the pieces right"
    )]
    NoMove { seen: String, expected: String },
    #[error("the board reads {seen}: {count} legal moves leave it so ({moves}); nothing was played")]
    Ambiguous { seen: String, count: usize, moves: String },
}

/// What a reading resolved to.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Resolved {
    /// Nothing moved (the reading is the position's own board).
    Unchanged,
    /// Pieces lifted, none put down where a legal move would: the move goes on.
    InProgress,
    Move(Move),
    /// A pawn reached the last rank: the reading cannot tell the new piece; ask which.
    Promotion(Vec<Move>),
    /// Several captures read alike and no reading showed which piece was taken: ask which.
    Choice(Vec<Move>),
}

/// Parses a reading ([module](self) docs for the forms).
///
/// # Errors
///
/// [`OccupancyError::Unreadable`] naming the text.
pub fn parse_reading(text: &str) -> Result<Reading, OccupancyError> {
    let trimmed = text.trim();
    let unreadable = || OccupancyError::Unreadable(trimmed.chars().take(100).collect());
    if let Some(hex) = trimmed.strip_prefix("0x").or_else(|| trimmed.strip_prefix("0X")) {
        let bits = u64::from_str_radix(hex.trim(), 16).map_err(|_| unreadable())?;
        return Ok(Reading::Occupied(Bitboard(bits)));
    }
    let digits: String = trimmed.chars().filter(|c| !c.is_whitespace() && *c != '/').collect();
    if digits.len() == 64 && digits.chars().all(|c| c == '0' || c == '1') {
        let bits = digits.chars().enumerate().fold(0u64, |bits, (i, c)| if c == '1' { bits | (1 << i) } else { bits });
        return Ok(Reading::Occupied(Bitboard(bits)));
    }
    // A FEN board field (and only that: the first space ends it).
    let field = trimmed.split_whitespace().next().unwrap_or_default();
    if field.matches('/').count() == 7 {
        let board: Board = field.parse().map_err(|_| unreadable())?;
        return Ok(Reading::Pieces(board));
    }
    Err(unreadable())
}

/// Squares in words: "e2, e4".
fn squares(bits: Bitboard) -> String {
    let names: Vec<String> = bits.into_iter().map(|s| s.to_string()).collect();
    if names.is_empty() { "none".to_string() } else { names.join(", ") }
}

/// The change from `before` to `after` in words: "e2 emptied, e4 filled".
fn change(before: Bitboard, after: Bitboard) -> String {
    let emptied = before & !after;
    let filled = after & !before;
    let mut out = String::new();
    if !emptied.is_empty() {
        let _ = write!(out, "{} emptied", squares(emptied));
    }
    if !filled.is_empty() {
        if !out.is_empty() {
            out.push_str(", ");
        }
        let _ = write!(out, "{} filled", squares(filled));
    }
    if out.is_empty() {
        out.push_str("no square changed");
    }
    out
}

/// Reads one move from the readings that arrive while the person makes it: remembers the
/// squares seen emptied since the position's own board was last read (a captured piece lifted
/// off shows which capture it was).
#[derive(Debug, Clone, Default)]
pub struct MoveReader {
    lifted: Bitboard,
    /// A reading that would be a rook's move from its corner while castling that side is
    /// legal: played when it comes again (the king may be about to follow).
    unconfirmed: Option<Bitboard>,
}

impl MoveReader {
    /// Forgets the readings so far (after a move was played).
    pub fn reset(&mut self) {
        self.lifted = Bitboard::EMPTY;
        self.unconfirmed = None;
    }

    /// What `reading` says of the person's move in `position`
    /// ([module](self) docs for how).
    ///
    /// # Errors
    ///
    /// A square filled that no legal move fills, or (pieces named) a board no legal move gives.
    pub fn read(&mut self, position: &Chess, reading: &Reading) -> Result<Resolved, OccupancyError> {
        let before = position.board().occupied();
        let seen = reading.occupied();
        let same = match reading {
            Reading::Occupied(bits) => *bits == before,
            Reading::Pieces(board) => board == position.board(),
        };
        if same {
            self.reset();
            return Ok(Resolved::Unchanged);
        }
        self.lifted |= before & !seen;
        let candidates: Vec<Move> = position
            .legal_moves()
            .into_iter()
            .filter(|m| {
                let mut after = position.clone();
                after.play_unchecked(*m);
                match reading {
                    Reading::Occupied(bits) => after.board().occupied() == *bits,
                    Reading::Pieces(board) => after.board() == board,
                }
            })
            .collect();
        let seen_text = change(before, seen);
        let san = |m: &Move| shakmaty::san::San::from_move(position, *m).to_string();
        match candidates.as_slice() {
            [] if (seen & !before).is_empty() => Ok(Resolved::InProgress),
            [] => {
                // What was legal from the squares the person emptied (or any move, if none).
                let emptied = before & !seen;
                let from: Vec<String> = position
                    .legal_moves()
                    .into_iter()
                    .filter(|m| m.from().is_some_and(|f| emptied.contains(f)))
                    .map(|m| san(&m))
                    .collect();
                let expected = if from.is_empty() {
                    "one of the side to move's pieces should leave its square".to_string()
                } else {
                    format!("legal from {}: {}", squares(emptied), from.join(", "))
                };
                Err(OccupancyError::NoMove { seen: seen_text, expected })
            }
            [one] => {
                // A rook from its corner while castling that side is legal: the person may be
                // castling rook first; the same reading again (the board settled) plays it.
                let castles_with_it = position
                    .legal_moves()
                    .iter()
                    .any(|m| matches!(m, Move::Castle { rook, .. } if Some(*rook) == one.from()));
                if one.role() == shakmaty::Role::Rook && castles_with_it && self.unconfirmed != Some(seen) {
                    self.unconfirmed = Some(seen);
                    return Ok(Resolved::InProgress);
                }
                Ok(Resolved::Move(*one))
            }
            many if many.iter().all(|m| m.is_promotion() && m.from() == many[0].from() && m.to() == many[0].to()) => {
                Ok(Resolved::Promotion(many.to_vec()))
            }
            many => {
                // Captures that read alike: the one whose victim was seen lifted.
                let shown: Vec<Move> =
                    many.iter().copied().filter(|m| m.capture().is_some() && self.lifted.contains(m.to())).collect();
                match shown.as_slice() {
                    [one] => Ok(Resolved::Move(*one)),
                    _ if many.iter().all(|m| m.capture().is_some()) => Ok(Resolved::Choice(many.to_vec())),
                    _ => Err(OccupancyError::Ambiguous {
                        seen: seen_text,
                        count: many.len(),
                        moves: many.iter().map(san).collect::<Vec<_>>().join(", "),
                    }),
                }
            }
        }
    }
}

/// The legal move of `position` after which the board reads `reading`, from that reading alone
/// ([`MoveReader::read`] with no earlier readings).
///
/// # Errors
///
/// As [`MoveReader::read`].
pub fn resolve(position: &Chess, reading: &Reading) -> Result<Resolved, OccupancyError> {
    MoveReader::default().read(position, reading)
}

/// The occupancy of `board` as the 64-character reading (a1 … h8).
pub fn reading_of(board: &Board) -> String {
    Square::ALL.iter().map(|s| if board.occupied().contains(*s) { '1' } else { '0' }).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use shakmaty::fen::Fen;
    use shakmaty::{CastlingMode, Role};

    fn position(fen: &str) -> Chess {
        fen.parse::<Fen>().unwrap().into_position(CastlingMode::Standard).unwrap()
    }

    fn after(position: &Chess, uci: &str) -> (Move, Board) {
        let m = uci.parse::<shakmaty::uci::UciMove>().unwrap().to_move(position).unwrap();
        let mut next = position.clone();
        next.play_unchecked(m);
        (m, next.board().clone())
    }

    /// Every legal move of positions with captures, both castlings, en passant and promotions
    /// resolves back from its occupancy (promotions as the choice of four), and from its FEN
    /// board field exactly.
    #[test]
    fn every_legal_move_reads_back() {
        for fen in [
            "rnbqkbnr/pppppppp/8/8/8/8/PPPPPPPP/RNBQKBNR w KQkq - 0 1",
            "r3k2r/pPpp1ppp/8/3Pp3/8/8/PPP2PPP/R3K2R w KQkq e6 0 1",
            "r3k2r/p1pp1ppp/8/8/3Pp3/8/PpP2PPP/R3K2R b KQkq d3 0 1",
        ] {
            let position = position(fen);
            for m in position.legal_moves() {
                let (_, board) = after(&position, &m.to_uci(CastlingMode::Standard).to_string());
                let bits = parse_reading(&reading_of(&board)).unwrap();
                match resolve(&position, &bits).unwrap() {
                    Resolved::Move(got) => assert_eq!(got, m, "{fen}"),
                    Resolved::Promotion(choices) => {
                        assert!(m.is_promotion() && choices.contains(&m) && choices.len() == 4, "{fen} {m:?}")
                    }
                    Resolved::Choice(choices) => {
                        // Captures alike: with the victim lifted first, the reading tells.
                        assert!(m.capture().is_some() && choices.contains(&m), "{fen} {m:?}");
                        let mut reader = MoveReader::default();
                        let mut lifted = position.board().clone();
                        let _ = lifted.remove_piece_at(m.to());
                        assert_eq!(
                            reader.read(&position, &Reading::Occupied(lifted.occupied())).unwrap(),
                            Resolved::InProgress
                        );
                        assert_eq!(reader.read(&position, &bits).unwrap(), Resolved::Move(m), "{fen} {m:?}");
                    }
                    Resolved::InProgress => {
                        // A rook from its corner while castling is legal: the same reading again.
                        assert_eq!(m.role(), Role::Rook, "{fen} {m:?}");
                        let mut reader = MoveReader::default();
                        assert_eq!(reader.read(&position, &bits).unwrap(), Resolved::InProgress);
                        assert_eq!(reader.read(&position, &bits).unwrap(), Resolved::Move(m), "{fen} {m:?}");
                    }
                    Resolved::Unchanged => panic!("{fen} {m:?}"),
                }
                let named = parse_reading(&board.to_string()).unwrap();
                let mut reader = MoveReader::default();
                let mut resolved = reader.read(&position, &named).unwrap();
                if resolved == Resolved::InProgress {
                    resolved = reader.read(&position, &named).unwrap();
                }
                assert_eq!(resolved, Resolved::Move(m), "{fen}");
            }
        }
    }

    /// The readings' three forms agree; a promotion's piece is read from the FEN's letter.
    #[test]
    fn forms_agree_and_letters_name_the_promotion() {
        let start = Chess::default();
        let (_, board) = after(&start, "e2e4");
        let text = reading_of(&board);
        let hex = format!("0x{:016x}", board.occupied().0);
        let spaced: String =
            text.as_bytes().chunks(8).map(|c| String::from_utf8_lossy(c).into_owned()).collect::<Vec<_>>().join(" / ");
        for form in [text.clone(), hex, spaced, board.to_string()] {
            let Resolved::Move(m) = resolve(&start, &parse_reading(&form).unwrap()).unwrap() else { panic!("{form}") };
            assert_eq!(m.to_uci(CastlingMode::Standard).to_string(), "e2e4", "{form}");
        }
        let promoting = position("8/1P4k1/8/8/8/8/6K1/8 w - - 0 1");
        let (m, board) = after(&promoting, "b7b8n");
        assert_eq!(resolve(&promoting, &parse_reading(&board.to_string()).unwrap()).unwrap(), Resolved::Move(m));
        assert_eq!(m.promotion(), Some(Role::Knight));
    }

    /// A change no legal move makes is refused, naming what changed and what was legal.
    #[test]
    fn impossible_changes_are_refused_with_what_was_seen_and_expected() {
        let start = Chess::default();
        // e2 to e5: a pawn cannot go three squares.
        let mut board = start.board().clone();
        let pawn = board.remove_piece_at(Square::E2).unwrap();
        board.set_piece_at(Square::E5, pawn);
        let error = resolve(&start, &parse_reading(&reading_of(&board)).unwrap()).unwrap_err();
        let text = error.to_string();
        assert!(text.contains("e2 emptied, e5 filled") && text.contains("legal from e2: e3, e4"), "{text}");
        // A piece lifted and not put down: a move in progress.
        let mut lifted = start.board().clone();
        let _ = lifted.remove_piece_at(Square::G1);
        assert_eq!(resolve(&start, &parse_reading(&reading_of(&lifted)).unwrap()).unwrap(), Resolved::InProgress);
        // A knight put down where it cannot go.
        let mut wrong = lifted.clone();
        wrong.set_piece_at(Square::G4, shakmaty::Piece { color: shakmaty::Color::White, role: Role::Knight });
        let text = resolve(&start, &parse_reading(&reading_of(&wrong)).unwrap()).unwrap_err().to_string();
        assert!(text.contains("g1 emptied, g4 filled") && text.contains("Nf3") && text.contains("Nh3"), "{text}");
        // Unchanged, and unreadable text.
        assert_eq!(resolve(&start, &parse_reading(&reading_of(start.board())).unwrap()).unwrap(), Resolved::Unchanged);
        for bad in ["", "0101", "0x1g", "rnbqkbnr/pppppppp/8/8", "2".repeat(64).as_str()] {
            assert!(matches!(parse_reading(bad), Err(OccupancyError::Unreadable(_))), "{bad:?}");
        }
    }

    /// A knight that may take on c6, d7 or f7 reads alike whichever it takes: asked, unless a
    /// reading showed the victim lifted.
    #[test]
    fn captures_that_read_alike_are_told_by_the_lifted_victim_or_asked() {
        let position = position("4k3/3p1p2/2p5/4N3/8/8/8/4K3 w - - 0 1");
        let (m, board) = after(&position, "e5d7");
        let reading = Reading::Occupied(board.occupied());
        let Resolved::Choice(choices) = resolve(&position, &reading).unwrap() else { panic!() };
        assert_eq!(choices.len(), 3);
        let mut reader = MoveReader::default();
        let mut lifted = position.board().clone();
        let _ = lifted.remove_piece_at(Square::D7);
        assert_eq!(reader.read(&position, &Reading::Occupied(lifted.occupied())).unwrap(), Resolved::InProgress);
        let _ = lifted.remove_piece_at(Square::E5);
        assert_eq!(reader.read(&position, &Reading::Occupied(lifted.occupied())).unwrap(), Resolved::InProgress);
        assert_eq!(reader.read(&position, &reading).unwrap(), Resolved::Move(m));
        // Put back untouched: the reader forgets what it saw.
        assert_eq!(
            reader.read(&position, &Reading::Occupied(position.board().occupied())).unwrap(),
            Resolved::Unchanged
        );
        assert!(matches!(reader.read(&position, &reading).unwrap(), Resolved::Choice(_)));
    }

    /// Castling rook first: the rook's move alone is a move in progress (castling is legal
    /// that side); the king following makes it castling; the same rook reading twice is the
    /// rook's move.
    #[test]
    fn castling_rook_first_waits_for_the_king() {
        let position = position("rn1qkbnr/ppp2ppp/3p4/4p3/2B1P1b1/5N2/PPPP1PPP/RNBQK2R w KQkq - 0 1");
        let (rook_move, rook_board) = after(&position, "h1f1");
        let (castle, castle_board) = after(&position, "e1g1");
        let mut reader = MoveReader::default();
        let rook_reading = Reading::Occupied(rook_board.occupied());
        assert_eq!(reader.read(&position, &rook_reading).unwrap(), Resolved::InProgress);
        assert_eq!(
            reader.read(&position, &Reading::Occupied(castle_board.occupied())).unwrap(),
            Resolved::Move(castle)
        );
        reader.reset();
        assert_eq!(reader.read(&position, &rook_reading).unwrap(), Resolved::InProgress);
        assert_eq!(reader.read(&position, &rook_reading).unwrap(), Resolved::Move(rook_move));
    }
}
