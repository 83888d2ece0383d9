//! The table around the board: where every physical piece stands, on the board, in a
//! graveyard of captured pieces or in the reserve of spare pieces for promotions.
//!
//! Zones are placed relative to the [`BoardGeometry`] in units of the square size, so a moved
//! or rescaled board moves them too. Values below are for the report's board (6 cm squares,
//! centre at (0, 0.33) m, rank 1 at y = 0.12 m, board edges at x = ±0.24 m and y = 0.09 m):
//!
//! - graveyards, one per colour beside the board, white's on the +x side and black's on the −x
//!   side: two columns at |x| = 0.28 m (slots 0–7) and 0.34 m (slots 8–15), eight rows from
//!   y = 0.12 m in steps of 0.05 m (up to y = 0.47 m): 16 slots per colour, filled lowest first;
//! - reserves, one spare queen, rook, bishop and knight per colour (slots 0–3 in that order),
//!   on the base line y = 0.06 m between the arm and the board, at |x| = 0.09, 0.15, 0.21 and
//!   0.27 m (white +x, black −x).
//!
//! The far corner of a graveyard, (±0.34, 0.47) m, is 0.58 m from the base axis, as far as h8;
//! the report's arm reaches it with the tool down up to a tip height of about 0.28 m.
//! The table surface is the board surface (`BoardGeometry::surface_height`).

use crate::board::BoardGeometry;
use crate::pieces::{PieceSet, piece_name};
use chessarm_core::nalgebra::{Vector2, Vector3};
use shakmaty::{Board, Chess, Color, Piece, Position, Role, Square};
use std::fmt;

/// Number of graveyard rows per column.
pub const GRAVEYARD_ROWS: usize = 8;
/// Number of graveyard slots per colour (two columns of [`GRAVEYARD_ROWS`]).
pub const GRAVEYARD_SLOTS: usize = 2 * GRAVEYARD_ROWS;
/// Distance of the two graveyard columns from the board centre along x, in square sizes
/// (0.28 and 0.34 m on 6 cm squares); white's at +x, black's at −x.
pub const GRAVEYARD_COLUMN_X: [f64; 2] = [14.0 / 3.0, 17.0 / 3.0];
/// y of the first graveyard row relative to the board centre, in square sizes (the rank-1
/// centres: 0.12 m on the report's board).
pub const GRAVEYARD_FIRST_ROW_Y: f64 = -3.5;
/// Distance between graveyard rows, in square sizes (0.05 m on 6 cm squares).
pub const GRAVEYARD_ROW_STEP: f64 = 5.0 / 6.0;
/// The spare pieces of each colour's reserve, by slot: two queens (promotions are mostly to
/// queens), a rook, a bishop and a knight.
pub const RESERVE_ROLES: [Role; 5] = [Role::Queen, Role::Rook, Role::Bishop, Role::Knight, Role::Queen];
/// Distance of the reserve slots from the board centre along x, in square sizes (0.09, 0.15,
/// 0.21, 0.27, 0.33 m on 6 cm squares); white's at +x, black's at −x.
pub const RESERVE_X: [f64; 5] = [1.5, 2.5, 3.5, 4.5, 5.5];
/// y of the reserve relative to the board centre, in square sizes (half a square outside the
/// near edge: 0.06 m on the report's board).
pub const RESERVE_Y: f64 = -4.5;

/// Where a physical piece is meant to stand.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Location {
    /// A square of the board.
    Square(Square),
    /// A slot (`0..GRAVEYARD_SLOTS`) of the graveyard of captured pieces of `color`.
    Graveyard {
        /// Colour of the pieces kept there.
        color: Color,
        /// Slot index.
        slot: usize,
    },
    /// A slot (`0..RESERVE_ROLES.len()`, see [`RESERVE_ROLES`]) of the spare pieces of `color`.
    Reserve {
        /// Colour of the pieces kept there.
        color: Color,
        /// Slot index.
        slot: usize,
    },
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Location::Square(square) => write!(f, "{square}"),
            Location::Graveyard { color, slot } => write!(f, "{color} graveyard slot {slot}"),
            Location::Reserve { color, slot } => write!(f, "{color} reserve slot {slot}"),
        }
    }
}

impl Location {
    /// Whether the location exists: every square, graveyard slots `< GRAVEYARD_SLOTS`,
    /// reserve slots `< RESERVE_ROLES.len()`.
    pub fn exists(&self) -> bool {
        match *self {
            Location::Square(_) => true,
            Location::Graveyard { slot, .. } => slot < GRAVEYARD_SLOTS,
            Location::Reserve { slot, .. } => slot < RESERVE_ROLES.len(),
        }
    }

