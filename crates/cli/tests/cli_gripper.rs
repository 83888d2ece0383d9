//! The gripper a URDF describes: the SO-101's file (`tests/fixtures/real-arms`) with its
//! `<collision>` meshes replaced by boxes where its parts are (the meshes are not in the
//! repository): the gripper's servo and its fixed jaw on `gripper_link`, the moving jaw on its
//! revolute joint. The fixed jaw is told from the servo, and is kept apart from the piece it
//! grips as chessarm's fingers are, while the rest of the arm keeps the clearance margin.

#![allow(clippy::unwrap_used)]

mod common;

use chessarm::app::setup::urdf_import::{ImportOptions, from_urdf};
use chessarm_core::arm::bodies::{Bodies, Gripper, Hand, Mount, Part, Solid, solids_into};
use chessarm_core::nalgebra::Vector4;
use common::{chessarm, json_file, json_of};
use std::path::Path;

fn so101() -> String {
    fixture("so101_new_calib")
}

fn fixture(name: &str) -> String {
    std::fs::read_to_string(Path::new(common::REAL_ARMS).join(format!("{name}.urdf"))).unwrap()
}

/// The SO-101's file with every `<collision>` taken out and `shapes` (link, `<collision>`
/// elements) put in.
fn with_shapes(shapes: &[(&str, String)]) -> String {
    shapes_in(so101(), shapes)
}

/// `text` with every `<collision>` taken out and `shapes` (link, `<collision>` elements) put in.
fn shapes_in(mut text: String, shapes: &[(&str, String)]) -> String {
    while let Some(start) = text.find("<collision>") {
        let end = text[start..].find("</collision>").unwrap() + start + "</collision>".len();
        text.replace_range(start..end, "");
    }
    for (link, elements) in shapes {
        let at = text.find(&format!("<link name=\"{link}\">")).unwrap();
        let close = text[at..].find("</link>").unwrap() + at;
        text.insert_str(close, elements);
    }
    text
}

fn collision_box(xyz: [f64; 3], size: [f64; 3]) -> String {
    format!(
        "<collision><origin xyz=\"{} {} {}\" rpy=\"0 0 0\"/><geometry><box size=\"{} {} {}\"/></geometry></collision>",
        xyz[0], xyz[1], xyz[2], size[0], size[1], size[2]
    )
}

/// The gripper's servo where the file's mesh has it, the moving jaw, and a fixed jaw 0.5 mm
/// thick whose inner face is `face` m along `gripper_link`'s x (the file's tool point is at
/// x = −7.9 mm, on its own fixed jaw's face), reaching from 18 mm above the tool point to 2 mm
/// below it (as the needle fingers do).
fn gripper(face: f64) -> String {
    with_shapes(&[
        (
            "gripper_link",
            collision_box([0.0077, 0.0001, -0.0234], [0.045, 0.025, 0.025])
                + &collision_box([face - 0.00025, 0.0, -0.0901], [0.0005, 0.005, 0.02]),
        ),
        ("moving_jaw_so101_v1_link", collision_box([0.0, -0.05, 0.0189], [0.01, 0.05, 0.01])),
    ])
}

fn wrist_roll_locked() -> ImportOptions {
    ImportOptions { locks: vec![("wrist_roll".into(), 0.0)], ..ImportOptions::default() }
}

/// The board `board --fit` gives the PincherX-100 as published with the needle fingers: its
/// JSON, and its setup file written into `dir`.
fn fitted_px100(dir: &Path) -> (serde_json::Value, std::path::PathBuf) {
    let plain = Path::new(common::REAL_ARMS).join("px100.urdf");
    let fit =
        json_of(&chessarm(&["--urdf", plain.to_str().unwrap(), "--arm", common::NEEDLE_FINGERS, "board", "--fit"]));
    let setup_path = dir.join("board.toml");
    std::fs::write(&setup_path, fit["setup"].as_str().unwrap()).unwrap();
    (fit, setup_path)
}

