//! Helpers shared by the chess crate's tests.

use chessarm_chess::clearance::moves::ClearanceCheck;
use chessarm_core::arm::bodies::Gripper;

/// Fingers 1.5 mm thick, opened 1.5 mm beside a piece, kept 1 mm from everything else (the
/// command line's needle fingers).
pub fn slim() -> ClearanceCheck {
    let gripper = Gripper {
        finger_length: 0.02,
        finger_reach: 0.002,
        finger_thickness: 0.0015,
        finger_width: 0.005,
        finger_opening: 0.0015,
    };
    ClearanceCheck { gripper, margin: 0.001, ..ClearanceCheck::default() }
}
