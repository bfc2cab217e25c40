use stencil::bridge::*;
use stencil::islands::label;
use stencil::raster::{BitGrid, Gray, TwoTone};
struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}
include!("/tmp/picture.rs");
#[test]
fn prof() {
    let two = picture(1280, 720, 100, 7);
    let map = label(&two.bits);
    let f = strips::Fields::new(&two, &map);
    let c = candidates::collect(&map);
    let mut ok = 0;
    let mut steps = 0;
    let mut ends = std::collections::HashMap::new();
    let mut hist = [0usize; 10];
    for id in 0..c.len() {
        match strips::walk_candidate(&f, &c, id, 200) {
            Ok(s) => {
                ok += 1;
                steps += s.len();
                hist[(s.len() / 20).min(9)] += 1;
            }
            Err(e) => {
                *ends.entry(format!("{e:?}")).or_insert(0) += 1;
            }
        }
    }
    eprintln!(
        "cands {} ok {} steps {} ends {:?} hist {:?} chains {}",
        c.len(),
        ok,
        steps,
        ends,
        hist,
        c.chains.len()
    );
}
