//! `fk` and `ik`.

use crate::app::setup::file::Setup;
use crate::cli::{FkArgs, IkArgs};
use anyhow::{Result, bail};
use chessarm_chess::board::parse_square;
use chessarm_core::arm::kinematics::FrameChain;
use chessarm_core::arm::model::JointVector;
use chessarm_core::arm::task::{inverse_kinematics, tool_point};
use chessarm_core::nalgebra::Vector3;
use serde_json::json;

pub fn fk(setup: &Setup, args: &FkArgs) -> Result<()> {
    crate::warn_outside_limits(setup, "--q", &args.q);
    let q = JointVector::<4>::from(setup.convention.user(args.q));
    let chain = FrameChain::new(&setup.arm, &q);
    let task = tool_point(&setup.arm, &q);
    let frames: Vec<_> = (0..4)
        .map(|i| {
            let pose = chain.body_pose(i);
            let rotation = pose.rotation.matrix();
            json!({
                "name": format!("frame{}", i + 1),
                "origin": pose.translation.vector.as_slice(),
                "rotation": (0..3).map(|r| (0..3).map(|c| rotation[(r, c)]).collect::<Vec<_>>()).collect::<Vec<_>>(),
            })
        })
        .collect();
    let mut human = format!(
        "tip ({:.6}, {:.6}, {:.6}) m, tool pitch {:.6} rad\nframe origins (m):\n",
        task.x, task.y, task.z, task.w
    );
    for i in 0..4 {
        let o = chain.body_pose(i).translation.vector;
        human.push_str(&format!("  frame{} ({:.6}, {:.6}, {:.6})\n", i + 1, o.x, o.y, o.z));
    }
    let human = human.replace("-0.000000", "0.000000");
    crate::emit(&human, &json!({ "tip": [task.x, task.y, task.z], "pitch": task.w, "frames": frames }))?;
    Ok(())
}

pub fn ik(setup: &Setup, args: &IkArgs) -> Result<()> {
    let target = match (&args.xyz, &args.square) {
        (Some(xyz), None) => Vector3::from(*xyz),
        (None, Some(name)) => setup.board.above(parse_square(name)?, args.height),
        _ => bail!("give either --xyz or --square"),
    };
    let q = setup.convention.user(inverse_kinematics(&setup.arm, &target, args.pitch)?);
    let human = format!(
        "q = [{}] rad (elbow up, tool pitch {:.6} rad) for the tip at ({:.6}, {:.6}, {:.6}) m\n",
        q.iter().map(|v| format!("{:.6}", v + 0.0)).collect::<Vec<_>>().join(", "),
        args.pitch,
        target.x,
        target.y,
        target.z
    );
    crate::emit(&human.replace("-0.000000", "0.000000"), &json!({ "q": q.as_slice() }))?;
    Ok(())
}