    /// Every graveyard and reserve slot of both colours.
    pub fn off_board() -> impl Iterator<Item = Location> {
        Color::ALL.into_iter().flat_map(|color| {
            (0..GRAVEYARD_SLOTS)
                .map(move |slot| Location::Graveyard { color, slot })
                .chain((0..RESERVE_ROLES.len()).map(move |slot| Location::Reserve { color, slot }))
        })
    }
}

/// Why a table operation failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TableError {
    /// Nothing stands at the location.
    #[error("no piece stands at {0}")]
    Empty(Location),
    /// Another piece already stands at the destination.
    #[error("{location} is taken by a {piece}")]
    Occupied {
        /// The destination.
        location: Location,
        /// Name of the piece standing there.
        piece: String,
    },
    /// The slot index is out of range.
    #[error("{0} does not exist: there are {GRAVEYARD_SLOTS} graveyard and 4 reserve slots per colour")]
    NoSuchSlot(Location),
    /// Every graveyard slot of the colour is taken.
    #[error("the {0} graveyard is full: all {GRAVEYARD_SLOTS} slots are taken")]
    GraveyardFull(Color),
    /// A position is NaN or infinite.
    #[error("position ({x}, {y}) m for {location} must be finite")]
    Position {
        /// The destination.
        location: Location,
        /// x, m.
        x: f64,
        /// y, m.
        y: f64,
    },
}

/// One physical piece on the table.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PhysicalPiece {
    /// Which piece it is.
    pub piece: Piece,
    /// Where it is meant to stand.
    pub location: Location,
    /// Where its base centre actually stands on the table (x, y, m, base frame); may differ
    /// from the nominal slot or square centre.
    pub position: Vector2<f64>,
}

/// A discrepancy between the table and the rules' board, found by [`Table::verify`].
#[derive(Debug, Clone, PartialEq)]
pub struct Misplaced {
    /// The square concerned, if the piece stands on (or is missing from) the board.
    pub square: Option<Square>,
    /// The piece concerned (the one standing there, or the missing one).
    pub piece: Option<Piece>,
    /// Distance of the piece's base centre from the square centre, m (0 for a missing piece).
    pub offset_m: f64,
    /// One-line description.
    pub reason: String,
}

impl fmt::Display for Misplaced {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.reason)
    }
}

/// Every physical piece: on the board, in the graveyards and in the reserves.
#[derive(Debug, Clone, PartialEq)]
pub struct Table {
    geometry: BoardGeometry,
    pieces: Vec<PhysicalPiece>,
}

impl Table {
    /// The pieces of `board` on their square centres, a full reserve (one spare queen, rook,
    /// bishop and knight per colour), empty graveyards.
    pub fn new(geometry: BoardGeometry, board: &Board) -> Self {
        let mut table = Self { geometry, pieces: Vec::new() };
        for (square, piece) in board {
            table.place(piece, Location::Square(square));
        }
        for color in Color::ALL {
            for (slot, role) in RESERVE_ROLES.into_iter().enumerate() {
                table.place(role.of(color), Location::Reserve { color, slot });
            }
        }
        table
    }

    /// [`Table::new`] with the board of a position.
    pub fn from_position(geometry: BoardGeometry, position: &Chess) -> Self {
        Self::new(geometry, position.board())
    }

    fn place(&mut self, piece: Piece, location: Location) {
        let position = self.nominal_position(location);
        self.pieces.push(PhysicalPiece { piece, location, position });
    }

    /// The board's geometry (m).
    pub fn geometry(&self) -> &BoardGeometry {
        &self.geometry
    }

    /// Every physical piece.
    pub fn pieces(&self) -> &[PhysicalPiece] {
        &self.pieces
    }

