//! OBJ loading: a light pre-scan that reports bad lines by number (tobj's errors carry none), then
//! tobj for the parsing proper (triangulation, objects and groups, polygon normals), then one
//! welded triangle soup with smooth vertex normals.

use std::collections::{HashMap, HashSet};
use std::path::Path;

use glam::Vec3;

use super::error::MeshError;
use stencil_io::excerpt;

/// A triangle mesh ready to render: welded positions, triangles, and optionally the file's own
/// normals per triangle corner.
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    /// Vertex positions, welded.
    pub positions: Vec<Vec3>,
    /// Counter-clockwise seen from outside (fixed on load for closed meshes that are inside out).
    pub triangles: Vec<[u32; 3]>,
    /// The file's normals per triangle corner, when every face has them (hard edges stay hard).
    /// `None`: shading uses smooth vertex normals.
    pub(crate) corner_normals: Option<Vec<[Vec3; 3]>>,
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
    pub(crate) fn with_normals(
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
        // A triangle repeated (the same corners the same way round, once welded) draws nothing
        // new, but every copy is rasterised and counted in every edge: 13,000 copies of one face
        // took minutes. Each is kept once (both sides of a sheet are two different triangles).
        let mut seen: HashSet<[u32; 3], BuildFx> =
            HashSet::with_capacity_and_hasher(triangles.len(), BuildFx);
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
            // The same triangle starting from its smallest corner.
            let k = (0..3).min_by_key(|&k| t[k]).unwrap_or(0);
            if !seen.insert([t[k], t[(k + 1) % 3], t[(k + 2) % 3]]) {
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
    pub(crate) fn bounding_sphere(&self) -> (Vec3, f32) {
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
    pub(crate) fn vertex_normals(&self) -> Vec<Vec3> {
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
    pub(crate) fn signed_volume(&self) -> f64 {
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
    let bytes = stencil_io::read_bytes(path, stencil_io::Kind::Mesh)?;
    let text = String::from_utf8(bytes).map_err(|e| MeshError::NotText {
        path: path.to_path_buf(),
        offset: e.utf8_error().valid_up_to(),
    })?;
    parse(path, &text)
}

/// Parse OBJ text (`path` only names it in errors).
pub(crate) fn parse(path: &Path, text: &str) -> Result<Mesh, MeshError> {
    // A byte-order mark (some Windows editors write one) is not part of the first statement.
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    // Line ends as classic Mac OS and some exporters write them, a lone CR, are line ends too
    // (both readers split on LF only, and read a whole file as one line: "a vertex with 61
    // numbers"); CR LF becomes one line end, so line numbers stay those an editor shows.
    let unified;
    let text = if text.contains('\r') {
        unified = text.replace("\r\n", "\n").replace('\r', "\n");
        unified.as_str()
    } else {
        text
    };
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
    check_spread(path, text, &mesh)?;
    Ok(mesh)
}

/// How much larger the whole model may be than the bulk of its vertices (the 90 % between the 5th
/// and 95th percentile along each axis): the picture frames the whole model, so at 500 times the
/// bulk is under 2 pixels of a 1024-pixel picture, a blank stencil.
pub(crate) const MAX_SPREAD: f32 = 500.0;

/// Refuse a model whose extent is a few stray vertices (a vertex at 1e20 among ones within a
/// metre), naming the farthest.
fn check_spread(path: &Path, text: &str, mesh: &Mesh) -> Result<(), MeshError> {
    let p = &mesh.positions;
    let n = p.len();
    // Too few vertices to tell a stray one from the shape.
    if n < 8 {
        return Ok(());
    }
    let trim = (n / 20).max(1);
    let (mut bulk, mut whole) = (0f32, 0f32);
    let mut boxed = [[0f32; 2]; 3];
    let mut c: Vec<f32> = Vec::with_capacity(n);
    for axis in 0..3 {
        c.clear();
        c.extend(p.iter().map(|v| v[axis]));
        let (lo, hi) = c
            .iter()
            .fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), &x| {
                (a.min(x), b.max(x))
            });
        let a = *c.select_nth_unstable_by(trim, f32::total_cmp).1;
        let b = *c.select_nth_unstable_by(n - 1 - trim, f32::total_cmp).1;
        boxed[axis] = [a, b];
        bulk = bulk.max(b - a);
        whole = whole.max(hi - lo);
    }
    if whole <= bulk * MAX_SPREAD {
        return Ok(());
    }
    // The vertex farthest outside the bulk's box.
    let outside = |v: &Vec3| {
        (0..3)
            .map(|k| (boxed[k][0] - v[k]).max(v[k] - boxed[k][1]).max(0.0))
            .fold(0f32, f32::max)
    };
    let far = p
        .iter()
        .copied()
        .max_by(|a, b| outside(a).total_cmp(&outside(b)))
        .unwrap_or(Vec3::ZERO);
    Err(MeshError::Outlier {
        path: path.to_path_buf(),
        line: line_of_vertex(text, far),
        msg: format!(
            "vertex ({}, {}, {}) is {} away from the rest of the model, most of whose vertices lie \
             within {} of each other: framing it would shrink the model to a dot in the picture; \
             remove the stray vertex or fix its coordinates",
            short(far.x),
            short(far.y),
            short(far.z),
            short(outside(&far)),
            short(bulk)
        ),
    })
}

/// A coordinate for a message: plain, or in exponent form when huge or tiny.
fn short(v: f32) -> String {
    if v == 0.0 || (1e-3..1e6).contains(&v.abs()) {
        format!("{v}")
    } else {
        format!("{v:.2e}")
    }
}

/// The line of the first `v` statement at `pos` (as tobj reads it: f32, divided by w).
fn line_of_vertex(text: &str, pos: Vec3) -> Option<usize> {
    text.lines().enumerate().find_map(|(i, raw)| {
        let mut w = raw.split('#').next()?.split_whitespace();
        if w.next()? != "v" {
            return None;
        }
        let n: Vec<f32> = w.map(|t| t.parse().ok()).collect::<Option<_>>()?;
        // x y z w: divided by w; x y z r g b: a colour.
        let s = if n.len() == 4 { n[3] } else { 1.0 };
        (n.len() >= 3 && Vec3::new(n[0] / s, n[1] / s, n[2] / s) == pos).then_some(i + 1)
    })
}

/// What the pre-scan counted.
#[derive(Debug, Default)]
struct Counts {
    vertices: usize,
    faces: usize,
}

/// OBJ statements a mesh file may contain that we either use or may safely ignore, by spaces.
const KNOWN: &str = "v vt vn vp f l p o g s mg usemtl mtllib cstype deg bmat step curv curv2 surf \
    parm trim hole scrv sp end con lod shadow_obj trace_obj ctech stech bevel \
    c_interp d_interp maplib usemap call csh";

/// Check every line tobj will read, so errors name the line (tobj's own errors name none):
/// numbers that do not parse or are not finite, vertices with a number of values tobj refuses (it
/// takes x y z, x y z w or x y z r g b), faces and lines with too few corners or indices pointing
/// at elements that do not exist, unknown statements (a binary file renamed .obj). Text quoted
/// back is cut short ([`excerpt`]).
fn prescan(path: &Path, text: &str) -> Result<Counts, MeshError> {
    let mut scan = Prescan::new(path);
    let mut args: Vec<&str> = Vec::with_capacity(8);
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
            "v" => scan.vertex(line, content, &args)?,
            "vn" | "vt" => scan.attribute(line, kw, content, &args)?,
            "f" | "l" => scan.element(line, kw, &args)?,
            "o" | "g" => {
                if scan.faces_pending {
                    scan.resolve()?;
                    scan.faces_pending = false;
                }
            }
            "usemtl" if args.is_empty() => {
                return Err(scan.malformed(line, "'usemtl' without a material name".into()));
            }
            _ if KNOWN.split(' ').any(|k| k == kw) => {}
            _ => {
                return Err(scan.malformed(
                    line,
                    format!(
                        "unknown statement '{}' (is this an OBJ text file?)",
                        excerpt(kw)
                    ),
                ));
            }
        }
    }
    scan.finish()
}

