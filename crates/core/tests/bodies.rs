//! The arm's solids (`chessarm_core::arm::bodies`) where the kinematics put the joints.

use chessarm_core::arm::bodies::{
    Bodies, Gripper, Hand, Held, JOINT_LENGTH, JOINT_RADIUS, LINK_RADIUS, Part, Solid, solids_into,
};
use chessarm_core::arm::kinematics::FrameChain;
use chessarm_core::arm::model::JointVector;
use chessarm_core::arm::outline::Outline;
use chessarm_core::arm::preset::report_arm;
use chessarm_core::nalgebra::Vector3;

/// At any angles the links run joint to joint and the last ends at the palm on the tool's
/// approach axis, each housing is centred on its joint's axis point and lies along the axis,
/// the fingers' inner faces are half the gap either side of the tip along the last joint's
/// axis and reach past the tip, the held piece hangs from the tip by its grip height, and a
/// buffer kept between calls is refilled, not grown.
#[test]
fn the_solids_follow_the_kinematic_chain() {
    let arm = report_arm();
    let gripper = Gripper::default();
    let held = Held { outline: Outline::cylinder(0.0145, 0.05), grip_height: 0.04, turn: 0.0 };
    let hand = Hand { gripper, gap: 0.041, held: Some(held) };
    let mut solids = Vec::new();
    for q in [[0.0, 0.5, -1.0, 0.3], [1.2, 1.4, -2.1, -0.4], [-2.0, 0.2, 0.4, 1.1]] {
        let q = JointVector::from(q);
        solids_into(&arm, &q, &hand, &Bodies::Drawn, &mut solids);
        let capacity = solids.capacity();
        solids_into(&arm, &q, &hand, &Bodies::Drawn, &mut solids);
        assert_eq!(solids.capacity(), capacity);
        assert!(solids.len() <= Bodies::Drawn.most_solids(4));
        let chain = FrameChain::new(&arm, &q);
        let tip = chain.tip();
        let approach = (tip - chain.joint_axis(3).1).normalize();
        let closing = chain.joint_axis(3).0;
        let palm = tip - gripper.palm_depth() * approach;
        let mut from = chain.joint_axis(0).1;
        let mut fingers = 0;
        for solid in &solids {
            match (solid.part, solid.solid.clone()) {
                (Part::Housing(j), Solid::Cylinder { a, b, radius }) => {
                    let (axis, point) = chain.joint_axis(j - 1);
                    assert!(((a + b) / 2.0 - point).norm() < 1e-12);
                    assert!(((b - a) - JOINT_LENGTH * axis).norm() < 1e-12);
                    assert_eq!(radius, JOINT_RADIUS);
                }
                (Part::Link(i), Solid::Cylinder { a, b, radius }) => {
                    // Each link starts at its joint's point and ends at the next frame's origin
                    // (the last at the palm)…
                    assert!((a - chain.joint_axis(i - 1).1).norm() < 1e-12);
                    let end = if i == 4 { palm } else { chain.body_pose(i - 1).translation.vector };
                    assert!((b - end).norm() < 1e-12);
                    // …where the previous one ended (the links form one chain from the base).
                    assert!((a - from).norm() < 1e-12);
                    from = b;
                    assert_eq!(radius, LINK_RADIUS);
                }
                (Part::Finger(k), Solid::Cuboid { centre, axes, half }) => {
                    fingers += 1;
                    let side = if k == 1 { -1.0 } else { 1.0 };
                    // The inner face: half the gap from the tool's axis along the closing axis.
                    let inner = centre - side * half.x * axes.column(0);
                    let r = inner - tip;
                    assert!((r.dot(&closing) - side * 0.5 * hand.gap).abs() < 1e-12, "{k}: {r}");
                    // The end of the finger: `finger_reach` past the tip, its root at the palm.
                    let along = (centre - tip).dot(&approach);
                    assert!((along + half.y - gripper.finger_reach).abs() < 1e-12);
                    assert!((along - half.y + gripper.palm_depth()).abs() < 1e-12);
                    assert!((axes.transpose() * axes - chessarm_core::nalgebra::Matrix3::identity()).norm() < 1e-12);
                    assert!((axes.determinant() - 1.0).abs() < 1e-12);
                }
                (Part::Held, Solid::Cylinder { a, b, radius }) => {
                    assert!((a - (tip + held.grip_height * approach)).norm() < 1e-12);
                    assert!(((a - b).norm() - held.outline.height()).abs() < 1e-12);
                    assert_eq!(radius, held.outline.widest());
                }
                (Part::Pedestal, Solid::Cylinder { b, .. }) => assert_eq!(b, arm.base()),
                other => panic!("unexpected solid {other:?}"),
            }
        }
        // The chain of links reaches the palm.
        assert!((from - palm).norm() < 1e-12);
        assert_eq!(fingers, 2);
        assert_eq!(solids.iter().filter(|s| matches!(s.part, Part::Housing(_))).count(), 4);
    }
}

