//! The JSON the page reads, as types serde writes: the state ([`State`]: `GET /api/state` and
//! every change's answer), the options, an export's answer and a refusal (`{"error": ..}`). A
//! key absent in some answers is an enum variant's; a key always there but sometimes `null` is
//! an `Option`.

use std::collections::BTreeMap;

use axum::http::StatusCode;
use axum::Json;
use serde::Serialize;
use stencil_core::layers::SetReport;
use stencil_core::report::Report;
use stencil_core::tiles::TilesReport;

use crate::outcome::{histogram, Done, Reuse, Shown};
use crate::params::{OptionSpec, OptionValue};

/// A refused request: its status and `{"error": MESSAGE}`.
pub(crate) type Refusal = (StatusCode, Json<Failure>);

/// The body of a refused request.
#[derive(Serialize)]
pub(crate) struct Failure {
    error: String,
}

pub(crate) fn bad(status: StatusCode, msg: impl Into<String>) -> Refusal {
    let error = msg.into();
    (status, Json(Failure { error }))
}

/// `GET /api/options`: `make`'s options, the input and the output folder.
#[derive(Serialize)]
pub(crate) struct Options<'a> {
    pub(crate) options: &'a [OptionSpec],
    pub(crate) input: String,
    pub(crate) out: String,
}

/// `POST /api/export`: the files written and removed (relative to `dir`), and the command line
/// and version they are of.
#[derive(Serialize)]
pub(crate) struct Exported {
    pub(crate) dir: String,
    pub(crate) files: Vec<String>,
    pub(crate) removed: Vec<String>,
    pub(crate) command: String,
    pub(crate) version: u64,
}

/// The state: the options and history as they are now, and the newest result computed.
#[derive(Serialize)]
pub(crate) struct State<'a> {
    /// The newest version asked for.
    pub(crate) version: u64,
    /// The version `shows` is of.
    pub(crate) shown: u64,
    pub(crate) updating: bool,
    /// The preview is this version's; the trace and the check are still running.
    pub(crate) checking: bool,
    pub(crate) params: BTreeMap<String, OptionValue>,
    pub(crate) command: String,
    pub(crate) can_undo: bool,
    pub(crate) can_redo: bool,
    pub(crate) ms: f64,
    /// The input changed on disk and was read again for this result.
    pub(crate) notice: Option<&'a str>,
    #[serde(flatten)]
    pub(crate) shows: Shows<'a>,
}

/// What the result shown is: an error, one stencil, a set, or tiles.
#[derive(Serialize)]
#[serde(untagged)]
pub(crate) enum Shows<'a> {
    Error {
        error: &'a str,
    },
    One {
        report: &'a Report,
        /// Why `make` would write nothing, in `make`'s words.
        refused: Option<&'a str>,
        /// The stages this run computed.
        ran: &'a [&'static str],
        otsu: u8,
        histogram: Vec<u64>,
        mm_per_px: f64,
        width_px: u32,
        height_px: u32,
    },
    /// The page shows one stencil of the set at a time (`layer_reports[k]`; `report` is the
    /// first) or the composite.
    Set {
        set: &'a SetReport,
        report: &'a Report,
        layer_reports: Vec<&'a Report>,
        histogram: Vec<u64>,
        mm_per_px: f64,
        width_px: u32,
        height_px: u32,
        composite_px: [u32; 2],
    },
    /// The page shows the whole picture's map (`tiles.png`) with the seams drawn over it from
    /// `tiles.seams` (in working pixels of the whole picture, `width_px` × `height_px`), or one
    /// tile's stencil (`tile_reports[k]`; `report` is the first).
    Tiles {
        tiles: &'a TilesReport,
        report: &'a Report,
        tile_reports: Vec<&'a Report>,
        mm_per_px: f64,
        width_px: u32,
        height_px: u32,
        map_px: [u32; 2],
    },
}

impl<'a> Shows<'a> {
    /// What `done` shows; the histogram of a kept working gray is counted once ([`Reuse`]).
    pub(crate) fn of(done: &'a Done, reuse: &Reuse) -> Self {
        match &done.outcome {
            Err(error) => Shows::Error { error },
            Ok(Shown::One(c)) => Shows::One {
                report: &c.report,
                refused: done.refused.as_deref(),
                ran: &c.ran,
                otsu: c.otsu,
                histogram: reuse.histogram_of(&c.gray).to_vec(),
                mm_per_px: c.params.working.scale.mm_per_px,
                width_px: c.report.width_px,
                height_px: c.report.height_px,
            },
            Ok(Shown::Set(set)) => {
                let stencils = set.stencils();
                let luma = &set.set.tones.luma;
                Shows::Set {
                    set: &set.set.report,
                    report: &stencils[0].report,
                    layer_reports: stencils.iter().map(|m| &m.report).collect(),
                    histogram: histogram(luma),
                    mm_per_px: stencils[0].scale.mm_per_px,
                    width_px: stencils[0].report.width_px,
                    height_px: stencils[0].report.height_px,
                    composite_px: [luma.width, luma.height],
                }
            }
            Ok(Shown::Tiles(t)) => {
                let stencils = t.stencils();
                let r = &t.tiled.report;
                Shows::Tiles {
                    tiles: r,
                    report: &stencils[0].report,
                    tile_reports: stencils.iter().map(|m| &m.report).collect(),
                    mm_per_px: r.mm_per_px,
                    width_px: r.size_px[0],
                    height_px: r.size_px[1],
                    map_px: [t.tiled.map.0, t.tiled.map.1],
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The page tells a result's kind by which keys are there: an error's state has `error` and
    /// no `report`, and `notice` is there as `null` when nothing changed on disk.
    #[test]
    fn an_error_state_has_error_and_no_report() {
        let state = State {
            version: 2,
            shown: 1,
            updating: true,
            checking: false,
            params: BTreeMap::from([("layers".into(), OptionValue::One(String::new()))]),
            command: "stencil make in.png".into(),
            can_undo: false,
            can_redo: false,
            ms: 1.5,
            notice: None,
            shows: Shows::Error { error: "bad" },
        };
        let v = serde_json::to_value(&state).unwrap();
        assert_eq!(v["error"], "bad");
        assert_eq!(v["params"], serde_json::json!({ "layers": "" }));
        assert!(v.get("report").is_none() && v.get("refused").is_none());
        assert!(v.get("notice").is_some_and(|n| n.is_null()), "{v}");
        assert_eq!(v["shown"], 1);
    }
}
