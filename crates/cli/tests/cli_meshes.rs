//! A URDF's `<collision>` meshes: a mesh with more vertices than chessarm takes a hull of is
//! stood in for by a bounded grid of points whose hull holds it (said in a warning), a smaller
//! one is hulled over its own vertices as before, and a mesh that overflows, is too small or
//! whose vertices all coincide is refused in one line naming the file and the value.

#![allow(clippy::unwrap_used)] // tests

mod common;

use chessarm_core::nalgebra::Vector3;
use common::{assert_one_line_error, chessarm};
use std::path::{Path, PathBuf};

use common::OFFSET_ARM as FIXTURE;

/// Binary STL of `triangles`.
fn binary_stl(triangles: &[[[f32; 3]; 3]]) -> Vec<u8> {
    let mut bytes = vec![0u8; 80];
    bytes.extend((triangles.len() as u32).to_le_bytes());
    for t in triangles {
        bytes.extend([0u8; 12]);
        for v in t {
            for c in v {
                bytes.extend(c.to_le_bytes());
            }
        }
        bytes.extend([0u8; 2]);
    }
    bytes
}

/// A UV sphere's triangles: `rings` × `segments` quads, two triangles each (the poles'
/// degenerate ones kept, as exporters write them), the ellipsoid of half axes `half`.
fn uv_sphere(rings: usize, segments: usize, half: [f32; 3]) -> Vec<[[f32; 3]; 3]> {
    let point = |r: usize, s: usize| {
        let (theta, phi) = (
            std::f32::consts::PI * r as f32 / rings as f32,
            std::f32::consts::TAU * (s % segments) as f32 / segments as f32,
        );
        [half[0] * theta.sin() * phi.cos(), half[1] * theta.sin() * phi.sin(), half[2] * theta.cos()]
    };
    let mut out = Vec::with_capacity(2 * rings * segments);
    for r in 0..rings {
        for s in 0..segments {
            let (a, b, c, d) = (point(r, s), point(r + 1, s), point(r + 1, s + 1), point(r, s + 1));
            out.push([a, b, c]);
            out.push([a, c, d]);
        }
    }
    out
}