    /// Nominal centre (x, y, m) of a location: the square centre, or the slot centre. Slot
    /// indices beyond the zone extrapolate its grid.
    pub fn nominal_position(&self, location: Location) -> Vector2<f64> {
        let g = &self.geometry;
        let side = |color: Color| if color == Color::White { 1.0 } else { -1.0 };
        let (x, y) = match location {
            Location::Square(square) => {
                let center = g.square_center(square);
                return Vector2::new(center.x, center.y);
            }
            Location::Graveyard { color, slot } => {
                let column = slot / GRAVEYARD_ROWS;
                let row = slot % GRAVEYARD_ROWS;
                let column_x = GRAVEYARD_COLUMN_X[0] + (GRAVEYARD_COLUMN_X[1] - GRAVEYARD_COLUMN_X[0]) * column as f64;
                (side(color) * column_x, GRAVEYARD_FIRST_ROW_Y + GRAVEYARD_ROW_STEP * row as f64)
            }
            Location::Reserve { color, slot } => {
                let step = RESERVE_X[1] - RESERVE_X[0];
                (side(color) * (RESERVE_X[0] + step * slot as f64), RESERVE_Y)
            }
        };
        g.on_table(x, y)
    }

    /// The piece meant to stand at `location`, if any.
    pub fn piece_at(&self, location: Location) -> Option<&PhysicalPiece> {
        self.pieces.iter().find(|p| p.location == location)
    }

    /// Index in [`Table::pieces`] of the piece meant to stand at `location`, if any. A piece
    /// keeps its index for the table's whole life: relocating it changes only its location.
    pub fn index_at(&self, location: Location) -> Option<usize> {
        self.pieces.iter().position(|p| p.location == location)
    }

    /// The lowest free graveyard slot of `color`.
    pub fn free_graveyard_slot(&self, color: Color) -> Result<usize, TableError> {
        (0..GRAVEYARD_SLOTS)
            .find(|&slot| self.piece_at(Location::Graveyard { color, slot }).is_none())
            .ok_or(TableError::GraveyardFull(color))
    }

    /// The lowest graveyard slot holding `piece` (of the piece's colour), e.g. a captured
    /// queen to bring back for a promotion.
    pub fn graveyard_slot_holding(&self, piece: Piece) -> Option<usize> {
        self.lowest_slot(piece, |location| match location {
            Location::Graveyard { color, slot } if color == piece.color => Some(slot),
            _ => None,
        })
    }

    /// The lowest reserve slot of the piece's colour holding `piece`.
    pub fn reserve_slot_holding(&self, piece: Piece) -> Option<usize> {
        self.lowest_slot(piece, |location| match location {
            Location::Reserve { color, slot } if color == piece.color => Some(slot),
            _ => None,
        })
    }

    fn lowest_slot(&self, piece: Piece, slot_of: impl Fn(Location) -> Option<usize>) -> Option<usize> {
        self.pieces.iter().filter(|p| p.piece == piece).filter_map(|p| slot_of(p.location)).min()
    }

    /// Moves the piece at `from` to `to`, standing at `actual` (x, y, m): the simulation
    /// decides where it was released. `from == to` only updates its position.
    pub fn relocate(&mut self, from: Location, to: Location, actual: Vector2<f64>) -> Result<(), TableError> {
        if !to.exists() {
            return Err(TableError::NoSuchSlot(to));
        }
        if !(actual.x.is_finite() && actual.y.is_finite()) {
            return Err(TableError::Position { location: to, x: actual.x, y: actual.y });
        }
        if to != from
            && let Some(other) = self.piece_at(to)
        {
            return Err(TableError::Occupied { location: to, piece: piece_name(other.piece) });
        }
        let moving = self.pieces.iter_mut().find(|p| p.location == from).ok_or(TableError::Empty(from))?;
        moving.location = to;
        moving.position = actual;
        Ok(())
    }

    /// The board as the table shows it: each piece whose base centre lies over the board is
    /// snapped to the square under it ([`BoardGeometry::square_at`]), whatever its recorded
    /// location. Returns the board and, sorted by square, each such piece with its offset
    /// from the square centre (x, y, m).
    pub fn snapped_board(&self) -> (Board, Vec<(Square, Piece, Vector2<f64>)>) {
        let mut standing: Vec<_> = self
            .pieces
            .iter()
            .filter_map(|p| self.square_under(p).map(|(square, offset)| (square, p.piece, offset)))
            .collect();
        standing.sort_by_key(|(square, _, _)| *square);
        let mut board = Board::empty();
        for (square, piece, _) in &standing {
            board.set_piece_at(*square, *piece);
        }
        (board, standing)
    }

    fn square_under(&self, piece: &PhysicalPiece) -> Option<(Square, Vector2<f64>)> {
        let point = Vector3::new(piece.position.x, piece.position.y, self.geometry.surface_height);
        self.geometry.square_at(&point)
    }

