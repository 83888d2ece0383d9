//! `--urdf FILE`: the user's own arm from URDF. The export → import round trip gives the same
//! dynamics; a hand-written arm with joint origins that are not DH-aligned gives the FK and
//! dynamics of an independent computation straight from the URDF's frames (parsed by urdf-rs,
//! not by chessarm); everything outside the supported shape is an error naming the element.

#![allow(clippy::unwrap_used, clippy::needless_range_loop)] // tests; index loops read as the formulas

mod common;

use chessarm_core::nalgebra::{Matrix3, Matrix4, Rotation3, Vector3, Vector4};
use common::{assert_one_line_error, chessarm, json_of, numbers};
use serde_json::Value;
use std::path::{Path, PathBuf};

use common::OFFSET_ARM as FIXTURE;

/// Seeded joint states spread over the joints' ranges (a small LCG: reproducible, no crate).
fn states(count: usize, seed: u64) -> Vec<([f64; 4], [f64; 4])> {
    let mut state = seed;
    let mut next = move || {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    (0..count).map(|_| (std::array::from_fn(|_| 2.5 * next()), std::array::from_fn(|_| 2.0 * next()))).collect()
}

fn list(values: &[f64; 4]) -> String {
    values.map(|v| format!("{v:e}")).join(",")
}

/// `dynamics` and `fk` of the arm `arm_args` at `(q, q̇)`: M, C·q̇, g and the tip.
fn chessarm_terms(
    arm_args: &[&str],
    q: &[f64; 4],
    qd: &[f64; 4],
) -> (Matrix4<f64>, Vector4<f64>, Vector4<f64>, Vector3<f64>) {
    let (q, qd) = (list(q), list(qd));
    let mut args = arm_args.to_vec();
    args.extend(["dynamics", "--q", &q, "--qd", &qd]);
    let dynamics = json_of(&chessarm(&args));
    let mut args = arm_args.to_vec();
    args.extend(["fk", "--q", &q]);
    let fk = json_of(&chessarm(&args));
    let rows: Vec<Vec<f64>> = dynamics["M"].as_array().unwrap().iter().map(numbers).collect();
    let mass = Matrix4::from_fn(|i, j| rows[i][j]);
    let vector = |value: &Value| Vector4::from_vec(numbers(value));
    (mass, vector(&dynamics["c"]), vector(&dynamics["g"]), Vector3::from_vec(numbers(&fk["tip"])))
}

fn max_abs<const R: usize, const C: usize>(m: &chessarm_core::nalgebra::SMatrix<f64, R, C>) -> f64 {
    m.abs().max()
}

#[test]
fn urdf_export_then_import_gives_the_same_dynamics() {
    let dir = tempfile::tempdir().unwrap();
    // The report's arm, and an asymmetric one: offsets along every axis, angle offsets, a
    // shoulder beside the base axis, a downward-pointing frame 1, motors and friction.
    let asymmetric = dir.path().join("asymmetric.toml");
    std::fs::write(
        &asymmetric,
        "gravity = [0.0, 0.0, -9.81]\n\
         [[links]]\na = 0.02\nalpha = -1.5707963267948966\nd = 0.2\ntheta_offset = 0.3\nmotor_mass = 0.0\nviscous = 0.1\n\
         [[links]]\na = 0.28\nd = 0.03\ntheta_offset = -0.2\nmotor_mass = 0.25\ncom = [-0.12, 0.01, 0.02]\n\
         [[links]]\na = 0.31\nalpha = 3.141592653589793\nd = -0.01\ntheta_offset = 0.4\nmotor_mass = 0.15\ncoulomb = 0.02\n\
         [[links]]\na = 0.1\nalpha = 0.3\nd = 0.015\ntheta_offset = 0.1\nmotor_mass = 0.05\n",
    )
    .unwrap();
    for (name, arm_args) in [("report", vec![]), ("asymmetric", vec!["--arm", asymmetric.to_str().unwrap()])] {
        let mut args = arm_args.clone();
        args.push("urdf");
        let output = chessarm(&args);
        assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
        let urdf = dir.path().join(format!("{name}.urdf"));
        std::fs::write(&urdf, &output.stdout).unwrap();
        let imported = vec!["--urdf", urdf.to_str().unwrap()];
        for (q, qd) in states(12, 7) {
            let (m0, c0, g0, tip0) = chessarm_terms(&arm_args, &q, &qd);
            let (m1, c1, g1, tip1) = chessarm_terms(&imported, &q, &qd);
            // Both sides are the same arithmetic on parameters that went through 17-digit text
            // and an Euler-angle round trip: agreement to rounding, far inside 1e-12.
            assert!(max_abs(&(m0 - m1)) < 1e-12, "{name} M at q = {q:?}: {m0} vs {m1}");
            assert!(max_abs(&(c0 - c1)) < 1e-12, "{name} C·q̇ at {q:?}, {qd:?}: {c0} vs {c1}");
            assert!(max_abs(&(g0 - g1)) < 1e-12, "{name} g at {q:?}: {g0} vs {g1}");
            assert!((tip0 - tip1).norm() < 1e-12, "{name} tip at {q:?}: {tip0} vs {tip1}");
        }
    }
}

/// A rigid body of the independent model: mass, COM and inertia in the frame of the joint that
/// moves it.
struct Body {
    joint: usize,
    mass: f64,
    com: Vector3<f64>,
    inertia: Matrix3<f64>,
}

/// The fixture's chain as urdf-rs reads it: per moving joint its origin, axis; the bodies; the
/// tool offset — composed straight from the URDF (no DH anywhere).
struct Independent {
    /// Per moving joint: the fixed transforms from the previous moving joint's frame to it.
    origins: Vec<(Rotation3<f64>, Vector3<f64>)>,
    axes: Vec<Vector3<f64>>,
    bodies: Vec<Body>,
    tool: Vector3<f64>,
    /// Per link: the moving joint that carries it (`None`: the base) and its pose in that
    /// joint's frame (the base frame for the base's).
    links: Vec<LinkPose>,
}

/// A link's name, the moving joint that carries it and its pose in that joint's frame.
type LinkPose = (String, Option<usize>, Rotation3<f64>, Vector3<f64>);

fn pose_of(pose: &urdf_rs::Pose) -> (Rotation3<f64>, Vector3<f64>) {
    let [r, p, y] = [pose.rpy[0], pose.rpy[1], pose.rpy[2]];
    (Rotation3::from_euler_angles(r, p, y), Vector3::new(pose.xyz[0], pose.xyz[1], pose.xyz[2]))
}

fn independent(path: &Path) -> Independent {
    let robot = urdf_rs::read_file(path).unwrap();
    let link = |name: &str| robot.links.iter().find(|l| l.name == name).unwrap();
    let mut origins = Vec::new();
    let mut axes = Vec::new();
    let mut bodies = Vec::new();
    // Pose of the current link in the last moving joint's frame.
    let (mut rotation, mut translation) = (Rotation3::identity(), Vector3::zeros());
    let mut current = "base_link".to_string();
    let mut links = vec![(current.clone(), None, rotation, translation)];
    while let Some(joint) = robot.joints.iter().find(|j| j.parent.link == current) {
        let (r, t) = pose_of(&joint.origin);
        let (r, t) = (rotation * r, rotation * t + translation);
        let moving = matches!(joint.joint_type, urdf_rs::JointType::Revolute);
        if moving {
            origins.push((r, t));
            axes.push(Vector3::new(joint.axis.xyz[0], joint.axis.xyz[1], joint.axis.xyz[2]));
            (rotation, translation) = (Rotation3::identity(), Vector3::zeros());
        } else {
            (rotation, translation) = (r, t);
        }
        current = joint.child.link.clone();
        links.push((current.clone(), origins.len().checked_sub(1), rotation, translation));
        let inertial = &link(&current).inertial;
        if !origins.is_empty() && inertial.mass.value > 0.0 {
            let (ri, ti) = pose_of(&inertial.origin);
            let i = &inertial.inertia;
            let tensor = Matrix3::new(i.ixx, i.ixy, i.ixz, i.ixy, i.iyy, i.iyz, i.ixz, i.iyz, i.izz);
            let turn = rotation * ri;
            bodies.push(Body {
                joint: origins.len() - 1,
                mass: inertial.mass.value,
                com: rotation * ti + translation,
                inertia: turn.matrix() * tensor * turn.matrix().transpose(),
            });
        }
    }
    assert_eq!(origins.len(), 4);
    Independent { origins, axes, bodies, tool: translation, links }
}

impl Independent {
    /// Joint frames (rotation, origin) in the base frame at `q`.
    fn frames(&self, q: &[f64; 4]) -> Vec<(Rotation3<f64>, Vector3<f64>)> {
        let mut frames: Vec<(Rotation3<f64>, Vector3<f64>)> = Vec::new();
        let (mut rotation, mut translation) = (Rotation3::identity(), Vector3::zeros());
        for k in 0..4 {
            let (r, t) = &self.origins[k];
            translation += rotation * t;
            rotation = rotation
                * r
                * Rotation3::from_axis_angle(&chessarm_core::nalgebra::Unit::new_normalize(self.axes[k]), q[k]);
            frames.push((rotation, translation));
        }
        frames
    }

    fn tip(&self, q: &[f64; 4]) -> Vector3<f64> {
        let (rotation, translation) = self.frames(q)[3];
        rotation * self.tool + translation
    }

    /// `M(q) = Σ_b m Jvᵀ Jv + Jωᵀ (R I Rᵀ) Jω` and `g(q) = −Σ_b m Jvᵀ g⃗`, with the columns of
    /// joint j ≤ b's joint `Jv_j = u_j × (c − p_j)`, `Jω_j = u_j`.
    fn mass_and_gravity(&self, q: &[f64; 4], gravity: &Vector3<f64>) -> (Matrix4<f64>, Vector4<f64>) {
        let frames = self.frames(q);
        let world_axes: Vec<Vector3<f64>> = (0..4).map(|k| frames[k].0 * self.axes[k].normalize()).collect();
        let mut mass = Matrix4::zeros();
        let mut torque = Vector4::zeros();
        for body in &self.bodies {
            let (rotation, origin) = frames[body.joint];
            let com = rotation * body.com + origin;
            let inertia = rotation.matrix() * body.inertia * rotation.matrix().transpose();
            let mut linear = chessarm_core::nalgebra::Matrix3x4::zeros();
            let mut angular = chessarm_core::nalgebra::Matrix3x4::zeros();
            for j in 0..=body.joint {
                linear.set_column(j, &world_axes[j].cross(&(com - frames[j].1)));
                angular.set_column(j, &world_axes[j]);
            }
            mass += linear.transpose() * linear * body.mass + angular.transpose() * inertia * angular;
            torque -= linear.transpose() * gravity * body.mass;
        }
        (mass, torque)
    }
}

#[test]
fn a_hand_written_urdf_arm_gives_the_independent_fk_and_dynamics() {
    let model = independent(Path::new(FIXTURE));
    let gravity = Vector3::new(0.0, 0.0, -9.8);
    let arm = ["--urdf", FIXTURE];
    for (q, qd) in states(16, 11) {
        let (mass, coriolis, g, tip) = chessarm_terms(&arm, &q, &qd);
        let (expected_mass, expected_g) = model.mass_and_gravity(&q, &gravity);
        // Two formulations of the same rigid bodies (DH recursion vs URDF frames with geometric
        // Jacobians): equal to rounding, here ~1e-17; 1e-12 leaves room for the import's
        // snapping of the axes, which rounds at 1e-16 for this file.
        assert!((model.tip(&q) - tip).norm() < 1e-12, "tip at q = {q:?}: {} vs {tip}", model.tip(&q));
        assert!(max_abs(&(expected_mass - mass)) < 1e-12, "M at q = {q:?}:\n{expected_mass} vs\n{mass}");
        assert!(max_abs(&(expected_g - g)) < 1e-12, "g at q = {q:?}: {expected_g} vs {g}");
        // C(q, q̇)·q̇ from the Christoffel symbols of the independent M by central differences:
        // `(C q̇)_i = Σ_jk (∂M_ij/∂q_k − ½ ∂M_jk/∂q_i) q̇_j q̇_k`. Step 1e-5 rad: truncation
        // ~1e-10 · |∂³M|, rounding ~1e-16/1e-5; 1e-8 N·m is far above both, far below any term.
        let step = 1e-5;
        let derivative = |k: usize| {
            let (mut plus, mut minus) = (q, q);
            plus[k] += step;
            minus[k] -= step;
            (model.mass_and_gravity(&plus, &gravity).0 - model.mass_and_gravity(&minus, &gravity).0) / (2.0 * step)
        };
        let dm: Vec<Matrix4<f64>> = (0..4).map(derivative).collect();
        let v = Vector4::from(qd);
        let mut expected_c = Vector4::zeros();
        for i in 0..4 {
            for j in 0..4 {
                for k in 0..4 {
                    expected_c[i] += (dm[k][(i, j)] - 0.5 * dm[i][(j, k)]) * v[j] * v[k];
                }
            }
        }
        assert!(max_abs(&(expected_c - coriolis)) < 1e-8, "C·q̇ at {q:?}, {qd:?}: {expected_c} vs {coriolis}");
    }
}

#[test]
fn a_urdf_arm_reaches_every_square_and_plays_a_move() {
    // FK(IK(x)) = x over the board for the fixture's offset geometry (its pitch plane lies 79 mm
    // beside the base axis, frame 1 points down, the elbow axis is reversed).
    for file in ['a', 'd', 'h'] {
        for rank in ['1', '4', '8'] {
            let square = format!("{file}{rank}");
            let ik = json_of(&chessarm(&["--urdf", FIXTURE, "ik", "--square", &square, "--height", "0.03"]));
            let q = numbers(&ik["q"]);
            let q = list(&[q[0], q[1], q[2], q[3]]);
            let fk = json_of(&chessarm(&["--urdf", FIXTURE, "fk", "--q", &q]));
            let tip = numbers(&fk["tip"]);
            let f = f64::from(file as u8 - b'a');
            let r = f64::from(rank as u8 - b'1');
            let expected = [(f - 3.5) * 0.06, 0.33 + (r - 3.5) * 0.06, 0.03];
            for (axis, (got, want)) in tip.iter().zip(expected).enumerate() {
                assert!((got - want).abs() < 1e-12, "{square} axis {axis}: {got} vs {want}");
            }
            assert!((fk["pitch"].as_f64().unwrap() + std::f64::consts::FRAC_PI_2).abs() < 1e-12, "{square}: {fk}");
        }
    }
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("play");
    // On the report's board a traverse (a1 to the white reserve) passes nearer the base than this
    // arm folds: the pre-flight refuses it, naming the point and `board --fit`.
    let refused = chessarm(&["--urdf", FIXTURE, "play", "--moves", "e4", "--out", out.to_str().unwrap()]);
    // (The import's notes come first on stderr: the tool frame it took, a placeholder torque.)
    assert_eq!(refused.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&refused.stderr);
    let last = stderr.trim_end().lines().last().unwrap();
    for needle in ["error:", "cannot be served", "the way from a1 to white reserve slot 0", "board --fit"] {
        assert!(last.contains(needle), "{needle}: {stderr}");
    }
    let report = json_of(&common::on_offset_arm_board(&["play", "--moves", "e4", "--out", out.to_str().unwrap()]));
    assert_eq!(report["misplaced"].as_u64(), Some(0), "{report}");
}

/// Writes `text` as a URDF in `dir` and runs `chessarm --urdf it fk`.
fn import(dir: &Path, name: &str, text: &str) -> std::process::Output {
    let path: PathBuf = dir.join(name);
    std::fs::write(&path, text).unwrap();
    chessarm(&["--urdf", path.to_str().unwrap(), "fk", "--q", "0,0,0,0"])
}

#[test]
fn urdf_outside_the_supported_shape_is_an_error_naming_the_element() {
    let dir = tempfile::tempdir().unwrap();
    let fixture = std::fs::read_to_string(FIXTURE).unwrap();
    let edit = |from: &str, to: &str| {
        assert!(fixture.contains(from), "{from}");
        fixture.replacen(from, to, 1)
    };
    let line_of = |needle: &str| fixture[..fixture.find(needle).unwrap()].matches('\n').count() + 1;
    let elbow_line = format!("line {}", line_of(r#"<joint name="elbow""#));
    let cases: Vec<(&str, String, Vec<String>)> = vec![
        (
            "prismatic",
            edit(r#"<joint name="elbow" type="revolute">"#, r#"<joint name="elbow" type="prismatic">"#),
            vec![
                elbow_line.clone(),
                "a prismatic joint on the way to the tool".into(),
                "--lock elbow=VALUE (m)".into(),
            ],
        ),
        (
            "wrist roll",
            edit(
                "<origin xyz=\"0.32 -0.015 -0.01\" rpy=\"0 0.6 0\"/>\n    <axis xyz=\"0 1 0\"/>",
                "<origin xyz=\"0.32 -0.015 -0.01\" rpy=\"0 0.6 0\"/>\n    <axis xyz=\"1 0 0\"/>",
            ),
            vec![
                format!("line {}: <joint name=\"wrist\">", line_of(r#"<joint name="wrist""#)),
                "not parallel to joint 'shoulder'".into(),
                "wrist roll".into(),
            ],
        ),
        (
            "a floating joint",
            edit(r#"<joint name="elbow" type="revolute">"#, r#"<joint name="elbow" type="floating">"#),
            vec![elbow_line.clone(), "type=\"floating\"".into(), "cannot be modelled".into()],
        ),
        (
            "two tool frames",
            edit(
                "  <link name=\"tool\"/>",
                "  <link name=\"tool\"/>\n  <link name=\"camera_tip\"/>\n  <joint name=\"camera_mount\" type=\"fixed\"><parent link=\"forearm\"/><child link=\"camera_tip\"/></joint>",
            ),
            vec!["which link is the tool? candidates: 'tool', 'camera_tip'".into(), "--tool LINK".into()],
        ),
        (
            "missing inertial",
            edit(
                "  <link name=\"forearm\">\n    <inertial>\n      <origin xyz=\"0.16 -0.01 0.0\" rpy=\"0.2 0 0.1\"/>\n      <mass value=\"0.45\"/>\n      <inertia ixx=\"0.0003\" ixy=\"-0.00002\" ixz=\"0\" iyy=\"0.0052\" iyz=\"0\" izz=\"0.005\"/>\n    </inertial>\n  </link>",
                "  <link name=\"forearm\"/>",
            ),
            vec!["<link name=\"forearm\">".into(), "no <inertial>".into(), "moved by joint 'elbow'".into()],
        ),
        (
            "tilted base",
            edit(r#"<origin xyz="0 0 0.04" rpy="0 0 0.25"/>"#, r#"<origin xyz="0 0 0.04" rpy="0.2 0 0.25"/>"#),
            vec![format!("line {}: <joint name=\"waist\">", line_of(r#"<joint name="waist""#)), "base yaw".into()],
        ),
        (
            "a negative base mass",
            edit(r#"<mass value="2.0"/>"#, r#"<mass value="-2.0"/>"#),
            vec!["<link name=\"base_link\">".into(), "<mass value=\"-2\"> is negative".into()],
        ),
        (
            "an empty link name",
            edit(r#"<link name="pedestal">"#, r#"<link name="">"#),
            vec!["a link's name must not be empty".into()],
        ),
        (
            "a joint named twice",
            edit(r#"<joint name="elbow" type="revolute">"#, r#"<joint name="shoulder" type="revolute">"#),
            vec![format!("{elbow_line}: <joint name=\"shoulder\">"), "a second joint named 'shoulder'".into()],
        ),
        (
            "an empty joint name",
            edit(r#"<joint name="elbow" type="revolute">"#, r#"<joint name=" " type="revolute">"#),
            vec![elbow_line.clone(), "a joint's name must not be empty".into()],
        ),
        (
            "a second tree",
            edit(
                "  <link name=\"tool\"/>",
                "  <link name=\"tool\"/>\n  <link name=\"stray\"/>\n  <link name=\"other\"/>\n  <joint name=\"s\" type=\"fixed\"><parent link=\"stray\"/><child link=\"other\"/></joint>",
            ),
            vec!["links 'base_link', 'stray' have no parent joint".into()],
        ),
        (
            "a loop beside the chain",
            edit(
                "  <link name=\"tool\"/>",
                "  <link name=\"tool\"/>\n  <link name=\"p\"/>\n  <link name=\"r\"/>\n  <joint name=\"pr\" type=\"fixed\"><parent link=\"p\"/><child link=\"r\"/></joint>\n  <joint name=\"rp\" type=\"fixed\"><parent link=\"r\"/><child link=\"p\"/></joint>",
            ),
            vec!["<link name=\"p\">".into(), "not reached from 'base_link'".into(), "loop".into()],
        ),
        (
            "tool on the wrist axis",
            edit(r#"<origin xyz="0.07 0.01 -0.015" rpy="0 0 0"/>"#, r#"<origin xyz="0 0.03 0" rpy="0 0 0"/>"#)
                .replace(r#"<origin xyz="0.05 0 0" rpy="0 0 0.4"/>"#, r#"<origin xyz="0 0 0" rpy="0 0 0"/>"#),
            vec!["<joint name=\"wrist\">".into(), "tool point lies on this joint's axis".into()],
        ),
        (
            "sideways gravity",
            edit(
                "<robot name=\"offset_arm\">",
                "<robot name=\"offset_arm\">\n  <mujoco><option gravity=\"9.8 0 0\"/></mujoco>",
            ),
            vec!["<option>".into(), "gravity must point along −z".into()],
        ),
        (
            "an unphysical fixed link",
            edit(
                r#"<inertia ixx="0.00003" ixy="0" ixz="0" iyy="0.00004" iyz="0.000002" izz="0.000035"/>"#,
                r#"<inertia ixx="-0.0005" ixy="0" ixz="0" iyy="0.00004" iyz="0.000002" izz="0.000035"/>"#,
            ),
            vec!["<link name=\"gripper\">".into(), "principal moments".into()],
        ),
        (
            "no tool",
            edit(
                "  <joint name=\"tool_flange\" type=\"fixed\">",
                "  <joint name=\"tool_flange\" type=\"fixed\">\n    <!-- cut -->",
            )
            .split("  <joint name=\"tool_flange\"")
            .next()
            .unwrap()
            .to_string()
                + "</robot>\n",
            vec![
                "no tool frame".into(),
                "add a fixed joint to a link whose origin is the tool tip".into(),
                "--tool LINK".into(),
            ],
        ),
        (
            "three joints",
            edit(r#"<joint name="waist" type="revolute">"#, r#"<joint name="waist" type="fixed">"#),
            vec!["3 moving joints".into(), "base_link → pedestal → turret".into()],
        ),
        (
            "not a number",
            edit(r#"effort="30""#, r#"effort="thirty""#),
            vec![
                format!("line {}", line_of(r#"effort="30""#)),
                r#"effort="thirty""#.into(),
                "not a finite number".into(),
            ],
        ),
        ("not XML", edit("</robot>", "</robt>"), vec!["not valid XML".into()]),
    ];
    for (case, text, needles) in cases {
        let output = import(dir.path(), "bad.urdf", &text);
        let mut needles: Vec<&str> = needles.iter().map(String::as_str).collect();
        needles.push("bad.urdf");
        eprintln!("{case}: {}", String::from_utf8_lossy(&output.stderr).trim_end());
        assert_one_line_error(&output, &needles);
    }
    let missing = chessarm(&["--urdf", "no/such.urdf", "fk", "--q", "0,0,0,0"]);
    assert_one_line_error(&missing, &["URDF file no/such.urdf: cannot read"]);
}

#[test]
fn fixed_links_after_the_tool_are_followed_to_the_chain_s_end() {
    // Marker links chained after the tool (the case that was quadratic): the tool is
    // the chain's last link, here at the same place as the tool, so FK is the default arm's.
    // (Their import time is measured by `cargo bench --bench import`: linear, 0.4 s for 100 000.)
    let dir = tempfile::tempdir().unwrap();
    let mut text = String::from_utf8(chessarm(&["urdf"]).stdout).unwrap();
    let mut chain = String::new();
    let mut parent = "tool".to_string();
    for i in 0..2000 {
        chain.push_str(&format!(
            "<link name=\"m{i}\"/><joint name=\"jm{i}\" type=\"fixed\"><parent link=\"{parent}\"/><child link=\"m{i}\"/></joint>\n"
        ));
        parent = format!("m{i}");
    }
    text = text.replace("</robot>", &format!("{chain}</robot>"));
    let path = dir.path().join("markers.urdf");
    std::fs::write(&path, text).unwrap();
    let fk = |extra: &[&str]| {
        let output = chessarm(&[extra, &["fk", "--q", "0.3,1.0,-1.2,-0.5"]].concat());
        assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
        let value: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
        value["frames"].as_array().unwrap().iter().flat_map(|f| common::numbers(&f["origin"])).collect::<Vec<f64>>()
    };
    let (imported, default) = (fk(&["--urdf", path.to_str().unwrap()]), fk(&[]));
    assert_eq!(imported.len(), default.len());
    // The URDF round trip rebuilds the DH parameters by trigonometry: a few ulp of 0.3 m.
    for (a, b) in imported.iter().zip(&default) {
        assert!((a - b).abs() < 1e-12, "{imported:?} vs {default:?}");
    }
}

/// The import's answers to what makers' files contain, on edits of the example arm: each taken
/// as published (with what the terminal says) or refused in one error that lists every problem.
#[test]
fn makers_files_are_taken_as_published_or_refused_with_every_problem_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let fixture = std::fs::read_to_string(FIXTURE).unwrap();
    let edit = |from: &str, to: &str| {
        assert!(fixture.contains(from), "{from}");
        fixture.replacen(from, to, 1)
    };
    let run = |name: &str, text: &str, extra: &[&str]| {
        let path = dir.path().join(name);
        std::fs::write(&path, text).unwrap();
        chessarm(&[&["--urdf", path.to_str().unwrap()][..], extra, &["fk", "--q", "0.3,1.0,-1.2,-0.5"]].concat())
    };
    let tip = |output: &std::process::Output| -> Vec<f64> { numbers(&json_of(output)["tip"]) };
    let published = tip(&run("as-is.urdf", &fixture, &[]));
    let close = |a: &[f64], b: &[f64]| a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-12);

    // A gripper: two fingers (one a <mimic>) and a camera branch off the wrist, massless markers;
    // the tool is still found by its name, the fingers held at 0 or their nearest limit.
    let fingers = "\n  <link name=\"finger_l\"><inertial><mass value=\"0.01\"/><inertia ixx=\"1e-7\" ixy=\"0\" ixz=\"0\" iyy=\"1e-7\" iyz=\"0\" izz=\"1e-7\"/></inertial></link>\
        \n  <link name=\"finger_r\"><inertial><mass value=\"0.01\"/><inertia ixx=\"1e-7\" ixy=\"0\" ixz=\"0\" iyy=\"1e-7\" iyz=\"0\" izz=\"1e-7\"/></inertial></link>\
        \n  <joint name=\"finger_l_joint\" type=\"prismatic\"><parent link=\"gripper\"/><child link=\"finger_l\"/><axis xyz=\"0 1 0\"/><limit lower=\"0.005\" upper=\"0.03\" effort=\"5\" velocity=\"1\"/></joint>\
        \n  <joint name=\"finger_r_joint\" type=\"prismatic\"><parent link=\"gripper\"/><child link=\"finger_r\"/><axis xyz=\"0 1 0\"/><limit lower=\"-0.03\" upper=\"-0.005\" effort=\"5\" velocity=\"1\"/><mimic joint=\"finger_l_joint\" multiplier=\"-1\"/></joint>\
        \n  <link name=\"camera\"/>\n  <joint name=\"camera_mount\" type=\"continuous\"><parent link=\"wrist_link\"/><child link=\"camera\"/></joint>\n</robot>";
    let gripper = edit("\n</robot>", fingers);
    let output = run("gripper.urdf", &gripper, &[]);
    let stderr = String::from_utf8_lossy(&output.stderr).to_string();
    assert!(stderr.contains("tool frame: link 'tool'"), "{stderr}");
    assert!(stderr.contains("finger_l_joint = 0.005"), "{stderr}");
    // The fingers' 20 g moves the dynamics, not the kinematics.
    assert!(close(&tip(&output), &published));
    // --lock on a follower is refused naming its leader; a value outside the limits too.
    let locked = run("gripper.urdf", &gripper, &["--lock", "finger_r_joint=-0.01"]);
    common::assert_one_line_error(&locked, &["--lock finger_r_joint=-0.01", "follows 'finger_l_joint'"]);
    let outside = run("gripper.urdf", &gripper, &["--lock", "finger_l_joint=0.5"]);
    common::assert_one_line_error(&outside, &["held at 0.5 m", "outside its <limit"]);
    let unknown = run("gripper.urdf", &gripper, &["--lock", "nose=0"]);
    common::assert_one_line_error(&unknown, &["no joint 'nose'", "'finger_l_joint'"]);

    // A fifth joint (a wrist roll before the tool): refused naming the lock that fixes it, taken
    // with the lock, and at the lock's value 0 the tool is where it was.
    let roll = edit(
        "  <joint name=\"tool_flange\" type=\"fixed\">",
        "  <joint name=\"tool_flange\" type=\"revolute\"><axis xyz=\"1 0 0\"/><limit lower=\"-3\" upper=\"3\" effort=\"2\" velocity=\"3\"/>",
    );
    let five = run("roll.urdf", &roll, &[]);
    common::assert_one_line_error(&five, &["5 moving joints", "--lock tool_flange=0"]);
    assert!(close(&tip(&run("roll.urdf", &roll, &["--lock", "tool_flange=0"])), &published));

    // A <mimic> joint on the way to the tool moves with its leader: held with a held leader (the
    // gripper's finger, here at 0.005 m: the flange turns 0.005·2 rad), refused when it follows
    // one of the arm's joints (a parallel linkage).
    let follower = gripper.replacen(
        "  <joint name=\"tool_flange\" type=\"fixed\">",
        "  <joint name=\"tool_flange\" type=\"revolute\"><axis xyz=\"1 0 0\"/><limit lower=\"-3\" upper=\"3\" effort=\"2\" velocity=\"3\"/><mimic joint=\"finger_l_joint\" multiplier=\"2\"/>",
        1,
    );
    let held = run("follower.urdf", &follower, &[]);
    assert!(held.status.success(), "{}", String::from_utf8_lossy(&held.stderr));
    let linkage =
        follower.replacen("<mimic joint=\"finger_l_joint\" multiplier=\"2\"/>", "<mimic joint=\"elbow\"/>", 1);
    common::assert_one_line_error(&run("linkage.urdf", &linkage, &[]), &["follows the arm's joint 'elbow'"]);
    // A continuous base without <limit>: ±π, with the other joints' smallest speed and torque.
    let continuous = edit("<joint name=\"waist\" type=\"revolute\">", "<joint name=\"waist\" type=\"continuous\">")
        .replacen("<limit lower=\"-3.1\" upper=\"3.1\" effort=\"12\" velocity=\"3\"/>", "", 1);
    let output = run("continuous.urdf", &continuous, &[]);
    let stderr = String::from_utf8_lossy(&output.stderr).to_string();
    assert!(stderr.contains("no effort limit given") && stderr.contains("taken as 6 N·m"), "{stderr}");
    assert!(close(&tip(&output), &published));

    // A base off the yaw axis: the model's base position, the same tool points moved with it.
    let moved =
        edit(r#"<origin xyz="0 0 0.04" rpy="0 0 0.25"/>"#, r#"<origin xyz="0.012 -0.02 0.04" rpy="0 0 0.25"/>"#);
    let shifted = tip(&run("moved.urdf", &moved, &[]));
    assert!(close(&shifted, &[published[0] + 0.012, published[1] - 0.02, published[2]]), "{shifted:?}");

    // Several problems: every one in one error, after the shape.
    let broken = edit(r#"<limit lower="-3.0" upper="3.0" effort="18" velocity="3"/>"#, "")
        .replacen("<mass value=\"0.45\"/>", "<mass value=\"-1\"/>", 1)
        .replacen(r#"<dynamics damping="0.05" friction="0.02"/>"#, r#"<dynamics damping="-1" friction="0.02"/>"#, 1);
    let output = run("broken.urdf", &broken, &[]);
    common::assert_one_line_error(
        &output,
        &[
            "3 problems",
            "(1)",
            "<link name=\"forearm\">",
            "<joint name=\"elbow\">",
            "has no <limit>",
            "(3)",
            "<joint name=\"waist\">",
            "damping and friction must be >= 0",
        ],
    );
    // A xacro file is recognised (its elements, or a substitution left in a value); an expanded
    // file that keeps the namespace declaration is URDF.
    let namespace = fixture.replacen(
        "<robot name=\"offset_arm\">",
        "<robot name=\"offset_arm\" xmlns:xacro=\"http://www.ros.org/wiki/xacro\">",
        1,
    );
    assert!(close(&tip(&run("expanded.urdf", &namespace, &[])), &published));
    let element = namespace.replacen(
        "<link name=\"pedestal\">",
        "<xacro:property name=\"h\" value=\"0.03\"/>\n  <link name=\"pedestal\">",
        1,
    );
    common::assert_one_line_error(&run("arm.urdf.xacro", &element, &[]), &["xacro file", "expand it first"]);
    let commented =
        namespace.replacen("<robot name", "<!-- <xacro:include filename=\"arm.xacro\"/> -->\n<robot name", 1);
    assert!(close(&tip(&run("commented.urdf", &commented, &[])), &published));
    let substitution =
        fixture.replacen(r#"<origin xyz="0 0 0.03" rpy="0 0 0"/>"#, r#"<origin xyz="0 0 ${h}" rpy="0 0 0"/>"#, 1);
    common::assert_one_line_error(&run("sub.urdf", &substitution, &[]), &["xacro file"]);
}

/// ASCII STL of the box `[0, x] × [0, y] × [0, z]` (12 triangles; its 8 corners, each repeated).
fn box_stl(x: f64, y: f64, z: f64) -> String {
    let corner = |i: usize| [(i & 1) as f64 * x, ((i >> 1) & 1) as f64 * y, ((i >> 2) & 1) as f64 * z];
    let mut text = String::from("solid box\n");
    for face in common::BOX_FACES {
        text.push_str("facet normal 0 0 0\nouter loop\n");
        for i in face {
            let [a, b, c] = corner(i);
            text.push_str(&format!("vertex {a} {b} {c}\n"));
        }
        text.push_str("endloop\nendfacet\n");
    }
    text + "endsolid box\n"
}

/// The fixture with `<collision>` shapes on the base's fixed link, each arm link and the
/// gripper fixed to the last: a box, a cylinder, a sphere and a box, a mesh (an STL box in mm,
/// scaled) and a turned cylinder, written to `dir` with the mesh in `dir/meshes`.
fn fixture_with_collisions(dir: &Path) -> PathBuf {
    let shapes = [
        ("pedestal", r#"<collision><origin xyz="0.01 0 -0.01" rpy="0 0 0.3"/><geometry><box size="0.08 0.06 0.02"/></geometry></collision>"#.to_string()),
        ("turret", r#"<collision><origin xyz="0 0.01 0.03" rpy="0.2 0 0"/><geometry><cylinder radius="0.03" length="0.05"/></geometry></collision>"#.to_string()),
        ("upper_arm", r#"<collision><origin xyz="0.05 0 0.01"/><geometry><sphere radius="0.02"/></geometry></collision><collision><origin xyz="0.1 0.005 0" rpy="0.1 -0.2 0.4"/><geometry><box size="0.12 0.03 0.02"/></geometry></collision>"#.to_string()),
        ("forearm", r#"<collision><origin xyz="0.02 -0.01 0.005" rpy="0 0.3 -0.2"/><geometry><mesh filename="package://offset_arm/meshes/forearm.stl" scale="0.001 0.001 0.001"/></geometry></collision>"#.to_string()),
        ("gripper", r#"<collision><origin xyz="0.01 0 0" rpy="0 1.5707963 0"/><geometry><cylinder radius="0.012" length="0.03"/></geometry></collision>"#.to_string()),
    ];
    let mut text = std::fs::read_to_string(FIXTURE).unwrap();
    for (link, shape) in &shapes {
        let open = format!("<link name=\"{link}\">");
        assert!(text.contains(&open), "{link}");
        text = text.replace(&open, &format!("{open}\n    {shape}"));
    }
    let package = dir.join("offset_arm");
    std::fs::create_dir_all(package.join("meshes")).unwrap();
    std::fs::create_dir_all(package.join("urdf")).unwrap();
    std::fs::write(package.join("meshes/forearm.stl"), box_stl(90.0, 20.0, 16.0)).unwrap();
    let path = package.join("urdf/offset_arm.urdf");
    std::fs::write(&path, text).unwrap();
    path
}

/// Every `<collision>` shape of a hand-written arm lands where the URDF's own frames put it
/// (composed by urdf-rs's reading, no DH) at any angles: box centres and axes, cylinder ends,
/// sphere centres, the mesh's pose; the mesh is its convex hull (the STL box's 8 corners
/// from 36 vertices); the fingers are chessarm's. Tolerance 1e-12 m: two compositions of the
/// same rigid transforms, rounding ~1e-16.
#[test]
fn collision_shapes_land_where_the_urdf_frames_put_them() {
    use chessarm_core::arm::bodies::{Bodies, Gripper, Hand, Part, Shape, Solid, solids_into};
    let dir = tempfile::tempdir().unwrap();
    let path = fixture_with_collisions(dir.path());
    let imported = chessarm::app::setup::urdf_import::load(&path, &Default::default()).unwrap();
    let Bodies::Described(shapes) = &imported.bodies else { panic!("{:?}", imported.notes) };
    assert_eq!(shapes.len(), 6);
    assert!(
        imported.notes.iter().any(|n| n.contains("6 <collision> shapes (1 mesh as convex hulls)")),
        "{:?}",
        imported.notes
    );
    let hull = shapes
        .iter()
        .find_map(|s| match &s.shape {
            Shape::Hull { points } => Some(points.clone()),
            _ => None,
        })
        .unwrap();
    assert_eq!(hull.len(), 8, "{hull:?}");
    let robot = urdf_rs::read_file(&path).unwrap();
    let model = independent(&path);
    let hand = Hand { gripper: Gripper::default(), gap: 0.04, held: None };
    let mut solids = Vec::new();
    for (q, _) in states(12, 5) {
        solids_into(&imported.model, &chessarm_core::nalgebra::Vector4::from(q), &hand, &imported.bodies, &mut solids);
        let frames = model.frames(&q);
        let mut expected = Vec::new();
        for (name, joint, r, t) in &model.links {
            let (rotation, translation) = match joint {
                None => (*r, *t),
                Some(k) => (frames[*k].0 * r, frames[*k].0 * t + frames[*k].1),
            };
            let link = robot.links.iter().find(|l| &l.name == name).unwrap();
            for collision in &link.collision {
                let (rc, tc) = pose_of(&collision.origin);
                let part = match joint {
                    None => Part::Pedestal,
                    Some(k) => Part::Link(k + 1),
                };
                expected.push((part, rotation * rc, rotation * tc + translation, collision.geometry.clone()));
            }
        }
        let arm: Vec<_> = solids.iter().filter(|s| !matches!(s.part, Part::Finger(_) | Part::Held)).collect();
        assert_eq!(arm.len(), expected.len());
        assert_eq!(solids.len() - arm.len(), 2, "two fingers");
        for (solid, (part, rotation, centre, geometry)) in arm.iter().zip(&expected) {
            assert_eq!(solid.part, *part);
            let near = |a: &Vector3<f64>, b: &Vector3<f64>| (a - b).norm() < 1e-12;
            match (&solid.solid, geometry) {
                (Solid::Cuboid { centre: c, axes, half }, urdf_rs::Geometry::Box { size }) => {
                    assert!(near(c, centre), "{c} vs {centre} at {q:?}");
                    assert!((axes - rotation.matrix()).abs().max() < 1e-12);
                    assert!(near(&(half * 2.0), &Vector3::new(size[0], size[1], size[2])));
                }
                (Solid::Cylinder { a, b, radius }, urdf_rs::Geometry::Cylinder { radius: r, length }) => {
                    let half = rotation * Vector3::new(0.0, 0.0, 0.5 * length);
                    assert!(near(a, &(centre - half)) && near(b, &(centre + half)), "{a} {b} at {q:?}");
                    assert_eq!(radius, r);
                }
                (Solid::Sphere { centre: c, radius }, urdf_rs::Geometry::Sphere { radius: r }) => {
                    assert!(near(c, centre));
                    assert_eq!(radius, r);
                }
                (Solid::Hull { pose, .. }, urdf_rs::Geometry::Mesh { .. }) => {
                    assert!(near(&pose.translation.vector, centre));
                    assert!((pose.rotation.matrix() - rotation.matrix()).abs().max() < 1e-12);
                }
                (solid, geometry) => panic!("{solid:?} for {geometry:?}"),
            }
        }
    }
}

/// A mesh that is not where the file says is said, with where it was looked for, and
/// chessarm's own solids stand in; a shape with a bad size or an unknown kind is an error
/// naming the link's line.
#[test]
fn a_missing_mesh_is_said_and_a_bad_shape_refused() {
    use chessarm_core::arm::bodies::Bodies;
    let dir = tempfile::tempdir().unwrap();
    let path = fixture_with_collisions(dir.path());
    std::fs::remove_file(dir.path().join("offset_arm/meshes/forearm.stl")).unwrap();
    let imported = chessarm::app::setup::urdf_import::load(&path, &Default::default()).unwrap();
    assert_eq!(imported.bodies, Bodies::Drawn);
    let warning = imported.warnings.iter().find(|w| w.contains("not found")).unwrap();
    assert!(warning.contains("'package://offset_arm/meshes/forearm.stl'"), "{warning}");
    assert!(warning.contains("offset_arm/meshes/forearm.stl"), "{warning}");
    // Shapes on every link but the turret: said, naming it.
    let text = std::fs::read_to_string(&path).unwrap();
    std::fs::write(dir.path().join("offset_arm/meshes/forearm.stl"), box_stl(90.0, 20.0, 16.0)).unwrap();
    let turret = text.lines().find(|l| l.contains("<cylinder radius=\"0.03\"")).unwrap().to_string();
    let partial = dir.path().join("offset_arm/urdf/partial.urdf");
    std::fs::write(&partial, text.replace(&turret, "")).unwrap();
    let imported = chessarm::app::setup::urdf_import::load(&partial, &Default::default()).unwrap();
    assert!(matches!(imported.bodies, Bodies::Described(_)));
    let warning = imported.warnings.iter().find(|w| w.contains("no <collision> shapes")).unwrap();
    assert!(warning.contains("'turret'") && !warning.contains("'forearm'"), "{warning}");
    // A mesh drawn in mm without its scale reaches 90 m: refused, saying how to scale it.
    let unscaled = dir.path().join("offset_arm/urdf/unscaled.urdf");
    std::fs::write(&unscaled, text.replace(r#" scale="0.001 0.001 0.001""#, "")).unwrap();
    let error = format!("{:#}", chessarm::app::setup::urdf_import::load(&unscaled, &Default::default()).unwrap_err());
    assert!(error.contains("link 'forearm'") && error.contains("scale=\"0.001 0.001 0.001\""), "{error}");
    for (from, to, needle) in [
        (r#"<sphere radius="0.02"/>"#, r#"<sphere radius="-0.02"/>"#, r#"radius="-0.02" must be > 0"#),
        (r#"<sphere radius="0.02"/>"#, r#"<capsule radius="0.02" length="0.1"/>"#, "with a <capsule>"),
        (r#"<box size="0.12 0.03 0.02"/>"#, r#"<box size="0.12 0.03"/>"#, "needs three finite numbers"),
        (r#"<box size="0.12 0.03 0.02"/>"#, r#"<box size="0.12 0 0.02"/>"#, r#"size="0.12 0 0.02" needs three sizes"#),
    ] {
        let bad = text.replace(from, to);
        let output = import(dir.path(), "bad.urdf", &bad);
        assert_one_line_error(&output, &["upper_arm", needle]);
    }
}

/// chessarm's URDF export imports back to chessarm's own solids: at any angles every drawn
/// cylinder (pedestal, housings, links ending at the palm) is one of the file's, ends and
/// radius within 1e-9 m (the export's shortest decimals and the DH refit), and the export's
/// tool marker is not a solid.
#[test]
fn the_export_imports_back_to_chessarms_own_solids() {
    use chessarm_core::arm::bodies::{Bodies, Gripper, Hand, Solid, solids_into};
    let arm = chessarm_core::arm::preset::report_arm();
    let gripper = Gripper::default();
    let names: [String; 4] = std::array::from_fn(|i| format!("joint{}", i + 1));
    let text = chessarm::app::formats::urdf::to_urdf(&arm, "chessarm", &names, &[1.0; 4], gripper.palm_depth());
    let imported = chessarm::app::setup::urdf_import::from_urdf(&text, &Default::default()).unwrap();
    assert!(matches!(imported.bodies, Bodies::Described(_)), "{:?}", imported.notes);
    let hand = Hand { gripper, gap: 0.04, held: None };
    let (mut drawn, mut described) = (Vec::new(), Vec::new());
    for (q, _) in states(12, 9) {
        let q = chessarm_core::nalgebra::Vector4::from(q);
        solids_into(&arm, &q, &hand, &Bodies::Drawn, &mut drawn);
        solids_into(&imported.model, &q, &hand, &imported.bodies, &mut described);
        assert_eq!(drawn.len(), described.len());
        for solid in &drawn {
            let found = described.iter().any(|other| match (&solid.solid, &other.solid) {
                (Solid::Cylinder { a, b, radius }, Solid::Cylinder { a: c, b: d, radius: r }) => {
                    let same = |x: &Vector3<f64>, y: &Vector3<f64>| (x - y).norm() < 1e-9;
                    (radius - r).abs() < 1e-12 && ((same(a, c) && same(b, d)) || (same(a, d) && same(b, c)))
                }
                (Solid::Cuboid { centre, half, .. }, Solid::Cuboid { centre: c, half: h, .. }) => {
                    (centre - c).norm() < 1e-9 && (half - h).norm() < 1e-12
                }
                _ => false,
            });
            assert!(found, "{} at {q:?} not in the import: {solid:?}", solid.part);
        }
    }
}

/// Played from its own URDF export (`chessarm urdf`, then `--urdf`), the report's arm keeps
/// the built-in arm's clearance on every move: the same obstacle and part, the distance within
/// 0.1 mm. Not equal: URDF has no rotor inertia, so the time-optimal timing of the same path
/// differs by milliseconds (measured 0.03 mm apart at most); the solids themselves are equal
/// to 1e-9 m (`the_export_imports_back_to_chessarms_own_solids`).
#[test]
fn the_exported_arm_plays_with_the_built_in_arm_s_clearance() {
    let dir = tempfile::tempdir().unwrap();
    let urdf = dir.path().join("arm.urdf");
    let exported = chessarm(&["urdf"]);
    assert!(exported.status.success());
    std::fs::write(&urdf, &exported.stdout).unwrap();
    let moves = "e4 d5 exd5 Qxd5 Nc3";
    let play = |extra: &[&str], out: &str| {
        let out = dir.path().join(out);
        let mut args = extra.to_vec();
        args.extend(["play", "--moves", moves, "--out", out.to_str().unwrap()]);
        assert!(chessarm(&args).status.success());
        serde_json::from_str::<Value>(&std::fs::read_to_string(out.join("game.json")).unwrap()).unwrap()
    };
    let built_in = play(&[], "built-in");
    let imported = play(&["--urdf", urdf.to_str().unwrap()], "imported");
    let (a, b) = (built_in["moves"].as_array().unwrap(), imported["moves"].as_array().unwrap());
    assert_eq!(a.len(), 5);
    for (one, two) in a.iter().zip(b) {
        let (x, y) = (&one["clearance"], &two["clearance"]);
        assert!(x["smallest_mm"].as_f64().is_some(), "{one}");
        assert!((x["smallest_mm"].as_f64().unwrap() - y["smallest_mm"].as_f64().unwrap()).abs() < 0.1, "{x} vs {y}");
        assert_eq!(x["obstacle"], y["obstacle"]);
        // (A drawn housing is one of the file's link shapes: the same place, named as a link.)
        assert!(x["part"] == y["part"] || x["part"].as_str().unwrap().contains("housing"), "{x} vs {y}");
        assert_eq!(y["executed"]["contact"], false);
    }
}

/// A tool offset that starts with a minus sign is read as the offset, typed either way
/// (`--tool-offset -0.01,0,0` was taken for an unknown flag `-0`), and moves the tool point.
#[test]
fn a_negative_tool_offset_is_read_as_typed() {
    let urdf = Path::new(common::REAL_ARMS).join("so101_new_calib.urdf");
    let urdf = urdf.to_str().unwrap();
    let fk = |offset: &[&str]| -> Value {
        json_of(&chessarm(&[&["--urdf", urdf, "--lock", "wrist_roll=0"], offset, &["fk", "--q", "0,0,0,0"]].concat()))
    };
    let spaced = fk(&["--tool-offset", "-0.01,0,0"]);
    let joined = fk(&["--tool-offset=-0.01,0,0"]);
    let none = fk(&[]);
    assert_eq!(spaced, joined);
    assert_ne!(spaced, none);
}