/// The shapes reaching down beside the grip are the fixed jaw; the servo above is not; the
/// moving jaw's link is left to the fingers. The note says which link holds the jaw.
#[test]
fn the_fixed_jaw_is_told_from_the_gripper_servo() {
    let imported = from_urdf(&gripper(-0.0137), &wrist_roll_locked()).unwrap();
    let Bodies::Described(shapes) = &imported.bodies else { panic!("{:?}", imported.bodies) };
    assert_eq!(shapes.len(), 2, "{shapes:?}");
    let jaws: Vec<bool> = shapes.iter().map(|s| s.mount == Mount::Jaw).collect();
    assert_eq!(jaws, [false, true], "the servo, then the jaw: {shapes:?}");
    assert!(shapes.iter().all(|s| s.body == 4));
    let notes = imported.notes.join("\n");
    assert!(notes.contains("'gripper_link' that reach down beside the grip are the gripper's fixed jaw"), "{notes}");
    assert!(notes.contains("'moving_jaw_so101_v1_link' left out"), "{notes}");
    // Its face is 5.8 mm from the tool point: nothing said; the file's own jaw's face is on it.
    assert!(!imported.warnings.iter().any(|w| w.contains("fixed jaw")), "{:?}", imported.warnings);
    let on_face = from_urdf(&gripper(-0.0079), &wrist_roll_locked()).unwrap();
    let warned = on_face.warnings.join("\n");
    assert!(warned.contains("the tool point is 0 mm from the gripper's fixed jaw (on 'gripper_link')"), "{warned}");
    assert!(warned.contains("--tool-offset"), "{warned}");
    // A file whose gripper has no shape reaching down beside the grip has no jaw.
    let high = with_shapes(&[("gripper_link", collision_box([0.0077, 0.0001, -0.0234], [0.045, 0.025, 0.025]))]);
    let imported = from_urdf(&high, &wrist_roll_locked()).unwrap();
    let Bodies::Described(shapes) = &imported.bodies else { panic!() };
    assert!(shapes.iter().all(|s| s.mount == Mount::Fixed), "{shapes:?}");
}

