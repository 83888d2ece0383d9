//! The report's scenario "queens-gambit": the pawn d2 → d4 (1. d4), with the report's
//! waypoints and timing (ERRATA "Facts to keep").

use crate::board::BoardGeometry;
use chessarm_core::nalgebra::Vector3;
use chessarm_core::plan::path::{CartesianPath, GripperAction};
use chessarm_core::plan::profile::ProfileError;
use shakmaty::Square;

/// Parameters of a report-style single pick-and-place with fixed move durations.
#[derive(Debug, Clone, PartialEq)]
pub struct FixedTimingMove {
    pub from: Square,
    pub to: Square,
    /// Where the tool tip starts, m.
    pub start: Vector3<f64>,
    /// Height of the traverse above the board, m.
    pub clearance: f64,
    /// Height of the tool tip when gripping, m (the report: the pawn's 5 cm).
    pub grip_height: f64,
    /// Durations of the seven moves: rise, traverse, descend, rise, traverse, descend, rise (s).
    pub durations: [f64; 7],
    /// Pause between moves, s.
    pub pause: f64,
}

/// Names of the built-in scenarios.
pub const SCENARIOS: [&str; 1] = ["queens-gambit"];

/// The report's move d2 → d4: start at (21, 0, 0) cm (below file h's x, at the base line),
/// clearance 15 cm, grip height 5 cm, durations 1, 3, 1, 1, 2, 1, 1 s, 0.5 s pauses: 13 s.
pub fn queens_gambit(board: &BoardGeometry) -> FixedTimingMove {
    let h_file_x = board.square_center(Square::H1).x;
    FixedTimingMove {
        from: Square::D2,
        to: Square::D4,
        start: Vector3::new(h_file_x, 0.0, board.surface_height),
        clearance: 0.15,
        grip_height: 0.05,
        durations: [1.0, 3.0, 1.0, 1.0, 2.0, 1.0, 1.0],
        pause: 0.5,
    }
}

/// Looks up a built-in scenario by name.
pub fn scenario(name: &str, board: &BoardGeometry) -> Option<FixedTimingMove> {
    match name {
        "queens-gambit" => Some(queens_gambit(board)),
        _ => None,
    }
}

impl FixedTimingMove {
    /// The tool-tip path: rise from the start, traverse over `from`, descend and grip, rise,
    /// traverse over `to`, descend and release, rise; a pause between consecutive moves.
    pub fn path(&self, board: &BoardGeometry) -> Result<CartesianPath, ProfileError> {
        let lift = Vector3::new(0.0, 0.0, self.clearance);
        let waypoints = [
            self.start + lift,
            board.above(self.from, self.clearance),
            board.above(self.from, self.grip_height),
            board.above(self.from, self.clearance),
            board.above(self.to, self.clearance),
            board.above(self.to, self.grip_height),
            board.above(self.to, self.clearance),
        ];
        let mut path = CartesianPath::new(self.start);
        for (index, (waypoint, duration)) in waypoints.iter().zip(self.durations).enumerate() {
            if index > 0 {
                path.pause(self.pause)?;
            }
            path.move_to(*waypoint, duration)?;
            match index {
                2 => path.mark(GripperAction::Grip),
                5 => path.mark(GripperAction::Release),
                _ => &mut path,
            };
        }
        Ok(path)
    }
}