/// What [`prescan`] has seen so far of one file.
struct Prescan<'a> {
    path: &'a Path,
    faces: usize,
    /// Vertices, texture coordinates and normals so far (what an index may point at).
    nv: usize,
    nt: usize,
    nn: usize,
    /// Vertices with a colour and without: tobj reads a colour per vertex only when every vertex
    /// has one (the first line of each kind, for the message).
    coloured: Option<usize>,
    plain: Option<usize>,
    /// Positive indices may point forward: tobj resolves them when an object or group ends (an
    /// `o` or `g` after faces) and at the end of the file, so they are checked then: (line,
    /// index, kind).
    forward: Vec<(usize, usize, char)>,
    faces_pending: bool,
}

impl<'a> Prescan<'a> {
    fn new(path: &'a Path) -> Self {
        Prescan {
            path,
            faces: 0,
            nv: 0,
            nt: 0,
            nn: 0,
            coloured: None,
            plain: None,
            forward: Vec::new(),
            faces_pending: false,
        }
    }

    fn malformed(&self, line: usize, msg: String) -> MeshError {
        MeshError::Malformed {
            path: self.path.to_path_buf(),
            line,
            msg,
        }
    }

    /// A coordinate as tobj reads it (f32): a number, finite.
    fn coordinate(&self, line: usize, what: &str, tok: &str) -> Result<f32, MeshError> {
        let x: f64 = tok.parse().map_err(|_| {
            self.malformed(line, format!("{what} '{}' is not a number", excerpt(tok)))
        })?;
        if !x.is_finite() || x.abs() > f32::MAX as f64 {
            return Err(MeshError::NonFinite {
                path: self.path.to_path_buf(),
                line,
                token: excerpt(tok),
            });
        }
        Ok(x as f32)
    }

