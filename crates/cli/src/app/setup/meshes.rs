//! Mesh files a URDF's `<mesh filename="…">` names: where they are and their vertices.
//!
//! A filename is `package://PACKAGE/PATH` (ROS: the folder named `PACKAGE`, looked for among
//! the URDF file's folder and its parents, and under each folder of `ROS_PACKAGE_PATH`),
//! `file://ABSOLUTE`, or a path relative to the URDF file's folder. STL files are read, binary
//! or ASCII (the format every arm of `../shared/real-arms` uses); vertices in the file's units,
//! scaled by the element's `scale`. Other formats (DAE, OBJ) are refused by name.

use anyhow::{Result, bail};
use chessarm_core::nalgebra::Vector3;
use std::io::{BufRead, Read};
use std::path::{Path, PathBuf};

/// Largest mesh file read, bytes (64 MB: an arm's link meshes are 0.1–5 MB).
pub const MAX_MESH_BYTES: u64 = 64_000_000;

/// Where `filename` may be, in the order looked at, for a URDF in folder `urdf_dir` and the
/// package folders `package_path` (`ROS_PACKAGE_PATH`'s entries).
pub fn candidates(filename: &str, urdf_dir: Option<&Path>, package_path: &[PathBuf]) -> Vec<PathBuf> {
    if let Some(rest) = filename.strip_prefix("package://") {
        let (package, path) = rest.split_once('/').unwrap_or((rest, ""));
        let mut out = Vec::new();
        for folder in urdf_dir.into_iter().flat_map(Path::ancestors) {
            if folder.file_name().is_some_and(|n| n == package) {
                out.push(folder.join(path));
            }
            out.push(folder.join(package).join(path));
        }
        out.extend(package_path.iter().map(|p| p.join(package).join(path)));
        out
    } else if let Some(absolute) = filename.strip_prefix("file://") {
        vec![PathBuf::from(absolute)]
    } else {
        vec![urdf_dir.map_or_else(|| PathBuf::from(filename), |d| d.join(filename))]
    }
}

/// `ROS_PACKAGE_PATH`'s folders.
pub fn package_path() -> Vec<PathBuf> {
    std::env::var_os("ROS_PACKAGE_PATH").map(|v| std::env::split_paths(&v).collect()).unwrap_or_default()
}

/// Most distinct vertices a mesh's hull is computed over as they are (the meshes of
/// `../shared/real-arms` have up to 26 967): above it a grid of points around the vertices stands in (see
/// [`around`]), so that a mesh of a million triangles imports in seconds and its hull stays
/// small for the clearance check, which scans the hull's vertices at every step.
pub const MAX_HULL_INPUT: usize = 40_000;

/// The most hull corners of all an arm's collision shapes together: the clearance check's
/// support searches go through a hull's corners, for every pose of every move, so the game's
/// check grows with their sum (two links of a 39 000-corner sphere: 2.7 s a move in a debug
/// build; forty of them, 19.5 s). The makers' arms here have 745 (PincherX-100), 1 468
/// (OpenManipulator-X) and 31 641 (SO-101).
pub const MAX_ARM_HULL_CORNERS: usize = 100_000;

/// Columns across the grid that stands in for a larger mesh: at most `2 (COLUMNS + 1)²` points
/// (8450) go to the hull.
pub const COLUMNS: usize = 64;

/// Smallest extent of a mesh after its scale, m: below a micrometre there is nothing the
/// clearance check can tell apart (its resolution is 0.5 mm).
pub const MIN_EXTENT: f64 = 1e-6;

/// Largest extent of a mesh after its scale, m: the hull's arithmetic takes products of four
/// lengths, which must stay finite (f64 ends at 1.8e308; 1e60⁴ = 1e240 leaves room).
pub const MAX_EXTENT: f64 = 1e60;

/// A mesh's points for its convex hull, m, with what was done to a large mesh.
#[derive(Debug, Clone)]
pub struct MeshPoints {
    /// Distinct vertices, sorted by their bits (or the grid points standing in for them).
    pub points: Vec<Vector3<f64>>,
    /// For a mesh of more than [`MAX_HULL_INPUT`] distinct vertices: how many it has, how many
    /// points stand in, and how far outside the mesh's own hull theirs reaches at most, m.
    pub decimated: Option<(usize, usize, f64)>,
}

