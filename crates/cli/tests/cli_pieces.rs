//! Pieces with a profile from the setup file: read, written back, refused when they are no
//! outline, and played: a Staunton set plays the Opera game as the cylinders of their bases do,
//! with room where the profile narrows.

#![allow(clippy::unwrap_used)]

mod common;

use common::{OPERA, assert_one_line_error, chessarm, chessarm_human, play_game};

/// A king and a knight of a Staunton set (fractions of the height and the base diameter).
const STAUNTON: &str = "[pieces.king]\n\
    outline = [[0, 1], [0.08, 1], [0.13, 0.72], [0.22, 0.5], [0.58, 0.34], [0.62, 0.64], [0.66, 0.64], \
    [0.7, 0.38], [0.82, 0.6], [0.86, 0.6], [0.88, 0.26], [1, 0.26]]\n\
    [pieces.queen]\n\
    outline = [[0, 1], [0.08, 1], [0.14, 0.72], [0.24, 0.5], [0.58, 0.34], [0.62, 0.64], [0.66, 0.64], \
    [0.7, 0.38], [0.84, 0.64], [0.9, 0.64], [0.94, 0.3], [1, 0.22]]\n\
    [pieces.knight]\n\
    outline = [[0, 1], [0.1, 1], [0.16, 0.74], [0.28, 0.58], [0.42, 0.56]]\n\
    head_block = [1.0, 0.78, 0.36]\n";

/// The profile is read and written back by `chessarm arm` (only where it is not the default
/// cylinder), and the file written reads back the same.
#[test]
fn a_profile_in_the_setup_file_is_read_and_written_back() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("staunton.toml");
    std::fs::write(&file, STAUNTON).unwrap();
    let printed = chessarm_human(&["--arm", file.to_str().unwrap(), "arm"]);
    assert!(printed.status.success(), "{}", String::from_utf8_lossy(&printed.stderr));
    let text = String::from_utf8(printed.stdout).unwrap();
    let value: toml::Value = toml::from_str(&text).unwrap();
    let king = &value["pieces"]["king"];
    assert_eq!(king["outline"].as_array().unwrap().len(), 12, "{text}");
    assert_eq!(value["pieces"]["knight"]["head_block"].as_array().unwrap().len(), 3, "{text}");
    assert!(value["pieces"]["pawn"].get("outline").is_none(), "the pawn is the default cylinder: {text}");
    let again = dir.path().join("again.toml");
    std::fs::write(&again, &text).unwrap();
    let reprinted = chessarm_human(&["--arm", again.to_str().unwrap(), "arm"]);
    assert_eq!(String::from_utf8(reprinted.stdout).unwrap(), text);
}

/// Rings that are no outline, a profile wider than its base or not reaching the top, and a head
/// block of the wrong length: one line naming the field, exit 2.
#[test]
fn a_profile_that_is_no_outline_is_refused_naming_the_field() {
    let dir = tempfile::tempdir().unwrap();
    for (toml, needles) in [
        ("[pieces.rook]\noutline = [[0.1, 1], [1, 1]]\n", &["pieces.rook.outline", "not at the base"][..]),
        (
            "[pieces.rook]\noutline = [[0, 1], [0.5, 1.2], [1, 1]]\n",
            &["pieces.rook.outline", "wider than the base"][..],
        ),
        ("[pieces.rook]\noutline = [[0, 1], [0.5, 1]]\n", &["pieces.rook.outline", "top must be at 1"][..]),
        (
            "[pieces.rook]\noutline = [[0, 1], [0.6, 1], [0.5, 1], [1, 1]]\n",
            &["pieces.rook.outline", "below the ring before"][..],
        ),
        ("[pieces.rook]\noutline = [[0, 0], [1, 0]]\n", &["pieces.rook.outline", "no volume"][..]),
        ("[pieces.knight]\nhead_block = [1.0, 0.78]\n", &["pieces.knight.head_block", "[top, length, width]"][..]),
    ] {
        let file = dir.path().join("bad.toml");
        std::fs::write(&file, toml).unwrap();
        assert_one_line_error(&chessarm(&["--arm", file.to_str().unwrap(), "arm"]), needles);
    }
}

/// The Opera game with Staunton kings, queens and knights: every piece in place, no contact,
/// and no nearer than with the cylinders of their bases (the profile only takes room away).
#[test]
fn a_staunton_set_plays_the_opera_game_with_room_to_spare() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("staunton.toml");
    std::fs::write(&file, STAUNTON).unwrap();
    let cylinders = play_game(&dir.path().join("cylinders"), &[OPERA]);
    let staunton = play_game(&dir.path().join("staunton"), &["--arm", file.to_str().unwrap(), OPERA]);
    for game in [&cylinders, &staunton] {
        assert_eq!(game["misplaced"].as_array().unwrap().len(), 0);
        assert_eq!(game["clearance"]["contacts"], 0);
    }
    let smallest = |game: &serde_json::Value| game["clearance"]["smallest_mm"].as_f64().unwrap();
    assert!(
        smallest(&staunton) >= smallest(&cylinders) - 1e-9,
        "{} against {}",
        smallest(&staunton),
        smallest(&cylinders)
    );
}