    /// `v x y z [w | r g b]`: the values tobj takes, finite, and a weight that keeps them so.
    fn vertex(&mut self, line: usize, content: &str, args: &[&str]) -> Result<(), MeshError> {
        if args.len() < 3 {
            return Err(self.malformed(
                line,
                format!(
                    "'v' needs 3 numbers (x y z), found {}: \"{}\"",
                    args.len(),
                    excerpt(content)
                ),
            ));
        }
        if !matches!(args.len(), 3 | 4 | 6) {
            return Err(self.malformed(
                line,
                format!(
                    "a vertex ('v') with {} numbers: give x y z, x y z w or x y z r g b",
                    args.len()
                ),
            ));
        }
        let mut p = [0f32; 3];
        for (k, tok) in args.iter().take(3).enumerate() {
            p[k] = self.coordinate(line, "vertex coordinate", tok)?;
        }
        if args.len() == 4 {
            // tobj divides x, y and z by w.
            let w = self.coordinate(line, "vertex weight w", args[3])?;
            if w == 0.0 || p.iter().any(|c| !(c / w).is_finite()) {
                return Err(self.malformed(
                    line,
                    format!(
                        "vertex weight w = {} divides the coordinates to nothing or to infinity",
                        excerpt(args[3])
                    ),
                ));
            }
        }
        let kind = if args.len() == 6 {
            &mut self.coloured
        } else {
            &mut self.plain
        };
        kind.get_or_insert(line);
        self.nv += 1;
        Ok(())
    }

