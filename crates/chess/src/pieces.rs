//! Chess pieces as physical objects: height, base diameter, mass, their Staunton profile (a
//! solid of revolution, a knight's head a block) and where the gripper holds them. All values
//! in SI units (m, kg).

use chessarm_core::arm::model::Payload;
use chessarm_core::arm::outline::Outline;
use shakmaty::{Color, Piece, Role};

/// Why a piece set is not usable.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PieceError {
    /// A dimension is not finite, not positive, or the grip point lies outside the piece.
    #[error("{role} {field} = {value}: {reason}")]
    Dimension {
        /// The piece kind, e.g. "king".
        role: &'static str,
        /// The field, e.g. "grip_height".
        field: &'static str,
        /// The offending value (m or kg).
        value: f64,
        /// What is required.
        reason: &'static str,
    },
}

/// Size and mass of one kind of piece.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PieceDimensions {
    /// Height from the base to the top, m.
    pub height: f64,
    /// Diameter of the base (the widest part of a Staunton piece), m.
    pub base_diameter: f64,
    /// Mass, kg.
    pub mass: f64,
    /// Height above the piece's base where the tool tip is while gripping it, m (in `(0, height]`):
    /// the middle of the fingers' pads.
    pub grip_height: f64,
    /// The piece's shape as a solid of revolution, in fractions: ring heights of `height`, ring
    /// radii (and the block's half sizes) of half `base_diameter` ([`PieceDimensions::outline`]
    /// gives it in metres), so that a new height or base diameter keeps the profile.
    pub shape: Outline,
}

impl PieceDimensions {
    /// The piece's outline in metres: [`PieceDimensions::shape`] × (height, base radius).
    pub fn outline(&self) -> Outline {
        self.shape.scaled(self.height, 0.5 * self.base_diameter)
    }

    /// The piece as a solid of its outline, uniform density, gripped `grip_height` m above its
    /// base (tool pointing down): [`Payload::upright`].
    pub fn payload(&self) -> Payload {
        Payload::upright(self.mass, &self.outline(), self.grip_height)
    }

    /// The gap the closed fingers hold the piece at, m: its widest diameter at or above where
    /// the fingers' ends are (`reach` m below the grip height), which parallel pads touch
    /// first; the block (a knight's head) counted turned any way.
    pub fn grip_width(&self, reach: f64) -> f64 {
        2.0 * self.outline().widest_above(self.grip_height - reach)
    }
}

/// The six kinds of pieces of a set.
///
/// The default is a weighted tournament (Staunton) set for 6 cm squares, king 9.5 cm tall
/// (FIDE: base diameter 40–50 % of the king's height, king ≈ 75 % of the square size or more),
/// each piece the cylinder of its base (a profile is given by [`PieceDimensions::shape`],
/// `[pieces.KIND] outline` in a setup file):
///
/// | piece  | height | base ⌀ | mass | grip height          |
/// |--------|--------|--------|------|----------------------|
/// | king   | 9.5 cm | 4.0 cm | 60 g | 7.6 cm (80 %)        |
/// | queen  | 8.5 cm | 3.8 cm | 50 g | 6.8 cm (80 %)        |
/// | bishop | 7.0 cm | 3.3 cm | 40 g | 5.6 cm (80 %)        |
/// | knight | 6.0 cm | 3.3 cm | 40 g | 4.8 cm (80 %)        |
/// | rook   | 5.5 cm | 3.3 cm | 40 g | 4.4 cm (80 %)        |
/// | pawn   | 5.0 cm | 2.9 cm | 30 g | 5.0 cm (top, report) |
///
/// The pawn is the report's: 5 cm tall and gripped at its top, so the report's grip height of
/// 5 cm is kept. Every base is narrower than a 6 cm square.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PieceSet {
    /// Pawn dimensions (m, kg).
    pub pawn: PieceDimensions,
    /// Knight dimensions (m, kg).
    pub knight: PieceDimensions,
    /// Bishop dimensions (m, kg).
    pub bishop: PieceDimensions,
    /// Rook dimensions (m, kg).
    pub rook: PieceDimensions,
    /// Queen dimensions (m, kg).
    pub queen: PieceDimensions,
    /// King dimensions (m, kg).
    pub king: PieceDimensions,
}

impl Default for PieceSet {
    /// The weighted Staunton set of the table above (6 cm squares), cylinders of their bases.
    fn default() -> Self {
        let piece = |height: f64, base_diameter: f64, mass: f64, grip_fraction: f64| PieceDimensions {
            height,
            base_diameter,
            mass,
            grip_height: height * grip_fraction,
            shape: Outline::cylinder(1.0, 1.0),
        };
        Self {
            pawn: piece(0.050, 0.029, 0.030, 1.0),
            knight: piece(0.060, 0.033, 0.040, 0.8),
            bishop: piece(0.070, 0.033, 0.040, 0.8),
            rook: piece(0.055, 0.033, 0.040, 0.8),
            queen: piece(0.085, 0.038, 0.050, 0.8),
            king: piece(0.095, 0.040, 0.060, 0.8),
        }
    }
}

