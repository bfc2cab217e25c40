//! Generate the sample pictures in `samples/` from geometry: `cargo run -p stencil-core --example make_samples`.
//!
//! Each picture is a dark design (to be cut) on white paper (the sheet), drawn at 4×4 supersampling
//! so edges are anti-aliased the way a real scan or export is. Deterministic: same bytes every run.

use std::path::Path;

const SS: u32 = 4;

/// A picture as a function from a point (in pixels) to gray 0..1.
fn render(path: &Path, w: u32, h: u32, f: impl Fn(f64, f64) -> f64) {
    let mut buf = Vec::with_capacity((w * h) as usize);
    for y in 0..h {
        for x in 0..w {
            let mut acc = 0.0;
            for sy in 0..SS {
                for sx in 0..SS {
                    let px = x as f64 + (sx as f64 + 0.5) / SS as f64;
                    let py = y as f64 + (sy as f64 + 0.5) / SS as f64;
                    acc += f(px, py);
                }
            }
            buf.push((acc / (SS * SS) as f64 * 255.0).round().clamp(0.0, 255.0) as u8);
        }
    }
    image::save_buffer(path, &buf, w, h, image::ExtendedColorType::L8).expect("write sample");
    println!("wrote {}", path.display());
}

fn dist(ax: f64, ay: f64, bx: f64, by: f64) -> f64 {
    ((ax - bx).powi(2) + (ay - by).powi(2)).sqrt()
}

/// Distance from a point to a segment.
fn seg(px: f64, py: f64, ax: f64, ay: f64, bx: f64, by: f64) -> f64 {
    let (dx, dy) = (bx - ax, by - ay);
    let t = (((px - ax) * dx + (py - ay) * dy) / (dx * dx + dy * dy)).clamp(0.0, 1.0);
    dist(px, py, ax + t * dx, ay + t * dy)
}

const INK: f64 = 0.08;
const PAPER: f64 = 1.0;

fn main() {
    // The repository's samples/, two levels above this crate.
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../samples");
    std::fs::create_dir_all(&dir).expect("samples dir");
    rings(&dir);
    target(&dir);
    letters(&dir);
    blobs(&dir);
    shaded(&dir);
}

fn rings(dir: &Path) {
    // Nested rings five deep: alternating ink and paper rings around a paper disc. Each paper ring
    // inside an ink ring is an island; the innermost disc is an island inside five of them.
    render(&dir.join("rings.png"), 320, 320, |x, y| {
        let r = dist(x, y, 160.0, 160.0);
        if r > 150.0 {
            return PAPER;
        }
        // Bands of 15 px: ink, paper, ink, paper, ... from the outside in.
        let band = ((150.0 - r) / 15.0).floor() as i64;
        if band % 2 == 0 {
            INK
        } else {
            PAPER
        }
    });
}

/// A target: three rings crossed by two ink bars, so each ring falls apart into four arcs.
fn target(dir: &Path) {
    render(&dir.join("target.png"), 300, 300, |x, y| {
        let r = dist(x, y, 150.0, 150.0);
        let bar = (x - 150.0).abs() < 6.0 || (y - 150.0).abs() < 6.0;
        if r < 130.0 && bar {
            return INK;
        }
        let ring = (r / 22.0).floor() as i64;
        if r < 132.0 && ring % 2 == 1 {
            INK
        } else {
            PAPER
        }
    });
}

/// Letters O A B 8 as thick strokes: their counters (the paper inside) are the islands a
/// lettering stencil always has to bridge.
fn letters(dir: &Path) {
    render(&dir.join("letters.png"), 480, 160, |x, y| {
        let stroke = 11.0;
        // O: an elliptical ring centred at (60, 80).
        let o = {
            let (dx, dy) = ((x - 60.0) / 42.0, (y - 80.0) / 58.0);
            let r = (dx * dx + dy * dy).sqrt();
            (r - 1.0).abs() * 48.0 < stroke
        };
        // A: two slanted strokes and a crossbar.
        let a = seg(x, y, 180.0, 22.0, 140.0, 140.0) < stroke
            || seg(x, y, 180.0, 22.0, 220.0, 140.0) < stroke
            || seg(x, y, 158.0, 95.0, 202.0, 95.0) < stroke * 0.8;
        // B: a stem and two bowls.
        let b = seg(x, y, 262.0, 22.0, 262.0, 138.0) < stroke
            || {
                let r = dist(x, y, 290.0, 51.0);
                (r - 29.0).abs() < stroke && x > 262.0
            }
            || {
                let r = dist(x, y, 292.0, 108.0);
                (r - 31.0).abs() < stroke && x > 262.0
            }
            || (seg(x, y, 262.0, 22.0, 290.0, 22.0) < stroke)
            || (seg(x, y, 262.0, 138.0, 292.0, 138.0) < stroke);
        // 8: two stacked rings.
        let eight = (dist(x, y, 410.0, 50.0) - 28.0).abs() < stroke
            || (dist(x, y, 410.0, 109.0) - 31.0).abs() < stroke;
        if o || a || b || eight {
            INK
        } else {
            PAPER
        }
    });
}

/// Random blobs: ink blobs, some with paper spots inside (islands), from a fixed seed.
fn blobs(dir: &Path) {
    let mut seed = 0x5eed_u64;
    let mut rnd = move || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((seed >> 11) as f64) / ((1u64 << 53) as f64)
    };
    let blobs: Vec<(f64, f64, f64)> = (0..16)
        .map(|_| {
            (
                30.0 + rnd() * 340.0,
                30.0 + rnd() * 240.0,
                12.0 + rnd() * 26.0,
            )
        })
        .collect();
    let spots: Vec<(f64, f64, f64)> = blobs
        .iter()
        .filter(|b| b.2 > 20.0)
        .map(|&(x, y, r)| {
            (
                x + (rnd() - 0.5) * r * 0.4,
                y + (rnd() - 0.5) * r * 0.4,
                r * (0.25 + rnd() * 0.2),
            )
        })
        .collect();
    render(&dir.join("blobs.png"), 400, 300, move |x, y| {
        // A smooth union of discs (metaball field) so blobs merge organically.
        let field: f64 = blobs
            .iter()
            .map(|&(bx, by, r)| (r * r) / ((x - bx).powi(2) + (y - by).powi(2) + 1.0))
            .sum();
        let in_spot = spots.iter().any(|&(sx, sy, r)| dist(x, y, sx, sy) < r);
        if field > 2.5 && !in_spot {
            INK
        } else {
            PAPER
        }
    });
}

/// A shaded shape: a paper disc inside a ring whose ink is shaded from black (left) to dark
/// gray (right, still below the default threshold). The ring is cut everywhere, but a bridge
/// over its light side hides less of the picture: the intensity term's case.
fn shaded(dir: &Path) {
    render(&dir.join("shaded.png"), 320, 240, |x, y| {
        let r = dist(x, y, 160.0, 120.0);
        if r < 55.0 {
            PAPER
        } else if r < 95.0 {
            // 0.02 at the far left of the ring to 0.45 at the far right.
            0.02 + 0.43 * ((x - 65.0) / 190.0).clamp(0.0, 1.0)
        } else {
            PAPER
        }
    });
}