/// The lowest point of each kind of solid, against points on its surface: a tilted cylinder's
/// rim, a sphere's bottom, a box's lowest corner.
#[test]
fn the_lowest_points_are_the_closed_forms() {
    let a = Vector3::new(0.0, 0.0, 0.3);
    let b = Vector3::new(0.3, 0.0, 0.7);
    // The axis rises 4 in 5 (u_z = 0.8): the rim's lowest point is r √(1 − 0.64) = 0.6 r below
    // the lower end's centre.
    let cylinder = Solid::Cylinder { a, b, radius: 0.05 };
    assert!((cylinder.lowest() - (0.3 - 0.05 * 0.6)).abs() < 1e-12);
    let sphere = Solid::Sphere { centre: a, radius: 0.05 };
    assert!((sphere.lowest() - 0.25).abs() < 1e-12);
    // A cube of half size 0.1 turned 45° about x: its lowest edge is 0.1 √2 below its centre.
    let turn = chessarm_core::nalgebra::Rotation3::from_axis_angle(&Vector3::x_axis(), std::f64::consts::FRAC_PI_4);
    let cube = Solid::Cuboid { centre: a, axes: *turn.matrix(), half: Vector3::repeat(0.1) };
    assert!((cube.lowest() - (0.3 - 0.1 * 2f64.sqrt())).abs() < 1e-12);
}

/// The gripper's value for a gap: each finger's inner face at least half the gap from the
/// tool's axis (the nearer finger decides), within the joint's range; none without sliding
/// fingers.
#[test]
fn the_finger_value_opens_every_finger_to_half_the_gap_within_the_range() {
    use chessarm_core::arm::bodies::{BodyShape, Mount, Shape, Slide, finger_gaps, finger_section, finger_value};
    use chessarm_core::arm::kinematics::Pose;
    let finger = |finger: usize, face: f64, rate: f64| BodyShape {
        body: 4,
        pose: Pose::identity(),
        shape: Shape::Sphere { radius: 0.002 },
        mount: Mount::Finger(Slide {
            finger,
            travel: Vector3::y() * rate,
            at_zero: Vector3::zeros(),
            face,
            rate,
            range: [-0.002, 0.02],
            thickness: 0.004,
            half_width: 0.003 * finger as f64,
        }),
    };
    // Faces 9 mm and 8 mm off the axis at 0, opening 1 mm and 2 mm per mm of travel.
    let shapes = [finger(1, 0.009, 1.0), finger(2, 0.008, 2.0)];
    // A gap of 30 mm: the first needs 6 mm of travel, the second 3.5 mm.
    assert!((finger_value(&shapes, 0.03).unwrap() - 0.006).abs() < 1e-15);
    // Beyond the range either way: its ends.
    assert_eq!(finger_value(&shapes, 0.2), Some(0.02));
    assert_eq!(finger_value(&shapes, 0.0), Some(-0.002));
    let fixed = BodyShape { mount: Mount::Fixed, ..shapes[0].clone() };
    assert_eq!(finger_value(std::slice::from_ref(&fixed), 0.03), None);
    // The gaps they reach: at −2 mm the second's face is 4 mm off the axis (the nearer), at
    // 20 mm the first's is 29 mm.
    let [closes, opens] = finger_gaps(&shapes).unwrap();
    assert!((closes - 0.008).abs() < 1e-15 && (opens - 0.058).abs() < 1e-15, "{closes} {opens}");
    assert_eq!(finger_section(&shapes), Some((0.004, 0.006)));
    assert_eq!(finger_gaps(std::slice::from_ref(&fixed)), None);
    assert_eq!(finger_section(&[fixed]), None);
}
