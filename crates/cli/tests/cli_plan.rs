//! The binary, end to end: kinematics commands, setup files, URDF and planning outputs.

#![allow(clippy::unwrap_used)] // test helpers may panic: a panic is a failed test

mod common;
use common::{assert_one_line_error, chessarm, json_of, numbers};

use chessarm_core::arm::kinematics::FrameChain;
use chessarm_core::arm::model::JointVector;
use chessarm_core::arm::preset::report_arm;
use chessarm_core::nalgebra::{Matrix4, Rotation3, Vector3};
use std::path::Path;

#[test]
fn ik_then_fk_returns_the_square() {
    let ik = json_of(&chessarm(&["ik", "--square", "d4", "--height", "0.05"]));
    let q = numbers(&ik["q"]);
    let q_text = q.iter().map(|v| format!("{v:?}")).collect::<Vec<_>>().join(",");
    let fk = json_of(&chessarm(&["fk", "--q", &q_text]));
    let tip = numbers(&fk["tip"]);
    for (got, want) in tip.iter().zip([-0.03, 0.30, 0.05]) {
        assert!((got - want).abs() < 1e-9, "{tip:?}");
    }
    assert!((fk["pitch"].as_f64().unwrap() + std::f64::consts::FRAC_PI_2).abs() < 1e-9);
    assert_eq!(fk["frames"].as_array().unwrap().len(), 4);
    let xyz = json_of(&chessarm(&["ik", "--xyz", "-0.03,0.3,0.05"]));
    // The square's centre is computed as −0.21 + 3·0.06, which differs from −0.03 in the last bit.
    for (a, b) in numbers(&xyz["q"]).iter().zip(&q) {
        assert!((a - b).abs() < 1e-12);
    }
}

#[test]
fn bad_kinematics_input_is_one_line_with_exit_code_2() {
    assert_one_line_error(
        &chessarm(&["ik", "--xyz", "0,0.9,0.05"]),
        &["out of reach", "(0.0000, 0.9000, 0.0500) m", "0.6096"],
    );
    assert_one_line_error(&chessarm(&["ik", "--square", "k9"]), &["'k9'"]);
    assert_one_line_error(&chessarm(&["ik", "--xyz", "0,0,0.1"]), &["base axis"]);
    assert_one_line_error(&chessarm(&["ik", "--xyz", "0,0.02,-0.25"]), &["joint 2", "outside its limits"]);
    assert_one_line_error(&chessarm(&["fk", "--q", "1,2,x,4"]), &["'x'"]);
    assert_one_line_error(&chessarm(&["fk", "--q", "1,2,3"]), &["expected 4", "'1,2,3'"]);
    assert_one_line_error(&chessarm(&["fk", "--q", "1,2,3,NaN"]), &["not finite"]);
    // Beyond ±1.6e6 rad the sines the kinematics take would be NaN: an error naming the flag.
    assert_one_line_error(&chessarm(&["fk", "--q", "1,-2e6,3,4"]), &["--q", "'-2e6'", "beyond"]);
    assert_one_line_error(&chessarm(&["simulate", "--q0", "0,0,0,1e20"]), &["--q0", "'1e20'", "beyond"]);
    assert_one_line_error(&chessarm(&["plan", "--scenario", "sicilian"]), &["unknown scenario 'sicilian'"]);
    assert_one_line_error(&chessarm(&["plan", "--dt", "-1"]), &["-1"]);
    assert_one_line_error(&chessarm(&["frobnicate"]), &["frobnicate"]);
}

fn write_setup(dir: &Path, name: &str, text: &str) -> String {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    path.display().to_string()
}