    /// `vn` (tobj reads three numbers) or `vt` (two).
    fn attribute(
        &mut self,
        line: usize,
        kw: &str,
        content: &str,
        args: &[&str],
    ) -> Result<(), MeshError> {
        let (need, what) = if kw == "vn" {
            (3, "normal")
        } else {
            (2, "texture coordinate")
        };
        if args.len() < need {
            return Err(self.malformed(
                line,
                format!(
                    "'{kw}' needs {need} numbers, found {}: \"{}\"",
                    args.len(),
                    excerpt(content)
                ),
            ));
        }
        for tok in args.iter().take(need) {
            self.coordinate(line, what, tok)?;
        }
        if kw == "vn" {
            self.nn += 1;
        } else {
            self.nt += 1;
        }
        Ok(())
    }

    /// `f` (at least three corners) or `l` (two), each corner checked by [`Prescan::corner`].
    fn element(&mut self, line: usize, kw: &str, args: &[&str]) -> Result<(), MeshError> {
        let min = if kw == "f" { 3 } else { 2 };
        if args.len() < min {
            return Err(self.malformed(
                line,
                format!(
                    "a {} needs at least {min} corners, found {}",
                    if kw == "f" { "face" } else { "line" },
                    args.len()
                ),
            ));
        }
        for corner in args {
            self.corner(line, corner)?;
        }
        self.faces_pending = true;
        if kw == "f" {
            self.faces += 1;
        }
        Ok(())
    }

    /// One corner, `v`, `v/vt`, `v//vn` or `v/vt/vn`: integers, not 0, negative ones pointing at
    /// an element seen, positive ones past the elements seen kept for [`Prescan::resolve`].
    fn corner(&mut self, line: usize, corner: &str) -> Result<(), MeshError> {
        for (k, part) in corner.split('/').enumerate() {
            if k > 2 || (part.is_empty() && k == 0) {
                return Err(self.malformed(
                    line,
                    format!(
                        "face corner '{}' is not v, v/vt, v//vn or v/vt/vn",
                        excerpt(corner)
                    ),
                ));
            }
            if part.is_empty() {
                continue;
            }
            let (count, kind) = match k {
                0 => (self.nv, 'v'),
                1 => (self.nt, 't'),
                _ => (self.nn, 'n'),
            };
            let idx: i64 = part.parse().map_err(|_| {
                self.malformed(
                    line,
                    format!(
                        "face index '{}' in '{}' is not an integer",
                        excerpt(part),
                        excerpt(corner)
                    ),
                )
            })?;
            if idx == 0 {
                return Err(self.malformed(
                    line,
                    format!(
                        "face index 0 in '{}': OBJ indices start at 1",
                        excerpt(corner)
                    ),
                ));
            }
            if idx < 0 {
                if idx.unsigned_abs() as usize > count {
                    return Err(bad_index(self.path, line, idx, count, kind));
                }
            } else if idx as usize > count {
                self.forward.push((line, idx as usize, kind));
            }
        }
        Ok(())
    }

    /// Check the forward indices kept so far against the elements now seen.
    fn resolve(&mut self) -> Result<(), MeshError> {
        for &(line, idx, kind) in &self.forward {
            let count = match kind {
                'v' => self.nv,
                't' => self.nt,
                _ => self.nn,
            };
            if idx > count {
                return Err(bad_index(self.path, line, idx as i64, count, kind));
            }
        }
        self.forward.clear();
        Ok(())
    }

    /// At the end of the file: the forward indices, and colours on every vertex or none.
    fn finish(mut self) -> Result<Counts, MeshError> {
        self.resolve()?;
        if let (Some(c), Some(p)) = (self.coloured, self.plain) {
            return Err(self.malformed(
                c.max(p),
                format!(
                    "vertices with a colour (first at line {c}) and without (first at line {p}): \
                     give every vertex a colour or none"
                ),
            ));
        }
        Ok(Counts {
            vertices: self.nv,
            faces: self.faces,
        })
    }
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
mod tests;