/// The points for the convex hull of the STL file at `path`, m after `scale` (per axis;
/// `scale_text` is the attribute as typed, for messages). The file is read as a stream (a
/// vertex is kept as three f64, 72 bytes a triangle against the file's 50).
///
/// # Errors
///
/// The file cannot be read, is longer than [`MAX_MESH_BYTES`], is not STL (binary or ASCII),
/// has a vertex that is not finite, all its vertices coincide, or scaled it overflows, is
/// smaller than [`MIN_EXTENT`] or spans no volume; each said with the file's name.
pub fn read_stl(path: &Path, scale: [f64; 3], scale_text: &str) -> Result<MeshPoints> {
    let name = path.display();
    let extension = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    if extension != "stl" {
        bail!("{name}: a .{extension} mesh; chessarm reads STL meshes only (convert it, e.g. with meshlab)");
    }
    let file = std::fs::File::open(path).map_err(|e| anyhow::anyhow!("{name}: cannot read: {e}"))?;
    let length = file.metadata().map_err(|e| anyhow::anyhow!("{name}: cannot read: {e}"))?.len();
    if length > MAX_MESH_BYTES {
        bail!("{name}: longer than {MAX_MESH_BYTES} bytes (the most chessarm reads of a mesh)");
    }
    if scale.contains(&0.0) {
        bail!("{name}: scale=\"{scale_text}\" flattens it (every factor must be non-zero)");
    }
    let reader = std::io::BufReader::with_capacity(1 << 16, file.take(MAX_MESH_BYTES + 1));
    let mut points = parse_stl_from(reader, length).map_err(|why| anyhow::anyhow!("{name}: {why}"))?;
    let count = points.len();
    let (low, high) = bounds(&points);
    if low == high {
        bail!("{name}: all {count} vertices coincide: no shape to check clearance with");
    }
    // Scaled in place, -0 as +0 (the hull's own pass sorts by bits so).
    for p in &mut points {
        *p = Vector3::new(p.x * scale[0] + 0.0, p.y * scale[1] + 0.0, p.z * scale[2] + 0.0);
    }
    let (low, high) = bounds(&points);
    let extent = (high - low).max();
    if extent.is_nan() || extent > MAX_EXTENT {
        let size = if extent.is_finite() {
            format!("the mesh would be {} m across", chessarm_core::short_number(extent))
        } else {
            format!("a coordinate would pass {}, the largest number there is", chessarm_core::short_number(f64::MAX))
        };
        bail!(
            "{name}: scaled by \"{scale_text}\" its vertices overflow ({size}; chessarm takes meshes up to {} m across)",
            chessarm_core::short_number(MAX_EXTENT)
        );
    }
    if extent < MIN_EXTENT {
        bail!(
            "{name}: scaled by \"{scale_text}\" the mesh is {} m across, too small to check clearance with (under a \
             micrometre)",
            chessarm_core::short_number(extent)
        );
    }
    // A mesh repeats each vertex in every triangle that has it (six times on average): once is
    // enough for the hull. Sorted by bits, as the hull's own pass does, in place (no second
    // copy of a large mesh).
    let bits = |p: &Vector3<f64>| [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()];
    points.sort_unstable_by_key(bits);
    points.dedup();
    let unique = points;
    if !spans_volume(&unique, extent) {
        bail!("{name}: its vertices span no volume (they lie in a plane or on a line)");
    }
    if unique.len() <= MAX_HULL_INPUT {
        return Ok(MeshPoints { points: unique, decimated: None });
    }
    let (points, within) = around(&unique, low, high);
    Ok(MeshPoints { decimated: Some((unique.len(), points.len(), within)), points })
}

/// The smallest and largest coordinates of `points`, per axis.
fn bounds(points: &[Vector3<f64>]) -> (Vector3<f64>, Vector3<f64>) {
    let first = points.first().copied().unwrap_or_else(Vector3::zeros);
    points.iter().fold((first, first), |(l, h), p| (l.inf(p), h.sup(p)))
}

/// Whether `points` (`extent` m across) span a volume: the point farthest from the first, the
/// one farthest from the line through both and the one farthest from the plane through the
/// three, the last at least a billionth of the extent from it.
fn spans_volume(points: &[Vector3<f64>], extent: f64) -> bool {
    let a = points[0];
    let farthest = |distance: &dyn Fn(&Vector3<f64>) -> f64| {
        points.iter().map(|p| (distance(p), *p)).fold((0.0, a), |best, c| if c.0 > best.0 { c } else { best })
    };
    let (_, b) = farthest(&|p| (p - a).norm());
    let line = (b - a).normalize();
    let (off_line, c) = farthest(&|p| (p - a - line * (p - a).dot(&line)).norm());
    if off_line <= 1e-9 * extent {
        return false;
    }
    let normal = line.cross(&(c - a)).normalize();
    let (off_plane, _) = farthest(&|p| (p - a).dot(&normal).abs());
    off_plane > 1e-9 * extent
}