#[test]
fn setup_file_round_trips_and_bad_files_name_the_field() {
    let dir = tempfile::tempdir().unwrap();
    let printed = chessarm(&["arm"]);
    assert!(printed.status.success());
    let text = String::from_utf8(printed.stdout).unwrap();
    let file = write_setup(dir.path(), "arm.toml", &text);
    // The printed setup loads back and describes the same arm.
    let again = chessarm(&["--arm", &file, "arm"]);
    assert_eq!(String::from_utf8(again.stdout).unwrap(), text);

    let negative_mass = text.replacen("mass = 0.5261671", "mass = -0.5261671", 1);
    let file = write_setup(dir.path(), "negative.toml", &negative_mass);
    assert_one_line_error(
        &chessarm(&["--arm", &file, "fk", "--q", "0,0,0,0"]),
        &["negative.toml", "link 2 mass = -0.5261671"],
    );

    let bad_tensor = text.replacen("0.007064321", "0.07064321", 1);
    let file = write_setup(dir.path(), "tensor.toml", &bad_tensor);
    assert_one_line_error(&chessarm(&["--arm", &file, "arm"]), &["link 2 inertia", "triangle"]);

    let file = write_setup(dir.path(), "syntax.toml", "gravity = [0, 0,\n[board\n");
    assert_one_line_error(&chessarm(&["--arm", &file, "arm"]), &["syntax.toml", "line "]);

    let file = write_setup(
        dir.path(),
        "unknown.toml",
        "[board]\nsquare_size = 0.05\ncenter = [0, 0.3]\nsurface_height = 0\ncolour = 1\n",
    );
    assert_one_line_error(&chessarm(&["--arm", &file, "arm"]), &["colour"]);

    let file = write_setup(dir.path(), "nan.toml", "gravity = [0, 0, nan]\n");
    assert_one_line_error(&chessarm(&["--arm", &file, "arm"]), &["gravity[2] = NaN"]);

    let three_links = &text[..text.rfind("\n[[links]]").unwrap()];
    let file = write_setup(dir.path(), "three.toml", three_links);
    assert_one_line_error(&chessarm(&["--arm", &file, "arm"]), &["4 joints", "lists 3"]);

    assert_one_line_error(&chessarm(&["--arm", "/nonexistent/arm.toml", "arm"]), &["/nonexistent/arm.toml"]);

    // Pieces: a grip above the piece's top is refused; a heavier pawn is accepted and printed back.
    let file = write_setup(
        dir.path(),
        "grip.toml",
        "[pieces.pawn]\nheight = 0.05\nbase_diameter = 0.029\nmass = 0.03\ngrip_height = 0.06\n",
    );
    assert_one_line_error(&chessarm(&["--arm", &file, "arm"]), &["pawn", "grip_height", "0.06"]);
    let file = write_setup(
        dir.path(),
        "pawn.toml",
        "[pieces.pawn]\nheight = 0.05\nbase_diameter = 0.029\nmass = 0.08\ngrip_height = 0.05\n",
    );
    let printed = String::from_utf8(chessarm(&["--arm", &file, "arm"]).stdout).unwrap();
    assert!(printed.contains("[pieces.pawn]") && printed.contains("mass = 0.08"), "{printed}");
    assert!(printed.contains("[pieces.king]"));

    // A partial file: only the board changes, and IK follows it.
    let file = write_setup(
        dir.path(),
        "board.toml",
        "[board]\nsquare_size = 0.05\ncenter = [0.0, 0.3]\nsurface_height = 0.0\n",
    );
    let q = numbers(&json_of(&chessarm(&["--arm", &file, "ik", "--square", "a1", "--height", "0.05"]))["q"]);
    let tip = report_arm_tip(&q);
    assert!((tip - Vector3::new(-0.175, 0.125, 0.05)).norm() < 1e-9, "{tip}");
}

fn report_arm_tip(q: &[f64]) -> Vector3<f64> {
    FrameChain::new(&report_arm(), &JointVector::<4>::from_column_slice(q)).tip()
}

/// Reads `<origin xyz=".." rpy=".."/>` of every joint, in order, from our URDF.
fn joint_origins(urdf: &str) -> Vec<(String, Matrix4<f64>)> {
    let mut result = Vec::new();
    for block in urdf.split("<joint ").skip(1) {
        let kind = block.split("type=\"").nth(1).unwrap().split('"').next().unwrap().to_string();
        let attribute = |name: &str| -> Vec<f64> {
            let text = block.split(&format!("{name}=\"")).nth(1).unwrap().split('"').next().unwrap();
            text.split_whitespace().map(|v| v.parse().unwrap()).collect()
        };
        let (xyz, rpy) = (attribute("xyz"), attribute("rpy"));
        let rotation = Rotation3::from_euler_angles(rpy[0], rpy[1], rpy[2]);
        let mut transform = Matrix4::identity();
        transform.fixed_view_mut::<3, 3>(0, 0).copy_from(rotation.matrix());
        transform.fixed_view_mut::<3, 1>(0, 3).copy_from(&Vector3::new(xyz[0], xyz[1], xyz[2]));
        result.push((kind, transform));
    }
    result
}

