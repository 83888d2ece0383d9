//! What a grip or a release can meet, before any game: every square and slot's *column*, the
//! tool going straight down over it from the highest traverse to each piece's grip height,
//! with the tallest and widest piece of the set standing on every place around it (the
//! squares and slots whose centres lie within 1.5 squares). The arm's solids ([`solids_into`]:
//! its links, housings, pedestal and fingers, open around the widest piece as narrowly as the
//! planner may open them beside a piece, [`MIN_OPENING`] a side or the gripper's own opening
//! when that is less) must keep the
//! clearance margin from those neighbours at every height checked. A game's moves go down and
//! up these columns with any pieces around, so a board whose columns are all clear cannot stop
//! a game on a neighbour at a grip or a release; the traverses pass above the tallest piece by
//! the planner's own margin. With the tool tilted ([`crate::tasks::MotionLimits::pitch`]) the
//! wrist leans over the neighbours on one side: this is what bounds the tilt a board can use.

use super::moves::{ClearanceCheck, MIN_OPENING};
use super::{NearestBuffers, Obstacle, Placed, Rules, StandingPiece, nearest};
use crate::board::BoardGeometry;
use crate::pieces::PieceSet;
use crate::table::{Location, Table};
use chessarm_core::arm::bodies::{ArmSolid, Hand, Part, solids_into};
use chessarm_core::arm::model::ArmModel;
use chessarm_core::arm::task::inverse_kinematics;
use chessarm_core::nalgebra::{Vector2, Vector3};
use shakmaty::{Board, Square};

/// How far around a place its neighbours stand, in squares: the eight squares around a square
/// (the diagonal ones at √2 ≈ 1.41), and the slots beside a slot.
pub const NEIGHBOURHOOD: f64 = 1.5;

/// A column that is not clear: where, at which height (m above the table), which part of the
/// arm, how near (m) to the piece on which neighbouring place.
#[derive(Debug, Clone, PartialEq)]
pub struct Crowded {
    pub place: String,
    pub height: f64,
    /// The tool's pitch, rad.
    pub pitch: f64,
    pub part: Part,
    pub neighbour: String,
    pub distance: f64,
}

impl std::fmt::Display for Crowded {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "over {} at {:.1} mm above the table with the tool {}, {} would come {:.1} mm from a piece on {} (the \
             tallest and widest piece of the set stands on every neighbouring place)",
            self.place,
            self.height * 1e3,
            tilt_words(self.pitch),
            self.part,
            self.distance * 1e3,
            self.neighbour
        )
    }
}

/// Checks every column of `geometry` (see the module) with the tool at `pitch` (rad), at
/// the `heights` given (m above the table; each at or above its piece's grip height), the arm
/// and its fingers as `check` describes them, keeping `check.margin`. Heights the arm does not
/// reach are left to the reach check. The first column that is not clear is returned.
pub fn check_columns(
    arm: &ArmModel<4>,
    check: &ClearanceCheck,
    geometry: &BoardGeometry,
    pieces: &PieceSet,
    heights: &[f64],
    pitch: f64,
) -> Result<(), Crowded> {
    let table = Table::new(*geometry, &Board::empty());
    let places: Vec<(String, Vector2<f64>)> = Square::ALL
        .into_iter()
        .map(Location::Square)
        .chain(Location::off_board())
        .map(|location| (location.to_string(), table.nominal_position(location)))
        .collect();
    let reach = NEIGHBOURHOOD * geometry.square_size;
    let neighbour = |at: Vector2<f64>| StandingPiece {
        base: Vector3::new(at.x, at.y, geometry.surface_height),
        radius: 0.5 * pieces.widest(),
        height: pieces.tallest(),
    };
    let mut gripper = check.gripper;
    gripper.finger_opening = gripper.finger_opening.min(MIN_OPENING);
    let hand = Hand { gripper, gap: gripper.open_gap(pieces.widest()), held: None };
    // Only the arm against the neighbours: the table and the arm itself are the sweeps' (the
    // columns do not change with what stands around them).
    let rules = Rules { table: None, off_table: Vec::new(), touching: Vec::new(), self_check: false };
    let mut solids: Vec<ArmSolid> = Vec::new();
    let mut buffers = NearestBuffers::default();
    for (name, centre) in &places {
        let around: Vec<usize> = (0..places.len())
            .filter(|&k| {
                let d = (places[k].1 - centre).norm();
                d > 1e-9 && d < reach
            })
            .collect();
        if around.is_empty() {
            continue;
        }
        let standing: Vec<Placed> = around.iter().map(|&k| Placed::piece(&neighbour(places[k].1))).collect();
        for &h in heights {
            let tip = Vector3::new(centre.x, centre.y, geometry.surface_height + h);
            let Ok(q) = inverse_kinematics(arm, &tip, pitch) else { continue };
            solids_into(arm, &q, &hand, &check.bodies, &mut solids);
            let found = nearest::<4>(&solids, &standing, &[], None, &rules, &mut buffers);
            if let Some(closest) = found.still
                && closest.distance < check.margin
                && let Obstacle::Piece(k) = closest.obstacle
            {
                return Err(Crowded {
                    place: name.clone(),
                    height: h,
                    pitch,
                    part: closest.part,
                    neighbour: places[around[k]].0.clone(),
                    distance: closest.distance,
                });
            }
        }
    }
    Ok(())
}

/// The tool's pitch in words: "straight down", or its tilt from it in degrees (converted here,
/// for messages) and which way it leans.
pub fn tilt_words(pitch: f64) -> String {
    let tilt = pitch - chessarm_core::arm::task::TOOL_DOWN;
    if tilt == 0.0 {
        return "straight down".to_string();
    }
    let way = if tilt > 0.0 { "out, away from the base" } else { "in, towards the base" };
    format!("tilted {:.0}° {way} (pitch {pitch:.4} rad)", tilt.abs().to_degrees())
}