/// Points whose convex hull holds every one of `points` (between `low` and `high`) and lies
/// within the returned distance of theirs, m: at most `2 (COLUMNS + 1)²` of them.
///
/// The mesh is cut into `COLUMNS` square columns of side `h` across its two shorter extents
/// (the columns run along its longest, so an arm's long link gets narrow columns); each
/// column's vertices lie in a box from its lowest to its highest vertex. Each corner of the
/// grid takes a point at the lowest bottom and one at the highest top of the columns around
/// it: the boxes, and so every vertex, lie in the hull of these points (conservative: the
/// clearance check sees the mesh at least as large as it is), and each point is a column's
/// diagonal, `h √2`, from the vertex whose height it took, so their hull lies within `h √2`
/// of the mesh's own hull.
pub fn around(points: &[Vector3<f64>], low: Vector3<f64>, high: Vector3<f64>) -> (Vec<Vector3<f64>>, f64) {
    let extent = high - low;
    let along = extent.imax();
    let (u, v) = ((along + 1) % 3, (along + 2) % 3);
    let h = extent[u].max(extent[v]) / COLUMNS as f64;
    let cells = |k: usize| ((extent[k] / h).ceil() as usize).clamp(1, COLUMNS);
    let (nu, nv) = (cells(u), cells(v));
    let index = |p: &Vector3<f64>, k: usize, n: usize| (((p[k] - low[k]) / h).floor().max(0.0) as usize).min(n - 1);
    let mut columns = vec![(f64::INFINITY, f64::NEG_INFINITY); nu * nv];
    for p in points {
        let column = &mut columns[index(p, u, nu) * nv + index(p, v, nv)];
        *column = (column.0.min(p[along]), column.1.max(p[along]));
    }
    let mut out = Vec::new();
    for i in 0..=nu {
        for j in 0..=nv {
            let (mut bottom, mut top) = (f64::INFINITY, f64::NEG_INFINITY);
            for ci in i.saturating_sub(1)..(i + 1).min(nu) {
                for cj in j.saturating_sub(1)..(j + 1).min(nv) {
                    let (b, t) = columns[ci * nv + cj];
                    (bottom, top) = (bottom.min(b), top.max(t));
                }
            }
            if bottom > top {
                continue;
            }
            let mut corner = low;
            corner[u] += i as f64 * h;
            corner[v] += j as f64 * h;
            for height in if bottom < top { vec![bottom, top] } else { vec![top] } {
                corner[along] = height;
                out.push(corner);
            }
        }
    }
    (out, h * std::f64::consts::SQRT_2)
}

/// The vertices of STL `bytes`: binary (an 80-byte header, a triangle count, 50 bytes a
/// triangle: normal, three vertices as little-endian f32, attribute) when the length says so,
/// else ASCII (`vertex x y z` lines).
pub fn parse_stl(bytes: &[u8]) -> Result<Vec<Vector3<f64>>, String> {
    parse_stl_from(bytes, bytes.len() as u64)
}

