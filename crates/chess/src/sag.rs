//! Which squares an arm on position servos (or steppers) holds: per square, for every piece at
//! its grip height with the tool pointing down, the static tool-tip error gravity leaves with
//! `plain` goals (the planned angles sent as they are) and each joint's torque headroom before
//! stall. Before buying servos, a maker sees which squares the arm can hold.
//!
//! A move's placement error is not a square's tip error: the gripper takes the piece with the
//! offset it sags by at the square it grips from and puts it down with the offset of the square
//! it goes to, so the piece moves by the difference of the two (a piece gripped off its centre).
//!
//! Static, at rest: each joint settles where its actuator holds the gravity torque `g(q)` of the
//! arm with the piece (a servo at `g / stiffness` from its goal, a stepper at its load angle
//! `asin(g / τ_hold) / n`), [`PositionBank::settled`]; the placement error is the horizontal
//! distance between the tool tip there and the planned one (where the piece is put down), the
//! height error the vertical one (a sagging arm grips and puts down lower). Counts, deadbands and backlash add up to a
//! count, the deadband and half the backlash per joint on top (not included here). The headroom
//! of a joint is `1 − |g_j| / τ_stall,j`: 0 at stall, negative where it cannot hold.

use crate::board::BoardGeometry;
use crate::pieces::PieceSet;
use chessarm_core::arm::dynamics::gravity_torques;
use chessarm_core::arm::kinematics::FrameChain;
use chessarm_core::arm::model::{ArmModel, JointVector};
use chessarm_core::arm::task::{held_turn, inverse_kinematics};
use chessarm_core::nalgebra::Vector3;
use chessarm_core::sim::actuator::{Actuators, PositionBank};
use shakmaty::{Role, Square};

/// One piece held over one square.
#[derive(Debug, Clone, PartialEq)]
pub struct PieceHold {
    pub role: Role,
    /// Tool-tip error at rest with the planned angles as goals, m: across the board (where the
    /// piece is put down) and up (positive) or down.
    pub error: f64,
    pub height_error: f64,
    /// Per joint: the angle it sags by (planned − held), rad; the gravity torque, N·m; the
    /// share of its stall torque left.
    pub sag: [f64; 4],
    pub load: [f64; 4],
    pub headroom: [f64; 4],
}

/// A square: every piece held there, or why the arm cannot reach it.
#[derive(Debug, Clone, PartialEq)]
pub struct SquareHold {
    pub square: Square,
    pub pieces: Result<Vec<PieceHold>, String>,
}

impl SquareHold {
    /// The lowest the tool comes below its planned height for any of the square's pieces, m
    /// (positive: a drop).
    pub fn worst_drop(&self) -> Option<f64> {
        self.pieces.as_ref().ok().map(|p| p.iter().map(|h| -h.height_error).fold(f64::NEG_INFINITY, f64::max))
    }

    /// The largest tool-tip error across the board of the square's pieces, m.
    pub fn worst_error(&self) -> Option<f64> {
        self.pieces.as_ref().ok().map(|p| p.iter().map(|h| h.error).fold(0.0, f64::max))
    }

    /// The smallest headroom of any joint holding any piece there, and the joint (1-based).
    pub fn least_headroom(&self) -> Option<(f64, usize)> {
        let pieces = self.pieces.as_ref().ok()?;
        pieces
            .iter()
            .flat_map(|h| h.headroom.iter().enumerate().map(|(j, r)| (*r, j + 1)))
            .min_by(|a, b| a.0.total_cmp(&b.0))
    }
}

/// The sag and headroom of every square of `geometry` for every piece of `pieces` (see the
/// module), the arm's joints driven by `actuators`, the tool at `pitch` (rad; the game's,
/// [`crate::reach::check_table`]).
pub fn sag_map(
    arm: &ArmModel<4>,
    actuators: &Actuators<4>,
    geometry: &BoardGeometry,
    pieces: &PieceSet,
    pitch: f64,
) -> Vec<SquareHold> {
    let turn = held_turn(arm, pitch);
    let stall = actuators.torque_limits();
    Square::ALL
        .into_iter()
        .map(|square| {
            let centre = geometry.square_center(square);
            let held = pieces
                .all()
                .into_iter()
                .map(|(role, d)| {
                    let point = Vector3::new(centre.x, centre.y, geometry.surface_height + d.grip_height);
                    let q = inverse_kinematics(arm, &point, pitch).map_err(|e| {
                        format!("{square} ({} at its grip height): {e}", crate::pieces::role_name(role))
                    })?;
                    let loaded =
                        arm.with_payload(Some(pieces.payload(role).turned(turn))).map_err(|e| e.to_string())?;
                    let settled = PositionBank::settled(actuators, &loaded, &q);
                    let planned = FrameChain::new(&loaded, &q).tip();
                    let actual = FrameChain::new(&loaded, &settled).tip();
                    let load = gravity_torques(&loaded, &settled);
                    let sag: JointVector<4> = q - settled;
                    Ok(PieceHold {
                        role,
                        error: (actual - planned).xy().norm(),
                        height_error: actual.z - planned.z,
                        sag: sag.into(),
                        load: load.into(),
                        headroom: std::array::from_fn(|j| 1.0 - load[j].abs() / stall[j]),
                    })
                })
                .collect::<Result<Vec<_>, String>>();
            SquareHold { square, pieces: held }
        })
        .collect()
}
