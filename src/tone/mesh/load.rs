//! OBJ loading: a light pre-scan that reports bad lines by number (tobj's errors carry none), then
//! tobj for the parsing proper (triangulation, objects and groups, polygon normals), then one
//! welded triangle soup with smooth vertex normals.

use std::collections::HashMap;
use std::path::Path;

use glam::Vec3;

use super::MeshError;

/// A triangle mesh ready to render: welded positions, triangles, and optionally the file's own
/// normals per triangle corner.
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    pub positions: Vec<Vec3>,
    /// Counter-clockwise seen from outside (fixed on load for closed meshes that are inside out).
    pub triangles: Vec<[u32; 3]>,
    /// The file's normals per triangle corner, when every face has them (hard edges stay hard).
    /// `None`: shading uses smooth vertex normals.
    pub corner_normals: Option<Vec<[Vec3; 3]>>,
    /// Every edge is shared by exactly two triangles (computed by [`Mesh::new`]).
    closed: bool,
}

impl Mesh {
    /// Build from positions and triangles: weld repeated positions, drop degenerate triangles and,
    /// for a closed mesh whose faces point inwards, turn it right side out.
    pub fn new(positions: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> Mesh {
        Self::with_normals(positions, triangles, None)
    }

    /// As [`Mesh::new`], keeping per-corner normals (one per triangle corner) when given.
    pub fn with_normals(
        positions: Vec<Vec3>,
        triangles: Vec<[u32; 3]>,
        corner_normals: Option<Vec<[Vec3; 3]>>,
    ) -> Mesh {
        // Weld on exact coordinates: files repeat a vertex per object/group/face with identical
        // text, so identical bits are what "the same vertex" means. -0.0 and 0.0 are one point.
        let key = |p: Vec3| (p + Vec3::ZERO).to_array().map(f32::to_bits);
        let mut index: HashMap<[u32; 3], u32, BuildFx> =
            HashMap::with_capacity_and_hasher(positions.len(), BuildFx);
        let mut welded = Vec::with_capacity(positions.len());
        let remap: Vec<u32> = positions
            .iter()
            .map(|&p| {
                *index.entry(key(p)).or_insert_with(|| {
                    welded.push(p);
                    (welded.len() - 1) as u32
                })
            })
            .collect();
        let mut tris = Vec::with_capacity(triangles.len());
        let mut normals = corner_normals.as_ref().map(|_| Vec::new());
        for (i, t) in triangles.iter().enumerate() {
            let t = t.map(|v| remap[v as usize]);
            let (a, b, c) = (
                welded[t[0] as usize],
                welded[t[1] as usize],
                welded[t[2] as usize],
            );
            if t[0] == t[1] || t[1] == t[2] || t[0] == t[2] || (b - a).cross(c - a) == Vec3::ZERO {
                continue;
            }
            tris.push(t);
            if let (Some(out), Some(src)) = (normals.as_mut(), corner_normals.as_ref()) {
                out.push(src[i]);
            }
        }
        let mut mesh = Mesh {
            positions: welded,
            triangles: tris,
            corner_normals: normals,
            closed: false,
        };
        mesh.closed = mesh.edges_paired();
        if mesh.closed && mesh.signed_volume() < 0.0 {
            mesh.flip();
        }
        mesh
    }

    /// Centre and radius of a bounding sphere (centred on the bounding box).
    pub fn bounding_sphere(&self) -> (Vec3, f32) {
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for &p in &self.positions {
            lo = lo.min(p);
            hi = hi.max(p);
        }
        let c = (lo + hi) * 0.5;
        let r = self
            .positions
            .iter()
            .map(|&p| p.distance(c))
            .fold(0.0f32, f32::max);
        (c, r.max(f32::MIN_POSITIVE))
    }

    /// Smooth vertex normals: the area-weighted mean of the adjacent faces' normals.
    pub fn vertex_normals(&self) -> Vec<Vec3> {
        let mut n = vec![Vec3::ZERO; self.positions.len()];
        for t in &self.triangles {
            let [a, b, c] = t.map(|v| self.positions[v as usize]);
            let f = (b - a).cross(c - a); // length = twice the area
            for &v in t {
                n[v as usize] += f;
            }
        }
        n.iter()
            .map(|v| v.try_normalize().unwrap_or(Vec3::Z))
            .collect()
    }

    /// Whether every edge is shared by exactly two triangles (a watertight surface: back faces are
    /// never visible, so the rasteriser may cull them).
    pub fn is_closed(&self) -> bool {
        self.closed
    }

    fn edges_paired(&self) -> bool {
        use rayon::prelude::*;
        // Sorted undirected edges: closed iff they come in pairs and never in threes.
        let mut edges: Vec<u64> = self
            .triangles
            .par_iter()
            .flat_map_iter(|t| {
                (0..3).map(move |k| {
                    let (a, b) = (t[k], t[(k + 1) % 3]);
                    ((a.min(b) as u64) << 32) | a.max(b) as u64
                })
            })
            .collect();
        edges.par_sort_unstable();
        !edges.is_empty() && edges.chunk_by(|a, b| a == b).all(|run| run.len() == 2)
    }

    /// Signed volume (positive when faces are counter-clockwise seen from outside).
    pub fn signed_volume(&self) -> f64 {
        self.triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|v| self.positions[v as usize].as_dvec3());
                a.dot(b.cross(c)) / 6.0
            })
            .sum()
    }

    fn flip(&mut self) {
        for t in &mut self.triangles {
            t.swap(1, 2);
        }
        if let Some(n) = self.corner_normals.as_mut() {
            for c in n {
                c.swap(1, 2);
            }
        }
    }

    /// The mesh as OBJ text (positions and faces, 1-based), for the sample generator and tests.
    pub fn to_obj(&self, name: &str) -> String {
        use std::fmt::Write;
        let mut s = String::with_capacity(self.positions.len() * 32 + self.triangles.len() * 20);
        let _ = writeln!(s, "# generated by stencil\no {name}");
        let num = |v: f32| {
            let t = format!("{v:.4}");
            if t == "-0.0000" {
                "0.0000".to_string()
            } else {
                t
            }
        };
        for p in &self.positions {
            let _ = writeln!(s, "v {} {} {}", num(p.x), num(p.y), num(p.z));
        }
        for t in &self.triangles {
            let _ = writeln!(s, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1);
        }
        s
    }
}

