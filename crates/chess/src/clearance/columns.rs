//! What a grip or a release can meet, before any game: every square and slot's *column*, the
//! tool going straight down over it from the highest traverse to each piece's grip height,
//! with the tallest and widest piece of the set standing on every place around it (the
//! squares and slots whose centres lie within 1.5 squares; a king never leaves the board, so
//! on a graveyard or reserve slot the tallest and widest of the others). The arm's solids ([`solids_into`]:
//! its links, housings, pedestal and fingers, open around the piece gripped there as narrowly
//! as the planner may open them beside a piece, [`MIN_OPENING`] a side or the gripper's own opening
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
use shakmaty::{Board, Role, Square};
use std::ops::ControlFlow;

/// How far around a place its neighbours stand, in squares: the eight squares around a square
/// (the diagonal ones at √2 ≈ 1.41), and the slots beside a slot.
pub const NEIGHBOURHOOD: f64 = 1.5;

/// A column that is not clear: where, at which height (m above the table), which part of the
/// arm, how near (m) to the piece on which neighbouring place.
#[derive(Debug, Clone, PartialEq)]
pub struct Crowded {
    pub place: String,
    /// The place's index among the board's places (squares a1 … h8, then the slots): the
    /// column to check first at another pitch.
    pub place_index: usize,
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
            "over {} at {:.1} mm above the table with the tool {}, {} would come {:.1} mm from a piece on {} (every \
             kind gripped there, the tallest and widest piece of the set on every neighbouring place)",
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
/// reach are left to the reach check. The first column that is not clear is returned; the
/// place of index `first` is checked before the others (one found crowded at another pitch
/// usually is at this one too).
pub fn check_columns(
    arm: &ArmModel<4>,
    check: &ClearanceCheck,
    geometry: &BoardGeometry,
    pieces: &PieceSet,
    heights: &[f64],
    pitch: f64,
    first: Option<usize>,
) -> Result<(), Crowded> {
    let mut found = None;
    each_crowded(arm, check, geometry, pieces, heights, pitch, first, |crowded| {
        found = Some(crowded);
        ControlFlow::Break(())
    });
    found.map_or(Ok(()), Err)
}

/// Every column of `geometry` that is not clear ([`check_columns`]), one [`Crowded`] per place
/// (the first height and part found there), in the places' order: what a board of given
/// squares leaves crowded, for `chessarm board --fit --square-size`.
pub fn crowded_columns(
    arm: &ArmModel<4>,
    check: &ClearanceCheck,
    geometry: &BoardGeometry,
    pieces: &PieceSet,
    heights: &[f64],
    pitch: f64,
) -> Vec<Crowded> {
    let mut all = Vec::new();
    each_crowded(arm, check, geometry, pieces, heights, pitch, None, |crowded| {
        all.push(crowded);
        ControlFlow::Continue(())
    });
    all
}

/// The columns' check: `crowded_at` is told of each place's first crowding (then the next place is
/// checked, unless it breaks), the place of index `first` checked before the others.
#[allow(clippy::too_many_arguments)]
fn each_crowded(
    arm: &ArmModel<4>,
    check: &ClearanceCheck,
    geometry: &BoardGeometry,
    pieces: &PieceSet,
    heights: &[f64],
    pitch: f64,
    first: Option<usize>,
    mut crowded_at: impl FnMut(Crowded) -> ControlFlow<()>,
) {
    let table = Table::new(*geometry, &Board::empty());
    // (name, centre, whether a king may stand there)
    let places: Vec<(String, Vector2<f64>, bool)> = Square::ALL
        .into_iter()
        .map(Location::Square)
        .chain(Location::off_board())
        .map(|location| {
            (location.to_string(), table.nominal_position(location), matches!(location, Location::Square(_)))
        })
        .collect();
    let reach = NEIGHBOURHOOD * geometry.square_size;
    // What may stand on a neighbouring place: every kind's outline at once (no king in a slot).
    let envelopes = [false, true].map(|kings| {
        let roles: Vec<Role> = Role::ALL.into_iter().filter(|role| kings || *role != Role::King).collect();
        pieces.envelope_of(&roles)
    });
    let neighbour = |at: Vector2<f64>, kings: bool| StandingPiece {
        base: Vector3::new(at.x, at.y, geometry.surface_height),
        outline: envelopes[usize::from(kings)],
        facing: geometry.ranks_direction(),
    };
    let mut gripper = check.gripper;
    gripper.finger_opening = gripper.finger_opening.min(MIN_OPENING);

    // Only the arm against the neighbours: the table and the arm itself are the sweeps' (the
    // columns do not change with what stands around them).
    let rules = Rules { table: None, off_table: Vec::new(), touching: Vec::new(), self_check: false };
    let mut solids: Vec<ArmSolid> = Vec::new();
    let mut buffers = NearestBuffers::default();
    let order = first.filter(|&k| k < places.len()).into_iter().chain((0..places.len()).filter(|&k| Some(k) != first));
    'places: for place_index in order {
        let (name, centre, kings) = &places[place_index];
        let around: Vec<usize> = (0..places.len())
            .filter(|&k| {
                let d = (places[k].1 - centre).norm();
                d > 1e-9 && d < reach
            })
            .collect();
        let mut standing: Vec<Placed> =
            around.iter().map(|&k| Placed::piece(&neighbour(places[k].1, places[k].2))).collect();
        // The piece gripped or put down on the place itself, last: the fingers close on it
        // (their gap to it is the gripper's, not a clearance), everything else must clear it.
        let own = standing.len();
        let gripped = [own];
        for (_, dims) in pieces.all().into_iter().filter(|(role, _)| *kings || *role != Role::King) {
            let piece = StandingPiece {
                base: Vector3::new(centre.x, centre.y, geometry.surface_height),
                outline: dims.outline(),
                facing: geometry.ranks_direction(),
            };
            standing.truncate(own);
            standing.push(Placed::piece(&piece));
            let hand = Hand { gripper, gap: gripper.open_gap(dims.grip_width(gripper.finger_reach)), held: None };
            for &h in heights.iter().filter(|h| **h >= dims.grip_height - 1e-12) {
                let tip = Vector3::new(centre.x, centre.y, geometry.surface_height + h);
                let Ok(q) = inverse_kinematics(arm, &tip, pitch) else { continue };
                solids_into(arm, &q, &hand, &check.bodies, &mut solids);
                let found = nearest::<4>(&solids, &standing, &gripped, None, &rules, &mut buffers);
                if let Some(closest) = found.still
                    && closest.distance < check.margin
                    && let Obstacle::Piece(k) = closest.obstacle
                {
                    let neighbour = match around.get(k) {
                        Some(&index) => places[index].0.clone(),
                        None => format!("{name} itself (the piece the fingers close on)"),
                    };
                    let crowded = Crowded {
                        place: name.clone(),
                        place_index,
                        height: h,
                        pitch,
                        part: closest.part,
                        neighbour,
                        distance: closest.distance,
                    };
                    match crowded_at(crowded) {
                        ControlFlow::Break(()) => return,
                        ControlFlow::Continue(()) => continue 'places,
                    }
                }
            }
        }
    }
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
