//! Mesh files a URDF's `<mesh filename="…">` names: where they are and their vertices.
//!
//! A filename is `package://PACKAGE/PATH` (ROS: the folder named `PACKAGE`, looked for among
//! the URDF file's folder and its parents, and under each folder of `ROS_PACKAGE_PATH`),
//! `file://ABSOLUTE`, or a path relative to the URDF file's folder. STL files are read, binary
//! or ASCII (the format every arm of `../shared/real-arms` uses); vertices in the file's units,
//! scaled by the element's `scale`. Other formats (DAE, OBJ) are refused by name.

use anyhow::{Result, bail};
use chessarm_core::nalgebra::Vector3;
use std::io::Read;
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

/// The vertices of the STL file at `path`, m after `scale` (per axis).
///
/// # Errors
///
/// The file cannot be read, is longer than [`MAX_MESH_BYTES`], is not STL (binary or ASCII),
/// or has a vertex that is not finite.
pub fn read_stl(path: &Path, scale: [f64; 3]) -> Result<Vec<Vector3<f64>>> {
    let extension = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase();
    if extension != "stl" {
        bail!(
            "{}: a .{extension} mesh; chessarm reads STL meshes only (convert it, e.g. with meshlab)",
            path.display()
        );
    }
    let file = std::fs::File::open(path).map_err(|e| anyhow::anyhow!("{}: cannot read: {e}", path.display()))?;
    let mut bytes = Vec::new();
    file.take(MAX_MESH_BYTES + 1).read_to_end(&mut bytes).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    if bytes.len() as u64 > MAX_MESH_BYTES {
        bail!("{}: longer than {MAX_MESH_BYTES} bytes (the most chessarm reads of a mesh)", path.display());
    }
    if scale.contains(&0.0) {
        bail!(
            "{}: scale=\"{} {} {}\" flattens it (every factor must be non-zero)",
            path.display(),
            scale[0],
            scale[1],
            scale[2]
        );
    }
    let points = parse_stl(&bytes).map_err(|why| anyhow::anyhow!("{}: {why}", path.display()))?;
    let scaled: Vec<Vector3<f64>> =
        points.into_iter().map(|p| Vector3::new(p.x * scale[0], p.y * scale[1], p.z * scale[2])).collect();
    if scaled.iter().any(|p| !p.iter().all(|c| c.is_finite())) {
        bail!("{}: scale=\"{} {} {}\" makes a vertex infinite", path.display(), scale[0], scale[1], scale[2]);
    }
    Ok(scaled)
}

/// The vertices of STL `bytes`: binary (an 80-byte header, a triangle count, 50 bytes a
/// triangle: normal, three vertices as little-endian f32, attribute) when the length says so,
/// else ASCII (`vertex x y z` lines).
pub fn parse_stl(bytes: &[u8]) -> Result<Vec<Vector3<f64>>, String> {
    let binary = bytes.len() >= 84 && {
        let count = u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]) as usize;
        count.checked_mul(50).and_then(|n| n.checked_add(84)) == Some(bytes.len())
    };
    let mut points = Vec::new();
    if binary {
        for triangle in bytes[84..].chunks_exact(50) {
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
        // A byte-order mark some editors write is not part of the text.
        let bytes = bytes.strip_prefix(&[0xEF, 0xBB, 0xBF]).unwrap_or(bytes);
        let text = std::str::from_utf8(bytes).map_err(|_| {
            "neither binary STL (its length does not match its triangle count) nor ASCII STL".to_string()
        })?;
        if !text.trim_start().starts_with("solid") {
            return Err(
                "neither binary STL (its length does not match its triangle count) nor ASCII STL (no `solid`)".into()
            );
        }
        for (number, line) in text.lines().enumerate() {
            let mut words = line.split_whitespace();
            if words.next() != Some("vertex") {
                continue;
            }
            let values: Vec<f64> = words
                .map(str::parse)
                .collect::<Result<_, _>>()
                .map_err(|_| format!("line {}: `{}` is not `vertex x y z`", number + 1, line.trim()))?;
            let [x, y, z] = values[..] else {
                return Err(format!("line {}: `{}` is not `vertex x y z`", number + 1, line.trim()));
            };
            points.push(Vector3::new(x, y, z));
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