/// A multiply-rotate hasher for welding keys (three f32 bit patterns): several times faster than
/// the default SipHash, and the keys come from the user's own file, not an adversary.
#[derive(Clone, Copy, Default)]
struct BuildFx;

struct Fx(u64);

impl std::hash::BuildHasher for BuildFx {
    type Hasher = Fx;
    fn build_hasher(&self) -> Fx {
        Fx(0)
    }
}

impl std::hash::Hasher for Fx {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.write_u64(b as u64);
        }
    }
    fn write_u32(&mut self, x: u32) {
        self.write_u64(x as u64);
    }
    fn write_u64(&mut self, x: u64) {
        self.0 = (self.0.rotate_left(5) ^ x).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
    }
    fn write_usize(&mut self, x: usize) {
        self.write_u64(x as u64);
    }
}

/// Load an OBJ file: check it line by line, parse it with tobj, merge every object and group into
/// one welded mesh.
pub fn load(path: &Path) -> Result<Mesh, MeshError> {
    let bytes = std::fs::read(path).map_err(|source| MeshError::Open {
        path: path.to_path_buf(),
        source,
    })?;
    let text = String::from_utf8(bytes).map_err(|e| MeshError::NotText {
        path: path.to_path_buf(),
        offset: e.utf8_error().valid_up_to(),
    })?;
    parse(path, &text)
}

/// Parse OBJ text (`path` only names it in errors).
pub fn parse(path: &Path, text: &str) -> Result<Mesh, MeshError> {
    let opts = tobj::LoadOptions {
        single_index: false,
        triangulate: true,
        ignore_points: true,
        ignore_lines: true,
    };
    // The check and the parse read the same text independently: run them side by side, and
    // report the check's error (it names the line) before any of tobj's.
    let (counts, parsed) = rayon::join(
        || prescan(path, text),
        || {
            tobj::load_obj_buf(&mut text.as_bytes(), &opts, |_| {
                // Materials do not matter to a toon render: never read .mtl files.
                Err(tobj::LoadError::GenericFailure)
            })
        },
    );
    let counts = counts?;
    let (models, _materials) = parsed.map_err(|e| MeshError::Parse {
        path: path.to_path_buf(),
        msg: e.to_string(),
    })?;
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    let mut corner_normals = Vec::new();
    let mut all_normals = true;
    for m in &models {
        let mesh = &m.mesh;
        let base = positions.len() as u32;
        positions.extend(
            mesh.positions
                .chunks_exact(3)
                .map(|c| Vec3::new(c[0], c[1], c[2])),
        );
        let has_normals =
            !mesh.normals.is_empty() && mesh.normal_indices.len() == mesh.indices.len();
        all_normals &= has_normals || mesh.indices.is_empty();
        for (k, tri) in mesh.indices.chunks_exact(3).enumerate() {
            triangles.push([tri[0] + base, tri[1] + base, tri[2] + base]);
            if has_normals {
                let n = |j: usize| {
                    let i = mesh.normal_indices[3 * k + j] as usize * 3;
                    Vec3::new(mesh.normals[i], mesh.normals[i + 1], mesh.normals[i + 2])
                        .try_normalize()
                        .unwrap_or(Vec3::ZERO)
                };
                corner_normals.push([n(0), n(1), n(2)]);
            }
        }
    }
    if triangles.is_empty() {
        return Err(MeshError::Empty {
            path: path.to_path_buf(),
            detail: format!(
                "no faces ({} vertices, {} face lines)",
                counts.vertices, counts.faces
            ),
        });
    }
    let normals =
        (all_normals && corner_normals.len() == triangles.len()).then_some(corner_normals);
    let mesh = Mesh::with_normals(positions, triangles, normals);
    if mesh.triangles.is_empty() {
        return Err(MeshError::Empty {
            path: path.to_path_buf(),
            detail: "every face has zero area".into(),
        });
    }
    Ok(mesh)
}