/// The fixture arm with the STL `mesh` as the forearm's collision shape at `scale` (as typed),
/// written to `dir`; the URDF's path and the mesh's.
fn arm_with_mesh(dir: &Path, mesh: &[u8], scale: &str) -> (PathBuf, PathBuf) {
    let stl = dir.join("forearm.stl");
    std::fs::write(&stl, mesh).unwrap();
    let shape =
        format!(r#"<collision><geometry><mesh filename="forearm.stl" scale="{scale}"/></geometry></collision>"#);
    let text = std::fs::read_to_string(FIXTURE)
        .unwrap()
        .replace("<link name=\"forearm\">", &format!("<link name=\"forearm\">\n    {shape}"));
    let urdf = dir.join("arm.urdf");
    std::fs::write(&urdf, text).unwrap();
    (urdf, stl)
}

fn fk(urdf: &Path) -> std::process::Output {
    chessarm(&["--urdf", urdf.to_str().unwrap(), "fk", "--q", "0,0,0,0"])
}

/// No library words in a message (parry's error names, Rust's Debug dumps).
fn in_users_words(output: &std::process::Output) {
    let stderr = String::from_utf8_lossy(&output.stderr);
    for jargon in ["IncompleteInput", "MissingSupportPoint", "Err(", "{ "] {
        assert!(!stderr.contains(jargon), "'{jargon}' in: {stderr}");
    }
}

/// The largest of `p · d` over `points`.
fn support(points: &[Vector3<f64>], d: &Vector3<f64>) -> f64 {
    points.iter().map(|p| p.dot(d)).fold(f64::NEG_INFINITY, f64::max)
}

/// A 100 000-triangle ellipsoid (about 50 000 distinct vertices, over the 40 000 chessarm takes a
/// hull of) is stood in for by at most `2 (COLUMNS + 1)²` points; their hull holds every vertex
/// (in each of 400 directions its extent reaches at least the vertices': conservative) and
/// reaches at most the said distance beyond them; the warning names the file, the vertex
/// count and the points kept.
#[test]
fn a_large_mesh_is_hulled_over_a_bounded_grid_that_holds_it() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = binary_stl(&uv_sphere(250, 200, [90.0, 20.0, 16.0]));
    let (urdf, stl) = arm_with_mesh(dir.path(), &mesh, "0.001 0.001 0.001");
    let read = chessarm::app::setup::meshes::read_stl(&stl, [0.001; 3], "0.001 0.001 0.001").unwrap();
    let (vertices, kept, within) = read.decimated.expect("decimated");
    let raw: Vec<Vector3<f64>> =
        chessarm::app::setup::meshes::parse_stl(&mesh).unwrap().iter().map(|p| p * 0.001).collect();
    let mut distinct: Vec<[u64; 3]> = raw.iter().map(|p| p.map(|c| (c + 0.0).to_bits()).into()).collect();
    distinct.sort_unstable();
    distinct.dedup();
    assert_eq!(vertices, distinct.len());
    assert!(vertices > chessarm::app::setup::meshes::MAX_HULL_INPUT, "{vertices}");
    assert_eq!(kept, read.points.len());
    let bound = 2 * (chessarm::app::setup::meshes::COLUMNS + 1).pow(2);
    assert!(kept <= bound, "{kept} points handed to the hull, more than {bound}");
    // The columns run along the 0.18 m axis, 64 of them across the 0.04 m one: 0.625 mm
    // square, so a point is at most 0.88 mm from the vertex whose height it took. Tolerance
    // 1e-10 m: the vertices are f32, 40 mm to 6e-8 of itself (2.4e-9 m), over 64, times √2.
    assert!((within - 0.04 / 64.0 * 2f64.sqrt()).abs() < 1e-10, "{within}");
    // 400 directions spread by the golden angle over the sphere. Rounding of the grid's
    // corners (sums of a few millimetre-sized terms): 1e-15 m; 1e-12 m is ample.
    for k in 0..400 {
        let z = 1.0 - (2 * k + 1) as f64 / 400.0;
        let phi = k as f64 * 2.399_963_229_728_653;
        let d = Vector3::new((1.0 - z * z).sqrt() * phi.cos(), (1.0 - z * z).sqrt() * phi.sin(), z);
        let (outer, inner) = (support(&read.points, &d), support(&raw, &d));
        assert!(outer >= inner - 1e-12, "direction {d}: {outer} inside {inner}");
        assert!(outer <= inner + within + 1e-12, "direction {d}: {outer} beyond {inner} + {within}");
    }
    let output = fk(&urdf);
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let stderr = String::from_utf8_lossy(&output.stderr);
    let warning = stderr.lines().find(|l| l.contains("distinct vertices")).expect(&stderr);
    assert!(warning.starts_with("warning: "), "{warning}");
    assert!(warning.contains(&format!("{} has {vertices} distinct vertices", stl.display())), "{warning}");
    assert!(warning.contains(&format!("the hull of {kept} points")), "{warning}");
    assert!(warning.contains("at most 0.9 mm outside"), "{warning}");
}

/// A mesh under the limit is hulled over its own vertices, as before: the hull is bit for bit
/// the hull of every vertex of the file.
#[test]
fn a_small_mesh_is_hulled_over_its_own_vertices() {
    let dir = tempfile::tempdir().unwrap();
    let mesh = binary_stl(&uv_sphere(60, 80, [90.0, 20.0, 16.0]));
    let (_, stl) = arm_with_mesh(dir.path(), &mesh, "-0.001 0.001 0.001");
    let read = chessarm::app::setup::meshes::read_stl(&stl, [-0.001, 0.001, 0.001], "-0.001 0.001 0.001").unwrap();
    assert!(read.decimated.is_none());
    let raw: Vec<Vector3<f64>> = chessarm::app::setup::meshes::parse_stl(&mesh)
        .unwrap()
        .iter()
        .map(|p| Vector3::new(p.x * -0.001, p.y * 0.001, p.z * 0.001))
        .collect();
    let before = chessarm_chess::clearance::hull_of(&raw).unwrap();
    let after = chessarm_chess::clearance::hull_of(&read.points).unwrap();
    let bits = |h: &[Vector3<f64>]| h.iter().map(|p| p.map(f64::to_bits)).collect::<Vec<_>>();
    assert_eq!(bits(&before), bits(&after));
}