impl PieceSet {
    /// Dimensions (m, kg) of the pieces of kind `role`.
    pub fn dimensions(&self, role: Role) -> &PieceDimensions {
        match role {
            Role::Pawn => &self.pawn,
            Role::Knight => &self.knight,
            Role::Bishop => &self.bishop,
            Role::Rook => &self.rook,
            Role::Queen => &self.queen,
            Role::King => &self.king,
        }
    }

    /// Dimensions of the pieces of kind `role`, to change.
    pub fn dimensions_mut(&mut self, role: Role) -> &mut PieceDimensions {
        match role {
            Role::Pawn => &mut self.pawn,
            Role::Knight => &mut self.knight,
            Role::Bishop => &mut self.bishop,
            Role::Rook => &mut self.rook,
            Role::Queen => &mut self.queen,
            Role::King => &mut self.king,
        }
    }

    /// Every kind with its dimensions (m, kg), pawn to king.
    pub fn all(&self) -> [(Role, &PieceDimensions); 6] {
        Role::ALL.map(|role| (role, self.dimensions(role)))
    }

    /// The set scaled by `k` (squares `k` times as large): lengths × `k`, masses × `k³` (the
    /// volume). The profiles are fractions of the lengths, so they keep their shape.
    pub fn scaled(&self, k: f64) -> Self {
        let mut scaled = *self;
        for role in Role::ALL {
            let d = scaled.dimensions_mut(role);
            d.height *= k;
            d.base_diameter *= k;
            d.grip_height *= k;
            d.mass *= k * k * k;
        }
        scaled
    }

    /// Height of the tallest piece, m.
    pub fn tallest(&self) -> f64 {
        self.all().iter().map(|(_, d)| d.height).fold(0.0, f64::max)
    }

    /// Base diameter of the widest piece, m.
    pub fn widest(&self) -> f64 {
        self.all().iter().map(|(_, d)| d.base_diameter).fold(0.0, f64::max)
    }

    /// The outline holding every kind's, m ([`Outline::envelope`]): what may stand on a
    /// neighbouring square.
    pub fn envelope(&self) -> Outline {
        self.envelope_of(&Role::ALL)
    }

    /// The outline holding the kinds `roles`', m.
    pub fn envelope_of(&self, roles: &[Role]) -> Outline {
        let outlines: Vec<Outline> = roles.iter().map(|&r| self.dimensions(r).outline()).collect();
        Outline::envelope(&outlines).unwrap_or_else(|| Outline::cylinder(0.5 * self.widest(), self.tallest()))
    }

    /// Largest grip height of any piece, m: the longest stretch of a carried piece below the
    /// tool tip.
    pub fn highest_grip(&self) -> f64 {
        self.all().iter().map(|(_, d)| d.grip_height).fold(0.0, f64::max)
    }

    /// The piece of kind `role` as a gripped payload (solid cylinder; kg, m).
    pub fn payload(&self, role: Role) -> Payload {
        self.dimensions(role).payload()
    }

    /// Checks that every number is finite and positive and that each grip height lies in
    /// `(0, height]` m.
    pub fn validated(self) -> Result<Self, PieceError> {
        for (role, dims) in self.all() {
            let role = role_name(role);
            let fields = [
                ("height", dims.height),
                ("base_diameter", dims.base_diameter),
                ("mass", dims.mass),
                ("grip_height", dims.grip_height),
            ];
            for (field, value) in fields {
                if !(value.is_finite() && value > 0.0) {
                    return Err(PieceError::Dimension { role, field, value, reason: "must be finite and > 0" });
                }
            }
            if dims.grip_height > dims.height {
                return Err(PieceError::Dimension {
                    role,
                    field: "grip_height",
                    value: dims.grip_height,
                    reason: "must not exceed the piece's height",
                });
            }
        }
        Ok(self)
    }
}

/// English name of a kind of piece: "pawn", "knight", "bishop", "rook", "queen", "king".
pub fn role_name(role: Role) -> &'static str {
    match role {
        Role::Pawn => "pawn",
        Role::Knight => "knight",
        Role::Bishop => "bishop",
        Role::Rook => "rook",
        Role::Queen => "queen",
        Role::King => "king",
    }
}

/// English name of a piece, e.g. "white queen".
pub fn piece_name(piece: Piece) -> String {
    let color = match piece.color {
        Color::White => "white",
        Color::Black => "black",
    };
    format!("{color} {}", role_name(piece.role))
}
