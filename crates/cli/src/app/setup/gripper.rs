//! The file's gripper against the setup's pieces: a URDF's fingers on prismatic joints must
//! close on every piece and open around it, checked before any game, plan or campaign.

use crate::app::setup::file::Setup;
use anyhow::{Result, bail};

/// With the file's fingers on prismatic joints: that they close on every piece and open around
/// it by `[gripper] finger_opening` a side within their joint's range (a piece they do not
/// close on would not be held, one they do not open around would be struck).
///
/// # Errors
///
/// The first piece that is narrower than the fingers close or wider than they open, with both.
pub fn check_file_fingers(setup: &Setup) -> Result<()> {
    let chessarm_core::arm::bodies::Bodies::Described(shapes) = &setup.clearance.bodies else { return Ok(()) };
    let Some([closes, opens]) = chessarm_core::arm::bodies::finger_gaps(shapes) else { return Ok(()) };
    let opening = setup.clearance.gripper.finger_opening;
    let mm = |m: f64| format!("{:.1} mm", m * 1e3);
    for (role, d) in setup.pieces.all() {
        // The fingers close on the piece's widest part above their ends.
        let (name, width) =
            (chessarm_chess::pieces::role_name(role), d.grip_width(setup.clearance.gripper.finger_reach));
        // (A micrometre's slack for the rounding of the faces' arithmetic.)
        if width < closes - 1e-6 {
            bail!(
                "the file's fingers close no narrower than {} (their joint at its limit): a {name} {} across would not \
                 be held where it is gripped ([pieces.{name}] base_diameter or grip_height, or a gripper that closes further)",
                mm(closes),
                mm(width)
            );
        }
        if width + 2.0 * opening > opens + 1e-6 {
            bail!(
                "the file's fingers open no wider than {} (their joint at its limit): a {name} {} across needs {} with \
                 [gripper] finger_opening {} a side",
                mm(opens),
                mm(width),
                mm(width + 2.0 * opening),
                mm(opening)
            );
        }
    }
    Ok(())
}
