//! The board an arm serves: with `fit`, the largest board (squares, centre, yaw) the arm's
//! reach allows, its pieces scaled with the squares; the check that every square, slot and
//! traverse is served, each square's radial margin, the squares the fingers need, and with
//! servos or steppers how well they hold each square (the sag map).

use crate::app::setup::file::Setup;
use anyhow::{Result, anyhow};
use chessarm_chess::board::BoardGeometry;
use chessarm_chess::reach::{
    ReachError, Unplaced, check_table, fit_board, place_board, place_failures, square_margins,
};
use chessarm_chess::sag::{SquareHold, sag_map};
use chessarm_chess::shakmaty::Square;

/// What the board study finds.
#[derive(Debug, Clone)]
pub struct BoardStudy {
    /// The setup with the fitted board and pieces (the setup's own without `fit`).
    pub fitted: Setup,
    /// With `fit`: how many board poses the search tried, and how long it took, s.
    pub tried: Option<usize>,
    pub seconds: f64,
    /// The tool's pitch (rad) nearest straight down at which every square, slot and traverse
    /// is served, or why none is.
    pub check: Result<f64, ReachError>,
    /// Each square's radial margin, m, or why it is not served.
    pub margins: Vec<(Square, Result<f64, String>)>,
    /// The smallest of the margins, m.
    pub smallest: f64,
    /// With servos or steppers: how they hold each square.
    pub sag: Option<Vec<SquareHold>>,
    /// The smallest square on which the fingers clear the neighbours of the piece they open
    /// around, m.
    pub fingers_need: f64,
    /// With squares of a given size that no pose serves: the nearest pose (the study's board)
    /// and what fails there.
    pub unplaced: Option<Box<Unplaced>>,
    /// On a board that is not served: every place that fails and why (the check names the
    /// first), with the tool straight down, or the placement's nearest pose's.
    pub failures: Vec<(String, String)>,
}

/// What `board` does with the setup's board.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum BoardFit {
    /// Checks the setup's board as it is.
    Check,
    /// Finds the largest board the arm serves.
    Largest,
    /// Places a board of squares of this size (m) where the arm serves it.
    Place(f64),
}