/// [`parse_stl`] of a stream `length` bytes long, read once.
fn parse_stl_from(mut reader: impl BufRead, length: u64) -> Result<Vec<Vector3<f64>>, String> {
    let unreadable = |e: std::io::Error| format!("cannot read: {e}");
    let mut head = Vec::with_capacity(84);
    (&mut reader).take(84).read_to_end(&mut head).map_err(unreadable)?;
    let binary = head.len() == 84 && {
        let count = u64::from(u32::from_le_bytes([head[80], head[81], head[82], head[83]]));
        count * 50 + 84 == length
    };
    let mut points = Vec::new();
    if binary {
        points.reserve_exact((length as usize - 84) / 50 * 3);
        let mut triangle = [0u8; 50];
        loop {
            match reader.read_exact(&mut triangle) {
                Ok(()) => {}
                Err(e) if e.kind() == std::io::ErrorKind::UnexpectedEof => break,
                Err(e) => return Err(unreadable(e)),
            }
            for v in 0..3 {
                let at = 12 + 12 * v;
                let f = |k: usize| {
                    let b = &triangle[at + 4 * k..at + 4 * k + 4];
                    f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
                };
                points.push(Vector3::new(f(0), f(1), f(2)));
            }
        }
    } else {
        let not_ascii =
            || "neither binary STL (its length does not match its triangle count) nor ASCII STL".to_string();
        let mut reader = std::io::Cursor::new(head).chain(reader);
        let mut line = Vec::new();
        let (mut number, mut started) = (0usize, false);
        loop {
            line.clear();
            if reader.read_until(b'\n', &mut line).map_err(unreadable)? == 0 {
                break;
            }
            number += 1;
            // A byte-order mark some editors write is not part of the text.
            let bytes = if number == 1 { line.strip_prefix(&[0xEF, 0xBB, 0xBF]).unwrap_or(&line) } else { &line };
            let text = std::str::from_utf8(bytes).map_err(|_| not_ascii())?;
            if !started {
                if text.trim().is_empty() {
                    continue;
                }
                if !text.trim_start().starts_with("solid") {
                    return Err(not_ascii() + " (no `solid`)");
                }
                started = true;
            }
            let mut words = text.split_whitespace();
            if words.next() != Some("vertex") {
                continue;
            }
            let bad = || format!("line {number}: `{}` is not `vertex x y z`", text.trim());
            let values: Vec<f64> = words.map(str::parse).collect::<Result<_, _>>().map_err(|_| bad())?;
            let [x, y, z] = values[..] else {
                return Err(bad());
            };
            points.push(Vector3::new(x, y, z));
        }
        if !started {
            return Err(not_ascii() + " (no `solid`)");
        }
    }
    if let Some(bad) = points.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
        return Err(format!("vertex {} is not finite", bad + 1));
    }
    if points.len() < 4 {
        return Err(format!("{} vertices: a solid needs at least 4", points.len()));
    }
    Ok(points)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn binary(triangles: &[[[f32; 3]; 3]]) -> Vec<u8> {
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

    /// A tetrahedron read from binary and from ASCII STL gives the same vertices.
    #[test]
    fn binary_and_ascii_stl_read_alike() {
        let [a, b, c, d] = [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 3.0]];
        let faces = [[a, c, b], [a, b, d], [a, d, c], [b, c, d]];
        let from_binary = parse_stl(&binary(&faces)).expect("binary");
        let mut text = String::from("solid t\n");
        for f in &faces {
            text.push_str("facet normal 0 0 0\nouter loop\n");
            for v in f {
                text.push_str(&format!("vertex {} {} {}\n", v[0], v[1], v[2]));
            }
            text.push_str("endloop\nendfacet\n");
        }
        text.push_str("endsolid t\n");
        let from_ascii = parse_stl(text.as_bytes()).expect("ascii");
        assert_eq!(from_binary.len(), 12);
        assert_eq!(from_binary, from_ascii);
        assert_eq!(from_binary[5], Vector3::new(0.0, 0.0, 3.0));
    }

    /// A truncated binary file and a text that is not STL are refused, saying why.
    #[test]
    fn a_file_that_is_not_stl_is_refused() {
        let mut bytes = binary(&[[[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]]);
        bytes.pop();
        assert!(parse_stl(&bytes).unwrap_err().contains("neither binary STL"));
        assert!(parse_stl(b"hello").unwrap_err().contains("no `solid`"));
        assert!(parse_stl(b"solid x\nvertex 1 2\n").unwrap_err().contains("line 2"));
    }

    /// `package://` looks in the URDF's folder's parents for the package, then in
    /// `ROS_PACKAGE_PATH`'s folders; a relative name is the URDF's folder's.
    #[test]
    fn package_names_are_looked_for_where_ros_keeps_them() {
        let dir = Path::new("/robots/arm_description/urdf");
        let found = candidates("package://arm_description/meshes/a.stl", Some(dir), &[PathBuf::from("/opt/ros")]);
        assert!(found.contains(&PathBuf::from("/robots/arm_description/meshes/a.stl")));
        assert_eq!(found.last(), Some(&PathBuf::from("/opt/ros/arm_description/meshes/a.stl")));
        assert_eq!(candidates("assets/b.stl", Some(dir), &[]), vec![dir.join("assets/b.stl")]);
        assert_eq!(candidates("file:///m/c.stl", Some(dir), &[]), vec![PathBuf::from("/m/c.stl")]);
    }
}
