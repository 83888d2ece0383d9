//! The arm's solids (`chessarm_core::arm::bodies`) where the kinematics put the joints.

use chessarm_core::arm::bodies::{JOINT_LENGTH, JOINT_RADIUS, LINK_RADIUS, Part, Solid, TOOL_RADIUS, solids_into};
use chessarm_core::arm::kinematics::FrameChain;
use chessarm_core::arm::model::JointVector;
use chessarm_core::arm::preset::report_arm;

/// At any angles the links run joint to joint and end at the tool tip, each housing is centred
/// on its joint's axis point and lies along the axis, the tool's sphere is on the tip, and a
/// buffer kept between calls is refilled, not grown.
#[test]
fn the_solids_follow_the_kinematic_chain() {
    let arm = report_arm();
    let mut solids = Vec::new();
    for q in [[0.0, 0.5, -1.0, 0.3], [1.2, 1.4, -2.1, -0.4], [-2.0, 0.2, 0.4, 1.1]] {
        let q = JointVector::from(q);
        solids_into(&arm, &q, &mut solids);
        let capacity = solids.capacity();
        solids_into(&arm, &q, &mut solids);
        assert_eq!(solids.capacity(), capacity);
        assert!(solids.len() <= 2 * 4 + 2);
        let chain = FrameChain::new(&arm, &q);
        let mut from = chain.joint_axis(0).1;
        for solid in &solids {
            match (solid.part, solid.solid) {
                (Part::Housing(j), Solid::Cylinder { a, b, radius }) => {
                    let (axis, point) = chain.joint_axis(j - 1);
                    assert!(((a + b) / 2.0 - point).norm() < 1e-12);
                    assert!(((b - a) - JOINT_LENGTH * axis).norm() < 1e-12);
                    assert_eq!(radius, JOINT_RADIUS);
                }
                (Part::Link(i), Solid::Cylinder { a, b, radius }) => {
                    // Each link starts at its joint's point and ends at the next frame's origin.
                    assert!((a - chain.joint_axis(i - 1).1).norm() < 1e-12);
                    assert!((b - chain.body_pose(i - 1).translation.vector).norm() < 1e-12);
                    // …where the previous one ended (the links form one chain from the base).
                    assert!((a - from).norm() < 1e-12);
                    from = b;
                    assert_eq!(radius, LINK_RADIUS);
                }
                (Part::Tool, Solid::Sphere { centre, radius }) => {
                    assert!((centre - chain.tip()).norm() < 1e-12);
                    assert_eq!(radius, TOOL_RADIUS);
                }
                (Part::Pedestal, Solid::Cylinder { b, .. }) => assert_eq!(b.norm(), 0.0),
                other => panic!("unexpected solid {other:?}"),
            }
        }
        // The chain of links reaches the tool tip.
        assert!((from - chain.tip()).norm() < 1e-12);
        assert_eq!(solids.iter().filter(|s| matches!(s.part, Part::Housing(_))).count(), 4);
    }
}
