//! The progress line of `make`, `tone` and `check`: a spinner, the elapsed time and the stage, on
//! stderr, only when stderr is a terminal, and only once a run has taken longer than
//! [`SHOW_AFTER`] (a quick run shows nothing). The library reports stages through
//! [`stencil_core::pipeline::Progress`]; this is the one implementation that draws.

use std::io::IsTerminal;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// A run shorter than this shows no progress line.
pub const SHOW_AFTER: Duration = Duration::from_millis(500);

/// Set to a number of milliseconds to show the line sooner or later (tests run small pictures).
const DELAY_ENV: &str = "STENCIL_PROGRESS_AFTER_MS";

/// What a stage of the pipeline is doing, for a person.
fn describe(stage: &str) -> String {
    let what = match stage {
        "tone" => "reading the picture and making the two tones",
        "filter" => "cleaning up thin webs and holes",
        "islands" => "finding islands",
        "bridge" => "placing bridges",
        "tidy" => "settling the bridges",
        "verify" => "checking the stencil is one piece",
        "vector" => "tracing the outlines",
        "check" | "check_opening" => "checking widths against the material",
        "repair" => "widening necks the check found",
        "recount" => "counting each bridge's pixels",
        "fidelity" => "measuring what changed",
        "kerf" => "offsetting for the kerf",
        "gcode" => "planning the G-code",
        "write" => "writing the files",
        "read" => "reading the stencil",
        other => other,
    };
    format!("{what} ({stage})")
}

/// The progress line. Dropping it clears it.
pub struct StageBar {
    bar: ProgressBar,
    /// Set when the run is over; the thread that shows the line checks it under the same lock.
    finished: Arc<Mutex<bool>>,
}

impl StageBar {
    /// A progress line on stderr if it is a terminal, else one that draws nothing.
    pub fn start() -> Arc<StageBar> {
        let bar = ProgressBar::with_draw_target(None, ProgressDrawTarget::hidden());
        bar.set_style(
            ProgressStyle::with_template("{spinner} {elapsed} {wide_msg}")
                .unwrap_or_else(|_| ProgressStyle::default_spinner()),
        );
        let finished = Arc::new(Mutex::new(false));
        if std::io::stderr().is_terminal() {
            let delay = std::env::var(DELAY_ENV)
                .ok()
                .and_then(|v| v.parse().ok())
                .map_or(SHOW_AFTER, Duration::from_millis);
            let (bar, finished) = (bar.clone(), finished.clone());
            std::thread::spawn(move || {
                std::thread::sleep(delay);
                let done = finished.lock().unwrap_or_else(|e| e.into_inner());
                if !*done {
                    bar.set_draw_target(ProgressDrawTarget::stderr());
                    bar.enable_steady_tick(Duration::from_millis(120));
                }
            });
        }
        Arc::new(StageBar { bar, finished })
    }

    /// Show a stage the CLI runs itself (outside the pipeline's own stages).
    pub fn set(&self, stage: &str) {
        self.bar.set_message(describe(stage));
    }

    /// Clear the line (before printing results).
    pub fn finish(&self) {
        let mut done = self.finished.lock().unwrap_or_else(|e| e.into_inner());
        *done = true;
        self.bar.finish_and_clear();
    }
}

impl stencil_core::pipeline::Progress for StageBar {
    fn stage(&self, name: &str) {
        self.set(name);
    }
}

impl Drop for StageBar {
    fn drop(&mut self) {
        self.finish();
    }
}
