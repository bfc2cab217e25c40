//! The user's say in where bridges go: areas no bridge may cross (`--keep-out`, `--no-bridge-near`)
//! and places a bridge must start near (`--bridge-at`).
//!
//! Forbidden pixels are handed to every strip through `super::strips::Fields::with_forbidden`:
//! a walk or a shortest-gap strip that runs into one is dropped, and the fallback search never
//! steps on one, so the tree only ever chooses among allowed strips. An island that can only be
//! joined through forbidden pixels is an error naming it and where it is
//! ([`super::BridgeError::KeptOut`]), never a floating piece.
//!
//! A requested place gets a bridge from the island under the point (or the island nearest it):
//! of that island's scored candidates (any kind, to any other node), the one starting nearest the
//! point. It joins the tree's bridges (and holds the island for the strength rules).

use std::sync::Arc;

use super::Graph;
use crate::islands::{IslandMap, CUT, FRAME};
use crate::raster::BitGrid;

/// The user's constraints. The millimetre fields are what the user gave (millimetres from the
/// picture's top left corner, x right, y down, as the report's positions); `make`'s pipeline
/// turns them into the pixel fields, which are what the bridge stage reads.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct UserBridges {
    /// `--no-bridge-near X,Y,R`, mm.
    pub no_bridge_near_mm: Vec<[f64; 3]>,
    /// `--bridge-at X,Y`, mm.
    pub at_mm: Vec<[f64; 2]>,
    /// `--min-island-mm2`: islands smaller than this are cut away instead of bridged.
    pub min_island_mm2: f64,
    /// Pixels no bridge may cross, the image's size.
    pub keep_out: Option<Arc<BitGrid>>,
    /// Places a bridge should start near, (x, y) in pixels.
    pub at: Vec<[f64; 2]>,
    /// `--keep-all-islands`: bridge every island, never drop one whose bridge would change the
    /// picture more than dropping it (see `bridge::drop`).
    pub keep_all_islands: bool,
}

/// What became of one `--bridge-at` request.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Request {
    /// The point asked for, pixels.
    pub at_px: [f64; 2],
    /// The island it was taken to mean (under the point, or the nearest).
    pub island: u32,
    /// Where the bridge starts, pixels, and how far that is from the point.
    pub start_px: Option<[f64; 2]>,
    pub distance_px: Option<f64>,
}

/// For each requested point, the candidate to add (if the island has an allowed one) and the
/// island. `None` when there is no island at all.
pub(super) fn requested(
    g: &Graph,
    map: &IslandMap,
    at: &[[f64; 2]],
) -> Vec<(Option<usize>, Request)> {
    at.iter()
        .filter_map(|&p| {
            let island = island_at(map, g, p)?;
            let best = g
                .by_pair
                .iter()
                .filter(|(&(a, b), _)| a == island || b == island)
                .flat_map(|(_, ids)| ids.iter().copied())
                .filter(|&id| g.scores[id].is_some() && g.cands.node(id) == island)
                .map(|id| {
                    let (x, y) = g.cands.pixels[id];
                    let d = (x as f64 + 0.5 - p[0]).hypot(y as f64 + 0.5 - p[1]);
                    (d, id)
                })
                .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            Some((
                best.map(|(_, id)| id),
                Request {
                    at_px: p,
                    island,
                    start_px: best.map(|(_, id)| {
                        let (x, y) = g.cands.pixels[id];
                        [x as f64 + 0.5, y as f64 + 0.5]
                    }),
                    distance_px: best.map(|(d, _)| d),
                },
            ))
        })
        .collect()
}

/// The island under `p`, or the one whose border pixel is nearest it.
fn island_at(map: &IslandMap, g: &Graph, p: [f64; 2]) -> Option<u32> {
    let (x, y) = (p[0].floor(), p[1].floor());
    if x >= 0.0 && y >= 0.0 && x < map.width as f64 && y < map.height as f64 {
        let l = map.label(x as u32, y as u32);
        if l != CUT && l != FRAME {
            return Some(l);
        }
    }
    (0..g.cands.originals())
        .map(|id| {
            let (cx, cy) = g.cands.pixels[id];
            ((cx as f64 + 0.5 - p[0]).hypot(cy as f64 + 0.5 - p[1]), id)
        })
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(_, id)| g.cands.node(id))
}
