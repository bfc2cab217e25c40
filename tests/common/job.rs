//! A G-code job like the ones `stencil` writes, for tests and benches: squares and circles as G1
//! segments, G0 travel, M4 laser mode with S power and F feed. `copies` repeats the pattern.

pub fn job_text_scaled(copies: usize) -> String {
    let mut s = String::from("; test job: six squares, four circles\nG21 G90\nM4 S0\n");
    for c in 0..copies {
        let dy = c as f64 * 50.0;
        for k in 0..6 {
            let (x0, y0) = (5.0 + k as f64 * 12.0, 5.0 + dy);
            s += &format!("G0 X{x0:.3} Y{y0:.3}\nS{}\n", 400 + 50 * k);
            let corners = [
                (0.0, 0.0),
                (10.0, 0.0),
                (10.0, 10.0),
                (0.0, 10.0),
                (0.0, 0.0),
            ];
            for e in 0..4 {
                let (a, b) = (corners[e], corners[e + 1]);
                for i in 1..=5 {
                    let t = i as f64 / 5.0;
                    let x = x0 + a.0 + (b.0 - a.0) * t;
                    let y = y0 + a.1 + (b.1 - a.1) * t;
                    let f = if e == 0 && i == 1 { " F1200" } else { "" };
                    s += &format!("G1 X{x:.3} Y{y:.3}{f}\n");
                }
            }
        }
        for k in 0..4 {
            let (cx, cy, r) = (10.0 + k as f64 * 15.0, 30.0 + dy, 5.0);
            s += &format!("S0\nG0 X{:.3} Y{cy:.3} (circle {k})\nS900\n", cx + r);
            for i in 1..=32 {
                let a = i as f64 / 32.0 * std::f64::consts::TAU;
                s += &format!("G1 X{:.3} Y{:.3}\n", cx + r * a.cos(), cy + r * a.sin());
            }
        }
    }
    s += "M5\nG0 X0 Y0\n";
    s
}