/// What the pre-scan counted.
#[derive(Debug, Default)]
struct Counts {
    vertices: usize,
    faces: usize,
}

/// OBJ statements a mesh file may contain that we either use or may safely ignore.
const KNOWN: &[&str] = &[
    "v",
    "vt",
    "vn",
    "vp",
    "f",
    "l",
    "p",
    "o",
    "g",
    "s",
    "mg",
    "usemtl",
    "mtllib",
    "cstype",
    "deg",
    "bmat",
    "step",
    "curv",
    "curv2",
    "surf",
    "parm",
    "trim",
    "hole",
    "scrv",
    "sp",
    "end",
    "con",
    "lod",
    "shadow_obj",
    "trace_obj",
    "ctech",
    "stech",
    "bevel",
    "c_interp",
    "d_interp",
    "maplib",
    "usemap",
    "call",
    "csh",
];

/// Check every line tobj will read, so errors name the line: numbers that do not parse or are not
/// finite, faces with too few corners or indices pointing at vertices that do not exist, unknown
/// statements (a binary file renamed .obj).
fn prescan(path: &Path, text: &str) -> Result<Counts, MeshError> {
    let mut counts = Counts::default();
    let (mut nv, mut nt, mut nn) = (0usize, 0usize, 0usize);
    // Positive indices may point forward; they are checked against the final counts.
    let mut forward: Vec<(usize, usize, char)> = Vec::new();
    let mut args: Vec<&str> = Vec::with_capacity(8);
    let malformed = |line: usize, msg: String| MeshError::Malformed {
        path: path.to_path_buf(),
        line,
        msg,
    };
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let content = raw.split('#').next().unwrap_or("").trim();
        if content.is_empty() {
            continue;
        }
        let mut words = content.split_whitespace();
        let Some(kw) = words.next() else { continue };
        // Reused across lines: no allocation per line.
        args.clear();
        args.extend(words);
        match kw {
            "v" | "vn" | "vt" => {
                let need = if kw == "vt" { 1 } else { 3 };
                let what = match kw {
                    "v" => "vertex",
                    "vn" => "normal",
                    _ => "texture coordinate",
                };
                if args.len() < need {
                    return Err(malformed(
                        line,
                        format!(
                            "'{kw}' needs {need} number(s), found {}: \"{content}\"",
                            args.len()
                        ),
                    ));
                }
                for tok in args
                    .iter()
                    .take(if kw == "vt" { args.len().min(3) } else { 3 })
                {
                    let x: f64 = tok.parse().map_err(|_| {
                        malformed(line, format!("{what} coordinate '{tok}' is not a number"))
                    })?;
                    if !x.is_finite() || x.abs() > f32::MAX as f64 {
                        return Err(MeshError::NonFinite {
                            path: path.to_path_buf(),
                            line,
                            token: tok.to_string(),
                        });
                    }
                }
                match kw {
                    "v" => nv += 1,
                    "vn" => nn += 1,
                    _ => nt += 1,
                }
            }
            "f" => {
                if args.len() < 3 {
                    return Err(malformed(
                        line,
                        format!("a face needs at least 3 corners, found {}", args.len()),
                    ));
                }
                for corner in &args {
                    for (k, part) in corner.split('/').enumerate() {
                        if k > 2 || (part.is_empty() && k == 0) {
                            return Err(malformed(
                                line,
                                format!("face corner '{corner}' is not v, v/vt, v//vn or v/vt/vn"),
                            ));
                        }
                        if part.is_empty() {
                            continue;
                        }
                        let (count, kind) = match k {
                            0 => (nv, 'v'),
                            1 => (nt, 't'),
                            _ => (nn, 'n'),
                        };
                        let idx: i64 = part.parse().map_err(|_| {
                            malformed(
                                line,
                                format!("face index '{part}' in '{corner}' is not an integer"),
                            )
                        })?;
                        if idx == 0 {
                            return Err(malformed(
                                line,
                                format!("face index 0 in '{corner}': OBJ indices start at 1"),
                            ));
                        }
                        if idx < 0 {
                            if (-idx) as usize > count {
                                return Err(bad_index(path, line, idx, count, kind));
                            }
                        } else if idx as usize > count {
                            forward.push((line, idx as usize, kind));
                        }
                    }
                }
                counts.faces += 1;
            }
            _ if KNOWN.contains(&kw) => {}
            _ => {
                let shown: String = kw.chars().take(20).collect();
                return Err(malformed(
                    line,
                    format!("unknown statement '{shown}' (is this an OBJ text file?)"),
                ));
            }
        }
    }
    for (line, idx, kind) in forward {
        let count = match kind {
            'v' => nv,
            't' => nt,
            _ => nn,
        };
        if idx > count {
            return Err(bad_index(path, line, idx as i64, count, kind));
        }
    }
    counts.vertices = nv;
    Ok(counts)
}