    /// Compares the table with the rules' board. Reports every piece standing more than
    /// `tolerance` m from its square centre, on a square where the rules have another piece or
    /// none, sharing a square, recorded on a square but standing off the board, and every
    /// piece of the rules with nothing standing on its square.
    pub fn verify(&self, rules: &Board, tolerance: f64) -> Vec<Misplaced> {
        let (_, standing) = self.snapped_board();
        let mut found = Vec::new();
        let mm = |m: f64| m * 1000.0;
        for square in Square::ALL {
            let here: Vec<_> = standing.iter().filter(|(s, _, _)| *s == square).collect();
            let expected = rules.piece_at(square);
            if here.is_empty() {
                if let Some(piece) = expected {
                    found.push(Misplaced {
                        square: Some(square),
                        piece: Some(piece),
                        offset_m: 0.0,
                        reason: format!("{} missing from {square}: nothing stands there", piece_name(piece)),
                    });
                }
                continue;
            }
            if here.len() > 1 {
                found.push(Misplaced {
                    square: Some(square),
                    piece: None,
                    offset_m: 0.0,
                    reason: format!("{} pieces stand on {square}", here.len()),
                });
            }
            for &&(_, piece, offset) in &here {
                let distance = offset.norm();
                if Some(piece) != expected {
                    let wanted = expected.map_or_else(|| "nothing".to_string(), piece_name);
                    found.push(Misplaced {
                        square: Some(square),
                        piece: Some(piece),
                        offset_m: distance,
                        reason: format!("{} stands on {square}, where the rules have {wanted}", piece_name(piece)),
                    });
                }
                if distance > tolerance {
                    found.push(Misplaced {
                        square: Some(square),
                        piece: Some(piece),
                        offset_m: distance,
                        reason: format!(
                            "{} stands {:.1} mm from the centre of {square} (tolerance {:.1} mm)",
                            piece_name(piece),
                            mm(distance),
                            mm(tolerance)
                        ),
                    });
                }
            }
        }
        for p in &self.pieces {
            if let Location::Square(square) = p.location
                && self.square_under(p).is_none()
            {
                let nominal = self.nominal_position(p.location);
                found.push(Misplaced {
                    square: Some(square),
                    piece: Some(p.piece),
                    offset_m: (p.position - nominal).norm(),
                    reason: format!(
                        "{} recorded on {square} stands off the board at ({:.4}, {:.4}) m",
                        piece_name(p.piece),
                        p.position.x,
                        p.position.y
                    ),
                });
            }
        }
        found
    }

    /// Height (m) of the tallest piece whose base centre lies within `clearance_radius` m of
    /// the segment between the table points `from` and `to` (x, y, m), leaving out the piece
    /// at `exclude`; 0 when there is none. Used to pick the traverse height.
    pub fn tallest_under(
        &self,
        from: Vector2<f64>,
        to: Vector2<f64>,
        clearance_radius: f64,
        pieces: &PieceSet,
        exclude: Option<Location>,
    ) -> f64 {
        self.tallest_under_point_where(from, to, clearance_radius, pieces, |p| Some(p.location) != exclude)
            .unwrap_or(0.0)
    }

    /// The height of the tallest piece that `keep` accepts with its base centre within
    /// `clearance_radius` of the segment `from`–`to` (m), or `None` when there is none.
    pub fn tallest_under_point_where(
        &self,
        from: Vector2<f64>,
        to: Vector2<f64>,
        clearance_radius: f64,
        pieces: &PieceSet,
        keep: impl Fn(&PhysicalPiece) -> bool,
    ) -> Option<f64> {
        self.pieces
            .iter()
            .filter(|p| keep(p))
            .filter(|p| distance_to_segment(p.position, from, to) <= clearance_radius)
            .map(|p| pieces.dimensions(p.piece.role).height)
            .reduce(f64::max)
    }
}

/// Distance (m) from `point` to the segment `a`–`b` in the table plane.
fn distance_to_segment(point: Vector2<f64>, a: Vector2<f64>, b: Vector2<f64>) -> f64 {
    (point - closest_on_segment(point, a, b)).norm()
}

/// The point of the segment `a`–`b` closest to `point` (table plane, m).
pub(crate) fn closest_on_segment(point: Vector2<f64>, a: Vector2<f64>, b: Vector2<f64>) -> Vector2<f64> {
    let ab = b - a;
    let length_squared = ab.norm_squared();
    let t = if length_squared > 0.0 { ((point - a).dot(&ab) / length_squared).clamp(0.0, 1.0) } else { 0.0 };
    a + ab * t
}
