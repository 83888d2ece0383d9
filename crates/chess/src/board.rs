//! Board geometry: where each square is in the arm's base frame.
//!
//! The report's layout: squares 6 cm apart, files a–h along x at −21 … +21 cm, rank r along y
//! at 12 + 6(r − 1) cm (the base sits two squares before rank 1), board surface at z = 0.
//! A board may be turned about the vertical by `yaw`: the files then run along
//! `(cos yaw, sin yaw)` and the ranks along `(−sin yaw, cos yaw)`. All values in metres and
//! radians.

use chessarm_core::nalgebra::{Vector2, Vector3};
use shakmaty::{File, Rank, Square};

/// Why a square or board description is not usable.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BoardError {
    #[error("'{0}' is not a square name (expected a file a–h and a rank 1–8, like e4)")]
    SquareName(String),
    #[error("board {field} = {value}: {reason}")]
    Geometry { field: &'static str, value: f64, reason: &'static str },
}

/// Position of the board in the base frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoardGeometry {
    /// Distance between neighbouring square centres, m.
    pub square_size: f64,
    /// Centre of the board (the corner shared by d4, e4, d5, e5) in the base frame, m.
    pub center: Vector2<f64>,
    /// Height of the board surface, m.
    pub surface_height: f64,
    /// Turn of the board about the vertical, rad (0: files along x, ranks along y).
    pub yaw: f64,
    /// How far every square, slot and traverse stays from the arm's base axis, m: the base's
    /// own room (its servo and mount), where the arm would fold over itself.
    pub base_clearance: f64,
    /// The squares turned half a turn on the table: rank 8 where rank 1 would be, while the
    /// graveyards, the reserves and the home point keep their places (`yaw` turns them all).
    /// The 64 square centres are the same points either way, so the arm serves the board
    /// turned exactly when it serves it unturned: this is how a person playing white sits
    /// across from the arm with their first rank in front of them.
    pub squares_turned: bool,
}

impl Default for BoardGeometry {
    /// The report's board: 6 cm squares, centred on the y axis, rank 1 at y = 12 cm.
    fn default() -> Self {
        Self {
            square_size: 0.06,
            center: Vector2::new(0.0, 0.33),
            surface_height: 0.0,
            yaw: 0.0,
            base_clearance: 0.05,
            squares_turned: false,
        }
    }
}

impl BoardGeometry {
    /// Checks that every number is finite and the squares have a positive size.
    pub fn validated(self) -> Result<Self, BoardError> {
        if !(self.square_size.is_finite() && self.square_size > 0.0) {
            return Err(BoardError::Geometry {
                field: "square_size",
                value: self.square_size,
                reason: "must be finite and > 0",
            });
        }
        for (field, value) in [
            ("center.x", self.center.x),
            ("center.y", self.center.y),
            ("surface_height", self.surface_height),
            ("yaw", self.yaw),
        ] {
            if !value.is_finite() {
                return Err(BoardError::Geometry { field, value, reason: "must be finite" });
            }
        }
        if !(self.base_clearance.is_finite() && self.base_clearance >= 0.0) {
            return Err(BoardError::Geometry {
                field: "base_clearance",
                value: self.base_clearance,
                reason: "must be finite and >= 0",
            });
        }
        Ok(self)
    }

    /// The table point (x, y, m) at `files` squares along the files and `ranks` along the
    /// ranks from the board's centre: `centre + R(yaw)·(files, ranks)·square_size`.
    pub fn on_table(&self, files: f64, ranks: f64) -> Vector2<f64> {
        let (sin, cos) = self.yaw.sin_cos();
        // At yaw 0 exactly the report's sums, bit for bit.
        let (u, v) = (files * self.square_size, ranks * self.square_size);
        if self.yaw == 0.0 {
            self.center + Vector2::new(u, v)
        } else {
            self.center + Vector2::new(cos * u - sin * v, sin * u + cos * v)
        }
    }

    /// `square`'s centre in squares along the files and the ranks from the board's centre
    /// (a1: −3.5, −3.5).
    pub fn squares_from_center(square: Square) -> (f64, f64) {
        (f64::from(u8::from(square.file())) - 3.5, f64::from(u8::from(square.rank())) - 3.5)
    }

    /// The unit vector along the board's ranks on the table (from White's side to Black's
    /// before the squares turn): `R(yaw)·(0, 1)`. A knight faces along it.
    pub fn ranks_direction(&self) -> Vector2<f64> {
        let (sin, cos) = self.yaw.sin_cos();
        Vector2::new(-sin, cos)
    }

    /// `square`'s centre in squares from the board's centre along the table's files and ranks
    /// ([`Self::on_table`]): [`Self::squares_from_center`], negated when the squares are
    /// turned.
    pub fn square_on_table(&self, square: Square) -> (f64, f64) {
        let (file, rank) = Self::squares_from_center(square);
        if self.squares_turned { (-file, -rank) } else { (file, rank) }
    }

    /// Centre of `square` on the board surface, m.
    pub fn square_center(&self, square: Square) -> Vector3<f64> {
        let (file, rank) = self.square_on_table(square);
        let xy = self.on_table(file, rank);
        Vector3::new(xy.x, xy.y, self.surface_height)
    }

    /// The point `height` m above the centre of `square`.
    pub fn above(&self, square: Square, height: f64) -> Vector3<f64> {
        self.square_center(square) + Vector3::new(0.0, 0.0, height)
    }

    /// The square under a point and the point's horizontal offset from its centre (m), or
    /// `None` off the board.
    pub fn square_at(&self, point: &Vector3<f64>) -> Option<(Square, Vector2<f64>)> {
        let (sin, cos) = self.yaw.sin_cos();
        let (dx, dy) = (point.x - self.center.x, point.y - self.center.y);
        let (u, v) = if self.yaw == 0.0 { (dx, dy) } else { (cos * dx + sin * dy, -sin * dx + cos * dy) };
        let file = (u / self.square_size + 4.0).floor();
        let rank = (v / self.square_size + 4.0).floor();
        if !(0.0..8.0).contains(&file) || !(0.0..8.0).contains(&rank) {
            return None;
        }
        let (file, rank) = if self.squares_turned { (7.0 - file, 7.0 - rank) } else { (file, rank) };
        let square = Square::from_coords(File::new(file as u32), Rank::new(rank as u32));
        let center = self.square_center(square);
        Some((square, Vector2::new(point.x - center.x, point.y - center.y)))
    }
}

/// Parses a square name such as `d4` (case-insensitive).
pub fn parse_square(name: &str) -> Result<Square, BoardError> {
    name.trim().to_ascii_lowercase().parse::<Square>().map_err(|_| BoardError::SquareName(name.to_string()))
}