fn bad_index(path: &Path, line: usize, idx: i64, count: usize, kind: char) -> MeshError {
    let what = match kind {
        'v' => "vertices",
        't' => "texture coordinates",
        _ => "normals",
    };
    MeshError::BadIndex {
        path: path.to_path_buf(),
        line,
        msg: format!("face refers to index {idx} but the file has only {count} {what}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p() -> &'static Path {
        Path::new("test.obj")
    }

    /// A unit cube written as six groups, each repeating its own four corners.
    fn cube_groups() -> String {
        let faces: [[[f32; 3]; 4]; 6] = [
            [[0., 0., 1.], [1., 0., 1.], [1., 1., 1.], [0., 1., 1.]],
            [[1., 0., 0.], [0., 0., 0.], [0., 1., 0.], [1., 1., 0.]],
            [[1., 0., 1.], [1., 0., 0.], [1., 1., 0.], [1., 1., 1.]],
            [[0., 0., 0.], [0., 0., 1.], [0., 1., 1.], [0., 1., 0.]],
            [[0., 1., 1.], [1., 1., 1.], [1., 1., 0.], [0., 1., 0.]],
            [[0., 0., 0.], [1., 0., 0.], [1., 0., 1.], [0., 0., 1.]],
        ];
        let mut s = String::new();
        for (i, f) in faces.iter().enumerate() {
            s += &format!("o side{i}\n");
            for v in f {
                s += &format!("v {} {} {}\n", v[0], v[1], v[2]);
            }
            s += "f -4 -3 -2 -1\n";
        }
        s
    }

    #[test]
    fn groups_are_merged_welded_and_triangulated() {
        let m = parse(p(), &cube_groups()).unwrap();
        assert_eq!(m.positions.len(), 8, "24 repeated corners weld to 8");
        assert_eq!(m.triangles.len(), 12, "6 quads become 12 triangles");
        assert!(m.is_closed());
        assert!((m.signed_volume() - 1.0).abs() < 1e-6);
        assert!(m.corner_normals.is_none());
    }

    #[test]
    fn inside_out_closed_mesh_is_turned_right_side_out() {
        let text = cube_groups().replace("f -4 -3 -2 -1", "f -1 -2 -3 -4");
        let m = parse(p(), &text).unwrap();
        assert!((m.signed_volume() - 1.0).abs() < 1e-6);
    }

    #[test]
    fn smooth_normals_point_outwards() {
        let m = parse(p(), &cube_groups()).unwrap();
        let n = m.vertex_normals();
        for (v, n) in m.positions.iter().zip(&n) {
            let out = (*v - Vec3::splat(0.5)).normalize();
            assert!(n.dot(out) > 0.9, "{v} {n}");
        }
    }

    #[test]
    fn file_normals_are_kept_per_corner() {
        let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1\n";
        let m = parse(p(), text).unwrap();
        assert_eq!(m.corner_normals.unwrap()[0], [Vec3::Z; 3]);
    }

    #[test]
    fn bad_lines_are_reported_with_their_number() {
        let cases = [
            ("v 0 0 0\nv 1 0\n", "test.obj:2:"),
            ("v 0 0 0\nv 1 x 0\n", "test.obj:2:"),
            ("v 0 0 0\n\nv 1 NaN 0\n", "test.obj:3:"),
            ("v 0 0 0\nv 1 inf 0\n", "test.obj:2:"),
            ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", "test.obj:4:"),
            ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -4\n", "test.obj:4:"),
            ("v 0 0 0\nv 1 0 0\nf 1 2\n", "test.obj:3:"),
            ("\u{1}\u{2}binary\n", "test.obj:1:"),
        ];
        for (text, want) in cases {
            let e = parse(p(), text).unwrap_err().to_string();
            assert!(e.starts_with(want), "{text:?} gave {e}");
        }
    }

    #[test]
    fn no_faces_is_an_empty_mesh() {
        let e = parse(p(), "v 0 0 0\nv 1 0 0\n").unwrap_err().to_string();
        assert!(e.contains("test.obj") && e.contains("no faces"), "{e}");
        let e = parse(p(), "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("zero area"), "{e}");
    }
}