/// Checks the setup's board, fits the largest one or places one of given squares (`fit`);
/// `sag` asks for the sag map (refused with torque motors; with servos or steppers it is
/// always made). A board of given squares that no pose serves is not an error here: the
/// study holds the nearest pose and its failures ([`BoardStudy::unplaced`]).
///
/// # Errors
///
/// No board fits, the fitted squares are smaller than the fingers need, a sag map asked for
/// torque motors.
pub fn board_study(setup: &Setup, fit: BoardFit, sag: bool) -> Result<BoardStudy> {
    let limits = setup.motion;
    let started = std::time::Instant::now();
    let mut fitted = setup.clone();
    let mut tried = None;
    let mut unplaced = None;
    let needed = fingers_need(setup, setup.board.square_size)?;
    // What the fingers need, said of the file's fingers where it has them.
    let fingers = || match file_fingers(setup) {
        Some(file) => format!(
            "the file's fingers ({:.1} mm thick and {:.1} mm wide across the tool tip, opened {:.1} mm beside a \
             piece) need {:.1} mm to open around a piece beside its neighbours with {:.1} mm to spare ([motion] \
             arm_clearance)",
            file.gripper.finger_thickness * 1e3,
            file.gripper.finger_width * 1e3,
            file.gripper.finger_opening * 1e3,
            needed * 1e3,
            setup.clearance.margin * 1e3
        ),
        None => format!(
            "the fingers ([gripper]: {:.1} mm thick, {:.1} mm wide, opened {:.1} mm beside a piece) need {:.1} mm to \
             open around a piece beside its neighbours with {:.1} mm to spare ([motion] arm_clearance): slimmer \
             fingers, a smaller opening or a longer arm",
            setup.clearance.gripper.finger_thickness * 1e3,
            setup.clearance.gripper.finger_width * 1e3,
            setup.clearance.gripper.finger_opening * 1e3,
            needed * 1e3,
            setup.clearance.margin * 1e3
        ),
    };
    let table = (setup.board.surface_height, setup.board.base_clearance);
    match fit {
        BoardFit::Check => {}
        BoardFit::Largest => {
            let fit =
                fit_board(&setup.arm, &setup.pieces, setup.board.square_size, &limits, table, Some(&setup.clearance));
            // A fit refused for a finger beside a neighbour says what the fingers need.
            let fit = fit.map_err(|e| match &e {
                ReachError::NoFit { why, .. } if why.contains("finger") => anyhow!("{e}; {}", fingers()),
                _ => anyhow!("{e}"),
            })?;
            // The fingers open around a piece beside its neighbours: squares below what they
            // need would have the planner refuse moves.
            if fit.board.square_size < needed {
                anyhow::bail!(
                    "the arm serves squares of at most {:.1} mm, and {}",
                    fit.board.square_size * 1e3,
                    fingers()
                );
            }
            // The squares' turn on the table is the setup's (the fit serves either alike).
            fitted.board = BoardGeometry { squares_turned: setup.board.squares_turned, ..fit.board };
            fitted.pieces = fit.pieces;
            tried = Some(fit.tried);
        }
        BoardFit::Place(size) => {
            if size < needed {
                anyhow::bail!("--square-size: squares of {:.1} mm are too small: {}", size * 1e3, fingers());
            }
            let placed = place_board(
                &setup.arm,
                &setup.pieces,
                setup.board.square_size,
                size,
                &limits,
                table,
                Some(&setup.clearance),
            );
            let (board, pieces, poses) = match placed {
                Ok(fit) => (fit.board, fit.pieces, fit.tried),
                Err(nearest) => {
                    let found = (nearest.board, nearest.pieces, nearest.tried);
                    unplaced = Some(nearest);
                    found
                }
            };
            fitted.board = BoardGeometry { squares_turned: setup.board.squares_turned, ..board };
            fitted.pieces = pieces;
            tried = Some(poses);
        }
    }
    let seconds = started.elapsed().as_secs_f64();
    let check = match &unplaced {
        // Its failures are known; the full check would only find the first again.
        Some(nearest) => Err(ReachError::Unplaced(nearest.clone())),
        None => check_table(&setup.arm, &fitted.board, &fitted.pieces, &limits, Some(&setup.clearance)),
    };
    // The maps at the pitch the game would use (straight down when the board is not served, the
    // nearest pose's own pitch when none of given squares is).
    let pitch = match (&check, &unplaced) {
        (Ok(pitch), _) => *pitch,
        (Err(_), Some(nearest)) => nearest.pitch,
        (Err(_), None) => limits.pitch,
    };
    let limits = chessarm_chess::tasks::MotionLimits { pitch, ..limits };
    let mut margins = square_margins(&setup.arm, &fitted.board, &fitted.pieces, &limits);
    // Every place that fails on a board that is not served (the check names the first), at the
    // pitch the maps are drawn at: the placement's nearest pose has its own.
    let failures = match (&check, &unplaced) {
        (_, Some(nearest)) => nearest.failures.clone(),
        (Ok(_), None) => Vec::new(),
        (Err(_), None) => {
            place_failures(&setup.arm, &fitted.board, &fitted.pieces, &limits, limits.pitch, Some(&setup.clearance))
        }
    };
    // A square found crowded is not served either, whatever its reach.
    for (square, margin) in &mut margins {
        if let Some((_, why)) = failures.iter().find(|(place, _)| *place == square.to_string()) {
            *margin = Err(why.clone());
        }
    }
    let sag = match (setup.actuators.take_positions(), sag) {
        (true, _) => Some(sag_map(&setup.arm, &setup.actuators, &fitted.board, &fitted.pieces, limits.pitch)),
        (false, true) => {
            anyhow::bail!("--sag-map is for servos or steppers; the joints have torque motors (give --actuator NAME)")
        }
        (false, false) => None,
    };
    let smallest = margins.iter().filter_map(|(_, m)| m.as_ref().ok()).copied().fold(f64::INFINITY, f64::min);
    Ok(BoardStudy { fitted, tried, seconds, check, margins, smallest, sag, fingers_need: needed, unplaced, failures })
}

/// The smallest square (m) on which the setup's fingers clear the neighbours of the piece they
/// open around, the setup's pieces (on squares of `square` m) scaled with the squares: the
/// file's fingers where they slide on prismatic joints (their section across the tool tip as
/// boxes as thick as it and as wide as its farther side, [`file_fingers`]), else `[gripper]`'s.
fn fingers_need(setup: &Setup, square: f64) -> Result<f64> {
    let gripper = file_fingers(setup).map_or(setup.clearance.gripper, |f| f.gripper);
    chessarm_chess::clearance::moves::square_for_fingers(&setup.pieces, square, &gripper, setup.clearance.margin)
        .ok_or_else(|| anyhow!("the fingers do not clear a piece's neighbours even on squares of 20 cm"))
}

/// The file's fingers on prismatic joints, as the board's check sees them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FileFingers {
    /// `[gripper]` with the fingers' thickness and width across the tool tip (their section
    /// there, its width twice its farther side from the closing line), m.
    pub gripper: chessarm_core::arm::bodies::Gripper,
    /// The narrowest and widest gap they reach within their joint's range, m.
    pub gaps: [f64; 2],
}

/// The setup's file fingers (`None` without: `[gripper]`'s stand in).
pub fn file_fingers(setup: &Setup) -> Option<FileFingers> {
    let chessarm_core::arm::bodies::Bodies::Described(shapes) = &setup.clearance.bodies else { return None };
    let gaps = chessarm_core::arm::bodies::finger_gaps(shapes)?;
    let (thickness, half_width) = chessarm_core::arm::bodies::finger_section(shapes)?;
    let gripper = chessarm_core::arm::bodies::Gripper {
        finger_thickness: thickness,
        finger_width: 2.0 * half_width,
        ..setup.clearance.gripper
    };
    Some(FileFingers { gripper, gaps })
}