#[test]
fn urdf_chain_reproduces_forward_kinematics() {
    let output = chessarm(&["urdf"]);
    assert!(output.status.success());
    let urdf = String::from_utf8(output.stdout).unwrap();
    assert_eq!(urdf.matches("<link name=").count(), 6);
    assert_eq!(urdf.matches("type=\"revolute\"").count(), 4);
    assert!(urdf.contains("<link name=\"tool\">") && urdf.contains("type=\"fixed\""));
    assert!(urdf.contains("<mass value=\"0.5261671\"/>"));
    assert!(urdf.contains("effort=\"25\""));
    let joints = joint_origins(&urdf);
    let model = report_arm();
    for q in [[0.3, 0.8, -2.0, -0.4], [-1.2, 1.4, -2.6, 0.2], [2.0, 0.1, 0.5, -1.0]] {
        let mut transform = Matrix4::identity();
        let mut revolute = 0;
        for (kind, origin) in &joints {
            transform *= origin;
            if kind == "revolute" {
                let mut turn = Matrix4::identity();
                turn.fixed_view_mut::<3, 3>(0, 0)
                    .copy_from(Rotation3::from_axis_angle(&Vector3::z_axis(), q[revolute]).matrix());
                transform *= turn;
                revolute += 1;
            }
        }
        let tool = FrameChain::new(&model, &JointVector::<4>::from(q)).body_pose(3).to_homogeneous();
        assert!((transform - tool).abs().max() < 1e-12, "URDF tool pose differs from FK at {q:?}");
    }
}

#[test]
fn plan_writes_the_report_files_whole() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("plan");
    let out_text = out.display().to_string();
    let summary = json_of(&chessarm(&["plan", "--scenario", "queens-gambit", "--out", &out_text, "--xlsx"]));
    assert_eq!(summary["samples"].as_u64(), Some(2601));
    assert!((summary["duration_s"].as_f64().unwrap() - 13.0).abs() < 1e-12);
    let mut names = common::file_names(&out);
    // The results, the list of what chessarm wrote there and the folder's lock.
    assert_eq!(
        names,
        [
            ".chessarm-lock",
            ".chessarm-written",
            "cartesian.csv",
            "cartesian.png",
            "hardware",
            "joint.csv",
            "joint.png",
            "joint.xlsx"
        ],
        "stray files"
    );
    // The folder of trajectories for hardware keeps its own list.
    names.retain(|name| name != "hardware" && name != ".chessarm-lock");
    let mut listed: Vec<String> =
        std::fs::read_to_string(out.join(".chessarm-written")).unwrap().lines().map(String::from).collect();
    listed.sort();
    assert_eq!(listed, names[1..]);

    let mut cartesian = csv::Reader::from_path(out.join("cartesian.csv")).unwrap();
    assert_eq!(
        cartesian.headers().unwrap().iter().collect::<Vec<_>>(),
        ["t", "x", "y", "z", "vx", "vy", "vz", "ax", "ay", "az"]
    );
    let rows: Vec<Vec<f64>> =
        cartesian.records().map(|r| r.unwrap().iter().map(|v| v.parse().unwrap()).collect()).collect();
    assert_eq!(rows.len(), 2601);
    for (got, want) in rows[1200][..4].iter().zip([6.0, -0.03, 0.18, 0.05]) {
        assert!((got - want).abs() < 1e-12, "{:?}", &rows[1200]);
    }

    let mut joint = csv::Reader::from_path(out.join("joint.csv")).unwrap();
    let header: Vec<String> = joint.headers().unwrap().iter().map(String::from).collect();
    assert_eq!(header.len(), 13);
    assert_eq!(header[0], "t");
    assert_eq!(header[12], "qdd_des4");
    // Every joint row maps back onto the Cartesian row by forward kinematics.
    for (record, cartesian_row) in joint.records().zip(&rows).step_by(50) {
        let values: Vec<f64> = record.unwrap().iter().map(|v| v.parse().unwrap()).collect();
        let tip = report_arm_tip(&values[1..5]);
        assert!((tip - Vector3::new(cartesian_row[1], cartesian_row[2], cartesian_row[3])).norm() < 1e-9);
    }
    for png in ["cartesian.png", "joint.png"] {
        let bytes = std::fs::read(out.join(png)).unwrap();
        assert_eq!(&bytes[1..4], b"PNG");
        assert!(bytes.len() > 20_000, "{png} is nearly empty");
    }
    let xlsx = std::fs::read(out.join("joint.xlsx")).unwrap();
    assert_eq!(&xlsx[..2], b"PK");
}

#[test]
fn plan_into_an_unwritable_place_fails_cleanly() {
    let dir = tempfile::tempdir().unwrap();
    let blocker = dir.path().join("file");
    std::fs::write(&blocker, "not a folder").unwrap();
    let out = blocker.join("plan").display().to_string();
    assert_one_line_error(&chessarm(&["plan", "--out", &out]), &["output folder"]);
}

