//! The structured dynamics of the yaw–pitch family against the general RNEA/CRBA (the oracle):
//! the mass matrix, bias, gravity, Coriolis, inverse and forward dynamics and the tool tip at
//! random states of the report's arm, an asymmetric arm (offsets, reversed and downward frames,
//! a twisted tool frame, off-plane centres of mass, products of inertia, motors, rotors,
//! friction, a payload) and random arms of the family; refused for arms outside it.

#![allow(clippy::unwrap_used)] // test helpers may panic: a panic is a failed test

use chessarm_core::arm::dynamics::{
    DynamicsTerms, bias_torques, coriolis_torques, forward_dynamics, gravity_torques, inverse_dynamics, mass_matrix,
};
use chessarm_core::arm::kinematics::FrameChain;
use chessarm_core::arm::link::{DhParameters, Friction, Inertial};
use chessarm_core::arm::model::{ArmModel, JointVector, Payload};
use chessarm_core::arm::preset::report_arm;
use chessarm_core::arm::yaw_pitch::{Angles, Configuration, YawPitch};
use chessarm_core::lanes::Lanes;
use chessarm_core::nalgebra::{Matrix3, Rotation3, Vector3};
use chessarm_core::sim::{Integrator, Plant};
use proptest::prelude::*;

/// Agreement of the two formulations: both are a few hundred flops on O(1) numbers, so their
/// rounding differs by ~1e-15 relative; 1e-12 (the bound) relative to the quantity's
/// scale is far above that and far below any modelling mistake (a wrong sign or a missing
/// product of inertia changes torques by 1e-4 N·m and more).
const AGREE: f64 = 1e-12;

fn close(fast: &[f64], general: &[f64], what: &str) -> Result<(), TestCaseError> {
    let scale = general.iter().fold(1.0f64, |m, v| m.max(v.abs()));
    let worst = fast.iter().zip(general).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
    prop_assert!(worst <= AGREE * scale, "{what}: fast {fast:?} vs general {general:?}: {worst:e}");
    Ok(())
}

/// A box-shaped body's inertia about its centre, turned by roll–pitch–yaw `turn` (always physical).
fn tensor(mass: f64, size: [f64; 3], turn: [f64; 3]) -> Matrix3<f64> {
    let [x, y, z] = size.map(|s| s * s);
    let principal = Matrix3::from_diagonal(&Vector3::new(y + z, x + z, x + y)) * (mass / 12.0);
    let rotation = Rotation3::from_euler_angles(turn[0], turn[1], turn[2]).into_inner();
    rotation * principal * rotation.transpose()
}

/// An arm of the family with everything asymmetric that the family allows: `seed` (24 numbers
/// in [-1, 1]) sets offsets, twists' choices, centres of mass and tensors.
fn family_arm(seed: &[f64; 24], down: bool, reversed: [bool; 2], tool_twist: f64) -> ArmModel<4> {
    let mut links = *report_arm().links();
    let half_pi = std::f64::consts::FRAC_PI_2;
    let pitch_twist = |reverse: bool| if reverse { std::f64::consts::PI } else { 0.0 };
    let dh = [
        DhParameters {
            a: 0.03 * seed[0].abs(),
            alpha: if down { -half_pi } else { half_pi },
            d: 0.1,
            theta_offset: seed[1],
        },
        DhParameters { a: 0.3, alpha: pitch_twist(reversed[0]), d: 0.04 * seed[2], theta_offset: seed[3] },
        DhParameters { a: 0.28, alpha: pitch_twist(reversed[1]), d: 0.04 * seed[4], theta_offset: seed[5] },
        DhParameters { a: 0.1, alpha: tool_twist, d: 0.04 * seed[6], theta_offset: seed[7] },
    ];
    for (j, link) in links.iter_mut().enumerate() {
        let s = |k: usize| seed[(8 + 4 * j + k) % 24];
        link.dh = dh[j];
        let mass = 0.3 + 0.2 * s(0).abs();
        link.inertial = Inertial {
            mass,
            com: Vector3::new(-0.1 + 0.05 * s(1), 0.02 * s(2), 0.03 * s(3)),
            inertia: tensor(mass, [0.05 + 0.02 * s(0), 0.04, 0.03 + 0.01 * s(1)], [s(1), s(2), s(3)]),
        };
        link.motor_mass = 0.1 * s(2).abs();
        link.rotor_inertia = 1e-3 * s(3).abs();
        link.friction = Friction { viscous: 0.05 * s(1).abs(), coulomb: 0.02 * s(0).abs() };
    }
    ArmModel::new(links, Vector3::new(0.0, 0.0, -9.81)).unwrap()
}