fn box_triangles(corner: impl Fn(usize) -> [f32; 3]) -> Vec<[[f32; 3]; 3]> {
    common::BOX_FACES.iter().map(|f| f.map(&corner)).collect()
}

/// The fixture arm with `mesh` at `scale` is refused with one line holding every `needle`, in
/// the user's words.
fn refused(dir: &Path, mesh: &[u8], scale: &str, needles: &[&str]) {
    let (urdf, _) = arm_with_mesh(dir, mesh, scale);
    let output = fk(&urdf);
    assert_one_line_error(&output, needles);
    in_users_words(&output);
}

/// A 90 × 20 × 16 box (the fixture's forearm, in mm).
fn box_stl() -> Vec<u8> {
    binary_stl(&box_triangles(|i| [(i & 1) as f32 * 90.0, ((i >> 1) & 1) as f32 * 20.0, ((i >> 2) & 1) as f32 * 16.0]))
}

/// Scaled past any number, or past what the hull's arithmetic holds: the vertices overflow,
/// said with the scale as typed.
#[test]
fn a_mesh_scaled_past_any_number_is_said_to_overflow() {
    let dir = tempfile::tempdir().unwrap();
    let scale = "1e308 1e308 1e308";
    refused(dir.path(), &box_stl(), scale, &["forearm.stl", "scaled by \"1e308 1e308 1e308\"", "vertices overflow"]);
    // Finite coordinates whose products (the hull's volumes) are not: said with the size.
    let scale = "1e200 1e200 1e200";
    refused(dir.path(), &box_stl(), scale, &["forearm.stl", "scaled by \"1e200 1e200 1e200\"", "9e201 m across"]);
}

/// A mesh whose vertices are all one point is no shape: said with their count.
#[test]
fn a_mesh_whose_vertices_coincide_is_said_to_be_no_shape() {
    let dir = tempfile::tempdir().unwrap();
    let point = binary_stl(&box_triangles(|_| [5.0, 5.0, 5.0]));
    refused(
        dir.path(),
        &point,
        "0.001 0.001 0.001",
        &["forearm.stl", "all 36 vertices coincide", "no shape to check clearance with"],
    );
}

/// Scaled down to nothing: the mesh's size after the scale is said, with the scale as typed.
#[test]
fn a_mesh_scaled_to_nothing_is_said_to_be_too_small() {
    let dir = tempfile::tempdir().unwrap();
    refused(
        dir.path(),
        &box_stl(),
        "1e-300 1e-300 1e-300",
        &["forearm.stl", "scaled by \"1e-300 1e-300 1e-300\"", "the mesh is 9e-299 m across", "too small"],
    );
}

/// A flat mesh (every vertex in one plane) spans no volume: said before any hull is tried.
#[test]
fn a_flat_mesh_is_said_to_span_no_volume() {
    let dir = tempfile::tempdir().unwrap();
    let flat = binary_stl(&box_triangles(|i| [(i & 1) as f32 * 90.0, ((i >> 1) & 1) as f32 * 20.0, 0.0]));
    refused(dir.path(), &flat, "0.001 0.001 0.001", &["forearm.stl", "span no volume"]);
}

/// Many shapes of many corners: refused at import, naming the sum and the bound (forty copies
/// of a 39 000-corner sphere took 19.5 s a move in the clearance check, unannounced).
#[test]
fn collision_shapes_of_too_many_corners_in_all_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    // 99 rings of 200 segments: about 19 600 distinct vertices, all on the hull.
    let sphere = binary_stl(&uv_sphere(99, 200, [0.02, 0.02, 0.02]));
    let (urdf, _) = arm_with_mesh(dir.path(), &sphere, "1 1 1");
    // One copy imports; six on the forearm (six times ~19 600) are too many.
    assert!(fk(&urdf).status.success(), "{}", String::from_utf8_lossy(&fk(&urdf).stderr));
    let shape = r#"<collision><geometry><mesh filename="forearm.stl" scale="1 1 1"/></geometry></collision>"#;
    let text = std::fs::read_to_string(&urdf).unwrap().replace(shape, &shape.repeat(6));
    std::fs::write(&urdf, text).unwrap();
    let output = fk(&urdf);
    common::assert_one_line_error(&output, &["hull corners in all", "100000", "fewer or simpler shapes"]);
    in_users_words(&output);
}