/// A fixed jaw 0.8 mm beside the king it grips (less than the 1 mm the arm keeps from
/// everything, more than a contact) does not stop the game: its gap is the gripper's, as the
/// fingers' is (the king's move reports it), while it keeps the margin from every other piece.
/// (Counted as an obstacle to the king, as a link's shape is, the jaw would be 0.8 mm from it,
/// under the 1 mm margin: the move refused.)
#[test]
fn a_fixed_jaw_beside_the_piece_it_grips_is_kept_apart_from_it_as_a_finger() {
    let dir = tempfile::tempdir().unwrap();
    let plain = Path::new(common::REAL_ARMS).join("so101_new_calib.urdf");
    let fit = json_of(&chessarm(&[
        "--urdf",
        plain.to_str().unwrap(),
        "--lock",
        "wrist_roll=0",
        "--arm",
        common::NEEDLE_FINGERS,
        "board",
        "--fit",
    ]));
    // Slim pieces, so that the jaw beside the widest keeps clear of its neighbours on every
    // square and slot: 6 mm across, the pawns 5 mm.
    let mut setup: toml::Value = toml::from_str(fit["setup"].as_str().unwrap()).unwrap();
    for kind in ["pawn", "knight", "bishop", "rook", "queen", "king"] {
        let width = if kind == "pawn" { 0.005 } else { 0.006 };
        setup["pieces"][kind]["base_diameter"] = toml::Value::Float(width);
    }
    let king_radius = 0.003;
    let setup_path = dir.path().join("board.toml");
    std::fs::write(&setup_path, toml::to_string(&setup).unwrap()).unwrap();
    // The file's tool point is on gripper_link's x = −7.9 mm; the jaw's face 0.8 mm beyond the
    // king's side, away from the moving jaw.
    let urdf = dir.path().join("so101-jaw.urdf");
    std::fs::write(&urdf, gripper(-0.0079 - king_radius - 0.0008)).unwrap();
    let out = dir.path().join("game");
    let played = chessarm(&[
        "--urdf",
        urdf.to_str().unwrap(),
        "--arm",
        setup_path.to_str().unwrap(),
        "play",
        "--moves",
        "e4 e5 Ke2",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(played.status.success(), "{}", String::from_utf8_lossy(&played.stderr));
    let game = json_file(&out.join("game.json"));
    assert_eq!(game["complete"], true, "{game}");
    assert_eq!(game["clearance"]["contacts"], 0, "{}", game["clearance"]);
    let moves = game["moves"].as_array().unwrap();
    assert_eq!(moves.len(), 3);
    for m in moves {
        let clearance = &m["clearance"];
        // Everything but the gripped piece keeps the margin (1 mm with the needle fingers).
        assert!(clearance["smallest_mm"].as_f64().unwrap() >= 1.0, "{clearance}");
        assert_eq!(clearance["executed"]["contact"], false, "{clearance}");
    }
    // The king's move: the jaw's gap to the king is the gripper's, below the margin and above
    // a contact (the path tilts the jaw a little toward it).
    let king = &moves[2]["clearance"];
    let gap = king["fingers_to_gripped_piece_mm"].as_f64().unwrap();
    assert!((0.5..0.8 + 1e-6).contains(&gap), "{king}");
    // The pawns are 1 mm narrower: the jaw is 1.3 mm beside them (the needle fingers 1.5 mm).
    for pawn in &moves[..2] {
        let gap = pawn["clearance"]["fingers_to_gripped_piece_mm"].as_f64().unwrap();
        assert!((1.0..1.3 + 1e-6).contains(&gap), "{pawn}");
    }
}

/// The file's fingers on prismatic joints (the OpenManipulator-X's two, the second a `<mimic>`
/// follower; the PincherX-100's, whose follower's multiplier is −1 and whose joints are held at
/// their closing limit) stand in for chessarm's, and slide with the hand's gap: each finger a
/// box 8 mm thick whose inner face is level with the tool tip, so with the gap `g` the boxes'
/// centres stand `g / 2 + 4 mm` from the tip across the approach, within the joint's range
/// (closed as far as it goes below it: the OpenManipulator-X's fingers close to 20 mm, the
/// PincherX-100's to 14 mm).
#[test]
fn the_files_prismatic_fingers_slide_to_the_gap() {
    // (file, the two finger links, each box's centre in its link's frame, the smallest gap)
    let arms = [
        (
            "open_manipulator_x",
            ["gripper_left_link", "gripper_right_link"],
            [[0.126 - 0.0817, 0.004, 0.0], [0.126 - 0.0817, -0.004, 0.0]],
            0.020,
        ),
        (
            "px100",
            ["px100/left_finger_link", "px100/right_finger_link"],
            [[0.027575, -0.004, 0.0], [0.027575, 0.004, 0.0]],
            0.014,
        ),
    ];
    for (name, links, centres, closed) in arms {
        let shapes: Vec<(&str, String)> =
            links.iter().zip(centres).map(|(link, c)| (*link, collision_box(c, [0.01, 0.008, 0.02]))).collect();
        let imported = from_urdf(&shapes_in(fixture(name), &shapes), &ImportOptions::default()).unwrap();
        let Bodies::Described(described) = &imported.bodies else { panic!("{name}: {:?}", imported.bodies) };
        assert_eq!(described.len(), 2, "{name}: {described:?}");
        assert!(described.iter().all(|s| matches!(s.mount, Mount::Finger(_))), "{name}");
        let notes = imported.notes.join("\n");
        assert!(notes.contains("the fingers are the file's"), "{name}: {notes}");
        let q = Vector4::new(0.2, 0.3, -0.5, 0.4);
        let mut solids = Vec::new();
        for gap in [0.03, 0.05, 0.005] {
            let hand = Hand { gripper: Gripper::default(), gap, held: None };
            solids_into(&imported.model, &q, &hand, &imported.bodies, &mut solids);
            let fingers: Vec<&Solid> =
                solids.iter().filter(|s| matches!(s.part, Part::Finger(_))).map(|s| &s.solid).collect();
            assert_eq!(fingers.len(), 2, "{name}: only the file's fingers");
            let chain = chessarm_core::arm::kinematics::FrameChain::new(&imported.model, &q);
            let tip = chain.tip();
            let expected = 0.5 * gap.max(closed) + 0.004;
            for finger in fingers {
                let Solid::Cuboid { centre, .. } = finger else { panic!("{finger:?}") };
                let off = (centre - tip).norm();
                assert!((off - expected).abs() < 1e-9, "{name} gap {gap}: {off} vs {expected}");
            }
        }
    }
}

/// The hardware export drives the file's fingers: the PincherX-100's, boxes 1.5 mm thick
/// whose inner faces are 13.5 mm inside their links' origins, open around the fitted board's
/// pawn by the needle fingers' 1.5 mm a side (`left_finger` at its half width + 1.5 + 13.5 mm)
/// and closed on it (its half width + 13.5 mm), `right_finger` following by its
/// `<mimic multiplier="-1">`.
#[test]
fn the_hardware_export_commands_the_files_gripper_joint_from_the_pieces_width() {
    let dir = tempfile::tempdir().unwrap();
    let (fit, setup_path) = fitted_px100(dir.path());
    let setup: toml::Value = toml::from_str(fit["setup"].as_str().unwrap()).unwrap();
    let width = setup["pieces"]["pawn"]["base_diameter"].as_float().unwrap();
    let shapes = [
        ("px100/left_finger_link", collision_box([0.027575, -0.01275, 0.0], [0.01, 0.0015, 0.005])),
        ("px100/right_finger_link", collision_box([0.027575, 0.01275, 0.0], [0.01, 0.0015, 0.005])),
    ];
    let urdf = dir.path().join("px100-fingers.urdf");
    std::fs::write(&urdf, shapes_in(fixture("px100"), &shapes)).unwrap();
    let out = dir.path().join("plan");
    let planned = chessarm(&[
        "--urdf",
        urdf.to_str().unwrap(),
        "--arm",
        setup_path.to_str().unwrap(),
        "plan",
        "--moves",
        "e4",
        "--export-rate",
        "20",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(planned.status.success(), "{}", String::from_utf8_lossy(&planned.stderr));
    let text = std::fs::read_to_string(out.join("hardware/001-e2e4.csv")).unwrap();
    let mut rows = text.lines();
    let header: Vec<&str> = rows.next().unwrap().split(',').collect();
    let column = |name: &str| header.iter().position(|h| *h == name).unwrap_or_else(|| panic!("{name}: {header:?}"));
    let (left, right, state) = (column("q_left_finger"), column("q_right_finger"), column("gripper"));
    let (open, closed) = (0.5 * width + 0.0015 + 0.0135, 0.5 * width + 0.0135);
    let mut seen = [false; 2];
    for row in rows {
        let cells: Vec<&str> = row.split(',').collect();
        let value: f64 = cells[left].parse().unwrap();
        let expected = if cells[state] == "closed" { closed } else { open };
        seen[usize::from(cells[state] == "closed")] = true;
        assert!((value - expected).abs() < 1e-9, "{row}: {value} vs {expected}");
        assert_eq!(cells[right].parse::<f64>().unwrap(), -value, "{row}");
    }
    assert_eq!(seen, [true, true]);
}

/// A piece narrower than the file's fingers close is refused before a game starts, naming the
/// piece and both widths (the PincherX-100's boxes close to 14 mm; the fitted board's pawn is
/// half that).
#[test]
fn a_piece_the_files_fingers_do_not_close_on_is_refused_before_the_game() {
    let dir = tempfile::tempdir().unwrap();
    let (_, setup_path) = fitted_px100(dir.path());
    let shapes = [
        ("px100/left_finger_link", collision_box([0.027575, -0.004, 0.0], [0.01, 0.008, 0.02])),
        ("px100/right_finger_link", collision_box([0.027575, 0.004, 0.0], [0.01, 0.008, 0.02])),
    ];
    let urdf = dir.path().join("px100-fingers.urdf");
    std::fs::write(&urdf, shapes_in(fixture("px100"), &shapes)).unwrap();
    let out = dir.path().join("game");
    let refused = chessarm(&[
        "--urdf",
        urdf.to_str().unwrap(),
        "--arm",
        setup_path.to_str().unwrap(),
        "play",
        "--moves",
        "e4",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(!refused.status.success());
    let said = String::from_utf8_lossy(&refused.stderr);
    assert!(said.contains("the file's fingers close no narrower than 14.0 mm"), "{said}");
    assert!(said.contains("mm across would not be held where it is gripped ([pieces.pawn] base_diameter"), "{said}");
    assert!(!out.join("game.json").exists(), "nothing ran");
}

/// `board` says what squares the file's fingers need: the PincherX-100's boxes, 8 mm thick and
/// 20 mm wide across the tool tip, closing to 14 mm and opening to 58 mm, need the squares
/// chessarm's own fingers of that thickness and width need (the same check of the neighbours).
#[test]
fn board_says_what_squares_the_files_fingers_need() {
    let dir = tempfile::tempdir().unwrap();
    let (_, setup_path) = fitted_px100(dir.path());
    let plain = Path::new(common::REAL_ARMS).join("px100.urdf");
    let shapes = [
        ("px100/left_finger_link", collision_box([0.027575, -0.004, 0.0], [0.01, 0.008, 0.02])),
        ("px100/right_finger_link", collision_box([0.027575, 0.004, 0.0], [0.01, 0.008, 0.02])),
    ];
    let urdf = dir.path().join("px100-fingers.urdf");
    std::fs::write(&urdf, shapes_in(fixture("px100"), &shapes)).unwrap();
    let setup = setup_path.to_str().unwrap();
    let said = common::chessarm_human(&["--urdf", urdf.to_str().unwrap(), "--arm", setup, "board"]);
    let text = String::from_utf8_lossy(&said.stdout);
    assert!(
        text.contains("the file's fingers (8.0 mm thick, 20.0 mm wide across the tool tip, closing to 14.0 mm, opening to 58.0 mm)"),
        "{text}"
    );
    let needed = |output: &std::process::Output| {
        let text = String::from_utf8_lossy(&output.stdout).to_string();
        let at = text.find("squares of at least ").unwrap() + "squares of at least ".len();
        text[at..].split(' ').next().unwrap().parse::<f64>().unwrap()
    };
    // chessarm's fingers of the same section on the file without its shapes.
    let boxes = dir.path().join("boxes.toml");
    let mut table: toml::Value = toml::from_str(&std::fs::read_to_string(&setup_path).unwrap()).unwrap();
    table["gripper"]["finger_thickness"] = toml::Value::Float(0.008);
    table["gripper"]["finger_width"] = toml::Value::Float(0.02);
    std::fs::write(&boxes, toml::to_string(&table).unwrap()).unwrap();
    let own = common::chessarm_human(&["--urdf", plain.to_str().unwrap(), "--arm", boxes.to_str().unwrap(), "board"]);
    assert!(String::from_utf8_lossy(&own.stdout).contains("fingers: squares of at least"));
    assert_eq!(needed(&said), needed(&own));
    assert!(needed(&said) > 30.0, "{text}");
}

/// A game with the file's fingers: the PincherX-100's as needles (1.5 mm thick, 5 mm wide,
/// closing to 3 mm) on its fitted board play the first moves with each finger 1.5 mm off the
/// piece it opens around ([gripper] finger_opening), as chessarm's needle fingers do, and touch
/// nothing.
#[test]
fn the_files_fingers_open_around_each_piece_by_the_opening_and_touch_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let (_, setup_path) = fitted_px100(dir.path());
    // Inner faces 13.5 mm inside the links' origins: at the closing limit (15 mm) 1.5 mm off
    // the tool's axis.
    let shapes = [
        ("px100/left_finger_link", collision_box([0.027575, -0.01275, 0.0], [0.01, 0.0015, 0.005])),
        ("px100/right_finger_link", collision_box([0.027575, 0.01275, 0.0], [0.01, 0.0015, 0.005])),
    ];
    let urdf = dir.path().join("px100-needles.urdf");
    std::fs::write(&urdf, shapes_in(fixture("px100"), &shapes)).unwrap();
    let out = dir.path().join("game");
    let args =
        ["--urdf", urdf.to_str().unwrap(), "--arm", setup_path.to_str().unwrap(), "play", "--moves", "e4 e5 Nf3 Nc6"];
    let played = chessarm(&[&args[..], &["--out", out.to_str().unwrap()]].concat());
    assert!(played.status.success(), "{}", String::from_utf8_lossy(&played.stderr));
    let game = json_file(&out.join("game.json"));
    assert_eq!(game["complete"], true);
    assert_eq!(game["clearance"]["contacts"], 0, "{}", game["clearance"]);
    for m in game["moves"].as_array().unwrap() {
        let clearance = &m["clearance"];
        let gap = clearance["fingers_to_gripped_piece_mm"].as_f64().unwrap();
        // The gap the plan keeps is the opening (held at the closing limit, the fingers would
        // stand inside the pawn).
        assert!((gap - 1.5).abs() < 0.01, "{clearance}");
        assert_eq!(clearance["executed"]["contact"], false, "{clearance}");
        assert!(clearance["smallest_mm"].as_f64().unwrap() >= 1.0, "{clearance}");
    }
}