fn asymmetric_arm() -> ArmModel<4> {
    let seed: [f64; 24] = std::array::from_fn(|k| ((k as f64 * 0.7).sin() * 1.3).clamp(-1.0, 1.0));
    let payload = Payload {
        inertial: Inertial {
            mass: 0.05,
            com: Vector3::new(0.02, 0.01, -0.015),
            inertia: tensor(0.05, [0.02, 0.02, 0.04], [0.2, -0.1, 0.4]),
        },
    };
    family_arm(&seed, true, [true, false], 0.7).with_payload(Some(payload)).unwrap()
}

/// The fast path (the model as built) against the general path (the same model with it off)
/// at one state.
fn agree_at(model: &ArmModel<4>, q: [f64; 4], qd: [f64; 4], qdd: [f64; 4]) -> Result<(), TestCaseError> {
    prop_assert!(model.yaw_pitch().is_some(), "the arm must take the structured path");
    let general = model.with_general_dynamics();
    prop_assert!(general.yaw_pitch().is_none());
    let (q, qd, qdd) = (JointVector::from(q), JointVector::from(qd), JointVector::from(qdd));
    close(mass_matrix(model, &q).as_slice(), mass_matrix(&general, &q).as_slice(), "M")?;
    close(bias_torques(model, &q, &qd).as_slice(), bias_torques(&general, &q, &qd).as_slice(), "C q̇ + g")?;
    close(gravity_torques(model, &q).as_slice(), gravity_torques(&general, &q).as_slice(), "g")?;
    close(coriolis_torques(model, &q, &qd).as_slice(), coriolis_torques(&general, &q, &qd).as_slice(), "C q̇")?;
    let tau = inverse_dynamics(model, &q, &qd, &qdd);
    close(tau.as_slice(), inverse_dynamics(&general, &q, &qd, &qdd).as_slice(), "inverse dynamics")?;
    let fast_terms = DynamicsTerms::new(model, &q, &qd);
    let general_terms = DynamicsTerms::new(&general, &q, &qd);
    close(fast_terms.mass_matrix.as_slice(), general_terms.mass_matrix.as_slice(), "terms' M")?;
    close(fast_terms.bias.as_slice(), general_terms.bias.as_slice(), "terms' bias")?;
    let fast_acceleration = forward_dynamics(model, &q, &qd, &tau).unwrap();
    let general_acceleration = forward_dynamics(&general, &q, &qd, &tau).unwrap();
    close(fast_acceleration.as_slice(), general_acceleration.as_slice(), "forward dynamics")?;
    // Forward ∘ inverse = identity on the fast path alone (friction is the plant's, not RNEA's).
    if !model.has_friction() {
        close(fast_acceleration.as_slice(), qdd.as_slice(), "forward(inverse(q̈))")?;
    }
    // One plant step each way, and its tool tip.
    let state = chessarm_core::control::JointState { q, qd };
    let (mut fast_plant, mut general_plant) = (Plant::new(*model), Plant::new(general));
    let tip = fast_plant.evaluate(&state).unwrap().tip();
    close(tip.as_slice(), FrameChain::new(&general, &q).tip().as_slice(), "tip")?;
    // At these rates a 1 ms step moves the stages' angles by series; at 60 times them (up to
    // 240 rad/s) by more than the series' 0.05 rad, so their sines are computed afresh (review:
    // a mutant there passed every test). A longer step instead (0.1 s) is not a test of the
    // dynamics: its stages reach thousands of rad/s on light random arms, and the step
    // amplifies the formulations' 1e-15 rounding past 1e-12.
    for scale in [1.0, 60.0] {
        let state = chessarm_core::control::JointState { q, qd: qd * scale };
        for integrator in Integrator::ALL {
            let a = fast_plant.step(&state, &tau, 1e-3, integrator).unwrap();
            let b = general_plant.step(&state, &tau, 1e-3, integrator).unwrap();
            close(a.q.as_slice(), b.q.as_slice(), integrator.name())?;
            close(a.qd.as_slice(), b.qd.as_slice(), integrator.name())?;
        }
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn the_report_arm_and_an_asymmetric_arm_agree_with_the_general_algorithms(
        q in prop::array::uniform4(-3.0f64..3.0),
        qd in prop::array::uniform4(-4.0f64..4.0),
        qdd in prop::array::uniform4(-20.0f64..20.0),
    ) {
        agree_at(&report_arm(), q, qd, qdd)?;
        let loaded = report_arm().with_payload(Some(Payload::upright_cylinder(0.2, 0.05, 0.012, 0.03))).unwrap();
        agree_at(&loaded, q, qd, qdd)?;
        agree_at(&asymmetric_arm(), q, qd, qdd)?;
    }

    #[test]
    fn random_arms_of_the_family_agree_with_the_general_algorithms(
        seed in prop::array::uniform24(-1.0f64..1.0),
        down in any::<bool>(),
        reversed in prop::array::uniform2(any::<bool>()),
        tool_twist in -3.2f64..3.2,
        q in prop::array::uniform4(-3.0f64..3.0),
        qd in prop::array::uniform4(-4.0f64..4.0),
        qdd in prop::array::uniform4(-20.0f64..20.0),
    ) {
        agree_at(&family_arm(&seed, down, reversed, tool_twist), q, qd, qdd)?;
    }
}

/// `YawPitch::lane` gives back, entry for entry, each arm `gather` put in its lane (friction
/// or none), and gathering those lanes again gives the same batch.
#[test]
fn a_lane_of_gathered_constants_is_its_arm() {
    let seeds: [[f64; 24]; 2] = [
        std::array::from_fn(|k| ((k as f64 * 1.9).cos() * 1.1).clamp(-1.0, 1.0)),
        std::array::from_fn(|k| ((k as f64 * 0.3 + 2.0).sin() * 1.4).clamp(-1.0, 1.0)),
    ];
    let arms = [
        report_arm(),
        asymmetric_arm(),
        family_arm(&seeds[0], false, [false, true], -1.2),
        family_arm(&seeds[1], true, [true, true], 2.5),
    ];
    let constants: [YawPitch<f64>; 4] = std::array::from_fn(|i| *arms[i].yaw_pitch().unwrap());
    assert!(!constants[0].has_friction && constants[1].has_friction, "both kinds of lane are covered");
    let batch = YawPitch::<Lanes<4>>::gather(std::array::from_fn(|i| &constants[i]));
    for (i, arm) in constants.iter().enumerate() {
        let lane = batch.lane(i);
        assert!(lane == *arm, "lane {i}: {lane:?}\n{arm:?}");
    }
    let lanes: [YawPitch<f64>; 4] = std::array::from_fn(|i| batch.lane(i));
    assert!(YawPitch::<Lanes<4>>::gather(std::array::from_fn(|i| &lanes[i])) == batch);
}

/// A configuration refilled with another model equals one built for that model (its entries
/// that are the model's constants are not kept, so nothing of the first model is left to see),
/// and gives the same mass matrix, bias and tip bits.
#[test]
fn a_configuration_set_with_another_model_is_that_models_configuration() {
    let (a, b) = (report_arm(), asymmetric_arm());
    let (fast_a, fast_b) = (*a.yaw_pitch().unwrap(), *b.yaw_pitch().unwrap());
    let q = [0.3, -0.7, 1.1, -0.4];
    let qd = [0.5, -1.0, 0.25, 2.0];
    let mut reused = Configuration::new(&fast_a, Angles::new(&fast_a, &q));
    reused.set(&fast_b, Angles::new(&fast_b, &q));
    let fresh = Configuration::new(&fast_b, Angles::new(&fast_b, &q));
    assert!(reused == fresh, "{reused:?}\n{fresh:?}");
    assert_eq!(format!("{reused:?}"), format!("{fresh:?}"));
    let bits = |c: &Configuration<f64>| {
        let mut all: Vec<u64> = c.mass_matrix.iter().flatten().map(|v| v.to_bits()).collect();
        all.extend(c.bias(&fast_b, &qd).iter().map(|v| v.to_bits()));
        all.extend(c.tip_in_base(&fast_b.base).iter().map(|v| v.to_bits()));
        all
    };
    assert_eq!(bits(&reused), bits(&fresh));
}

/// Why `model` is outside the family, as the yaw–pitch constants of its links, bodies, gravity
/// and base say it.
fn why_not<const N: usize>(model: &ArmModel<N>) -> String {
    let bodies = std::array::from_fn(|j| *model.body(j));
    YawPitch::new(model.links(), &bodies, model.gravity(), model.base()).unwrap_err().to_string()
}

#[test]
fn arms_outside_the_family_take_the_general_path_and_say_why() {
    let mut links = *report_arm().links();
    links[1].dh.alpha = 0.3;
    let tilted = ArmModel::new(links, Vector3::new(0.0, 0.0, -9.8)).unwrap();
    assert!(tilted.yaw_pitch().is_none());
    let reason = why_not(&tilted);
    assert!(reason.contains("link 2") && reason.contains("alpha = 0.3 rad"), "{reason}");

    let mut links = *report_arm().links();
    links[0].dh.alpha = 1.2;
    let reason = why_not(&ArmModel::new(links, Vector3::new(0.0, 0.0, -9.8)).unwrap());
    assert!(reason.contains("link 1 needs alpha = ±90°"), "{reason}");

    let sideways = ArmModel::new(*report_arm().links(), Vector3::new(0.5, 0.0, -9.8)).unwrap();
    assert!(sideways.yaw_pitch().is_none());
    assert!(why_not(&sideways).contains("gravity (0.5, 0, -9.8)"));

    let three =
        ArmModel::<3>::new(std::array::from_fn(|j| report_arm().links()[j]), Vector3::new(0.0, 0.0, -9.8)).unwrap();
    assert!(three.yaw_pitch().is_none());
    assert!(why_not(&three).contains("3 joints"));

    // The report's arm is in; switched off it stays off through a payload and new links.
    let report = report_arm();
    assert!(report.yaw_pitch().is_some());
    let general = report.with_general_dynamics();
    assert!(general.with_payload(Some(Payload::point_mass(0.1))).unwrap().yaw_pitch().is_none());
    assert!(general.with_links(*report.links()).unwrap().yaw_pitch().is_none());
    assert!(report.with_payload(Some(Payload::point_mass(0.1))).unwrap().yaw_pitch().is_some());
}

#[test]
fn a_twist_within_rounding_of_90_degrees_is_in_the_family_and_a_visible_one_is_not() {
    let mut links = *report_arm().links();
    links[0].dh.alpha = std::f64::consts::FRAC_PI_2 + 1e-14;
    assert!(ArmModel::new(links, Vector3::new(0.0, 0.0, -9.8)).unwrap().yaw_pitch().is_some());
    links[0].dh.alpha = std::f64::consts::FRAC_PI_2 + 1e-9;
    assert!(ArmModel::new(links, Vector3::new(0.0, 0.0, -9.8)).unwrap().yaw_pitch().is_none());
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// The plant's structured kernels run compiled for the best SIMD level the CPU has: every
    /// level gives the same bits (plain IEEE operations, no fused multiply–add), for the
    /// start's terms and a step of every integrator, on the asymmetric arm (friction, offsets,
    /// products of inertia) and random arms of the family.
    #[test]
    fn the_plant_steps_to_the_same_bits_at_every_simd_level(
        seed in prop::array::uniform24(-1.0f64..1.0),
        q in prop::array::uniform4(-3.0f64..3.0),
        qd in prop::array::uniform4(-4.0f64..4.0),
        tau in prop::array::uniform4(-5.0f64..5.0),
    ) {
        use chessarm_core::sim::batch::SimdLevel;
        let bits = |v: &JointVector<4>| v.map(f64::to_bits);
        let state = chessarm_core::control::JointState { q: JointVector::from(q), qd: JointVector::from(qd) };
        let tau = JointVector::from(tau);
        static SAY_SKIPPED: std::sync::Once = std::sync::Once::new();
        SAY_SKIPPED.call_once(|| {
            for level in SimdLevel::ALL.into_iter().filter(|level| !level.available()) {
                // Past the harness's capture, so that it shows on the terminal.
                let _ = std::io::Write::write_fmt(
                    &mut std::io::stderr(),
                    format_args!("test the_plant_steps_to_the_same_bits ... SIMD level {} SKIPPED (this CPU does not have it)\n", level.name()),
                );
            }
        });
        for model in [asymmetric_arm(), family_arm(&seed, false, [false, true], 0.3)] {
            let mut baseline = Plant::new(model).with_simd_level(SimdLevel::Baseline);
            let expected = baseline.evaluate(&state).unwrap().clone();
            for level in SimdLevel::ALL.into_iter().filter(|level| level.available()) {
                let mut plant = Plant::new(model).with_simd_level(level);
                let at = plant.evaluate(&state).unwrap();
                prop_assert_eq!(at.mass_matrix().map(f64::to_bits), expected.mass_matrix().map(f64::to_bits));
                prop_assert_eq!(bits(at.bias()), bits(expected.bias()));
                prop_assert_eq!(at.tip().map(f64::to_bits), expected.tip().map(f64::to_bits));
                // 1 ms moves the stages' angles by series; 0.1 s by more than its 0.05 rad limit
                // at most states, where they are computed afresh.
                for (integrator, dt) in Integrator::ALL.into_iter().flat_map(|i| [(i, 1e-3), (i, 0.1)]) {
                    let a = plant.step(&state, &tau, dt, integrator).unwrap();
                    let b = baseline.step(&state, &tau, dt, integrator).unwrap();
                    prop_assert_eq!(bits(&a.q), bits(&b.q), "{} at {}, dt {}", integrator.name(), level.name(), dt);
                    prop_assert_eq!(bits(&a.qd), bits(&b.qd), "{} at {}, dt {}", integrator.name(), level.name(), dt);
                }
            }
        }
    }
}