#[test]
fn every_urdf_link_has_a_body_that_a_real_parser_reads() {
    let urdf = String::from_utf8(chessarm(&["urdf"]).stdout).unwrap();
    let robot = urdf_rs::read_from_string(&urdf).unwrap();
    let names: Vec<&str> = robot.links.iter().map(|l| l.name.as_str()).collect();
    assert_eq!(names, ["base_link", "link1", "link2", "link3", "link4", "tool"]);
    let model = report_arm();
    let palm = chessarm_core::arm::bodies::Gripper::default().palm_depth();
    for link in &robot.links {
        // The tool's sphere is a marker to see, not a solid.
        if link.name == "tool" {
            assert!(link.visual.len() == 1 && link.collision.is_empty(), "tool");
            continue;
        }
        assert!(!link.visual.is_empty() && link.visual.len() == link.collision.len(), "{}", link.name);
        for (visual, collision) in link.visual.iter().zip(&link.collision) {
            assert_eq!(format!("{:?}", visual.geometry), format!("{:?}", collision.geometry), "{}", link.name);
        }
        // Link i's long cylinder runs from its joint to the next: √(aᵢ² + dᵢ²) long; the
        // last one to the gripper's palm, `palm_depth` short of the tip along x₄.
        if let Some(i) = link.name.strip_prefix("link").and_then(|n| n.parse::<usize>().ok()) {
            let dh = model.link(i - 1).dh;
            let expected = if i == 4 { (dh.a - palm).hypot(dh.d) } else { dh.a.hypot(dh.d) };
            let lengths: Vec<f64> = link
                .visual
                .iter()
                .filter_map(|v| match v.geometry {
                    urdf_rs::Geometry::Cylinder { radius, length } if radius < 0.02 => Some(length),
                    _ => None,
                })
                .collect();
            if expected > 1e-9 {
                assert_eq!(lengths.len(), 1, "{}", link.name);
                assert!((lengths[0] - expected).abs() < 1e-12, "{}: {} against {expected}", link.name, lengths[0]);
            }
        }
    }
    // The tool keeps a (tiny) mass and a marker so that importers do not drop it, and no
    // number in the file is a negative zero.
    let tool = robot.links.iter().find(|l| l.name == "tool").unwrap();
    assert!(tool.inertial.mass.value > 0.0 && tool.inertial.mass.value < 1e-6);
    assert!(!urdf.contains(" -0 ") && !urdf.contains("\"-0 ") && !urdf.contains(" -0\""));
    assert_eq!(robot.joints.len(), 5);
}

#[test]
#[cfg_attr(not(tool_python), ignore = "needs CHESSARM_PYTHON, a Python with mujoco; see docs/testing.md")]
fn mujoco_reads_the_urdf_with_its_bodies_and_the_same_kinematics_and_dynamics() {
    let python = common::python_with_mujoco().expect("CHESSARM_PYTHON (or python3) with mujoco installed");
    let script = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/mujoco/check_urdf.py");
    let output = std::process::Command::new(&python).arg(&script).arg(env!("CARGO_BIN_EXE_chessarm")).output().unwrap();
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let report: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
    eprintln!("mujoco: {report}");
    // MuJoCo keeps the tool as a body of its own (not fused into link4) and every body has
    // its visual and collision geometry (the tool only its marker to see).
    let bodies: Vec<&str> = report["bodies"].as_array().unwrap().iter().map(|b| b.as_str().unwrap()).collect();
    assert_eq!(bodies, ["world", "base_link", "link1", "link2", "link3", "link4", "tool"]);
    for body in &bodies[1..] {
        let least = if *body == "tool" { 1 } else { 2 };
        assert!(
            report["geoms_per_body"][body].as_i64().unwrap() >= least,
            "{body} has no geometry in MuJoCo: {report}"
        );
    }
    assert_eq!(report["njnt"], 4);
    assert_eq!(common::numbers(&report["gravity"]), [0.0, 0.0, -9.8]);
    // FK and the dynamics agree: the URDF's numbers are written in full (shortest round-trip
    // decimals), so only the Euler-angle conversions round (≈1e-16 rad); the tool's trace of
    // mass (1e-9 kg at < 1 m) changes M by < 1e-9 kg·m² and g by < 1e-8 N·m.
    let worst = &report["worst"];
    assert!(worst["tool_m"].as_f64().unwrap() < 1e-9, "{report}");
    assert!(worst["mass_matrix"].as_f64().unwrap() < 1e-8, "{report}");
    assert!(worst["gravity_nm"].as_f64().unwrap() < 2e-8, "{report}");
}
