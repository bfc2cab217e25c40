//! Flow control: lines on their way to Grbl (character counting or send-response), their
//! acknowledgements and rejections, status polling while they run, and the `$C` check pass.

use std::collections::VecDeque;
use std::time::{Duration, Instant};

use super::config::FlowControl;
use super::observe::{Progress, Summary};
use super::session::Session;
use super::tracker::Tracker;
use crate::error::Unanswered;
use crate::error::{CheckRejection, Halt, MachineError};
use crate::program::{Program, ProgramLine};
use crate::protocol::{MachineState, Reply, Status, RT_STATUS};
use stencil_gcode::interpret as gcode;

/// A line as it goes out: program lines and the resume preamble.
#[derive(Clone)]
pub(super) struct Outgoing {
    /// File line (the resume point for preamble lines).
    pub(super) number: usize,
    pub(super) text: String,
    pub(super) motion: bool,
    pub(super) preamble: bool,
}

impl Outgoing {
    /// A program line, as it goes out.
    pub(super) fn program(l: &ProgramLine) -> Outgoing {
        Outgoing {
            number: l.number,
            text: l.text.clone(),
            motion: l.motion,
            preamble: false,
        }
    }
}

/// A Grbl system command (`$x=value`, `$H`, `$X`...), not G-code.
pub(super) fn is_system(line: &str) -> bool {
    line.starts_with('$')
}

impl Session<'_, '_> {
    /// Run the lines through `$C` check mode; refuse if any errors.
    pub(super) fn check(&mut self, job: &Program, body: &[Outgoing]) -> Result<(), MachineError> {
        self.obs
            .message("checking the program in Grbl's check mode ($C)");
        self.command("$C")?;
        self.obs.phase(true, body.len());
        // Grbl refuses `$` commands in check mode (error:8): they are not G-code to vet.
        let skipped = body.iter().filter(|l| is_system(&l.text)).count();
        if skipped > 0 {
            self.obs.message(&format!(
                "{skipped} `$` command line(s) are not checked (Grbl does not run them in check mode)"
            ));
        }
        let lines: Vec<Outgoing> = body
            .iter()
            .filter(|l| !is_system(&l.text))
            .map(|l| Outgoing {
                motion: false,
                ..l.clone()
            })
            .collect();
        let rejected = self.stream_inner(&lines, true, 1)?.rejected;
        // Leaving check mode soft-resets Grbl: wait for its banner.
        self.command("$C")?;
        let (mut alarm, mut hinted) = (None, false);
        if self
            .wait_welcome(self.cfg.timeout, &mut alarm, &mut hinted)?
            .is_none()
        {
            return Err(self.no_answer());
        }
        if !rejected.is_empty() {
            return Err(MachineError::CheckFailed {
                file: job.name.clone(),
                rejected,
            });
        }
        self.obs
            .message("check mode passed: every line was accepted");
        Ok(())
    }

    pub(super) fn stream(
        &mut self,
        lines: &[Outgoing],
        checking: bool,
        start_line: usize,
    ) -> Result<Summary, MachineError> {
        let run = self.stream_inner(lines, checking, start_line)?;
        Ok(Summary {
            lines: run.acked,
            bytes: run.bytes,
            elapsed: run.elapsed,
            rx_limit: self.rx_limit(),
            max_in_flight: run.max_in_flight,
            total: self.started.elapsed(),
            info: self.info.clone(),
        })
    }

    /// Stream `lines` until every one is answered and, for a real run, the machine has finished
    /// moving; in check mode (`checking`) rejected lines are collected instead of stopping.
    fn stream_inner(
        &mut self,
        lines: &[Outgoing],
        checking: bool,
        start_line: usize,
    ) -> Result<Run, MachineError> {
        let mut f = Flight::new(lines, start_line, self.info.planner_blocks);
        let mut last_poll = Instant::now() - self.cfg.poll_interval;
        self.link.last_heard = Instant::now();
        self.started = Instant::now();

        loop {
            self.apply_controls(&mut f)?;
            self.fill(&mut f)?;
            // Done when every line is acknowledged and, for a real run, the machine has finished
            // moving (`ok` only means queued).
            if f.acked_total == lines.len() && (checking || f.finished) {
                break;
            }
            if last_poll.elapsed() >= self.cfg.poll_interval {
                if let Err(e) = self.link.write(&[RT_STATUS]) {
                    return Err(self.fault(e, &f));
                }
                last_poll = Instant::now();
            }
            let wait = self
                .cfg
                .poll_interval
                .saturating_sub(last_poll.elapsed())
                .min(Duration::from_millis(50));
            let line = match self.link.line(wait) {
                Ok(Some(l)) => l,
                Ok(None) => continue,
                Err(e) => return Err(self.fault(e, &f)),
            };
            self.on_reply(&mut f, &line, checking)?;
        }
        Ok(f.run)
    }

    /// The most bytes character counting keeps in flight: the receive buffer less one.
    pub(super) fn rx_limit(&self) -> usize {
        self.info.rx_buffer.saturating_sub(1).max(1)
    }

    /// Fill Grbl's receive buffer as far as the flow control allows.
    fn fill(&mut self, f: &mut Flight<'_>) -> Result<(), MachineError> {
        let (lines, rx_limit) = (f.lines, self.rx_limit());
        while f.next < lines.len() {
            let next = f.next;
            let len = lines[next].text.len() + 1;
            // `$` commands (settings written to EEPROM, homing...) go alone: Grbl stops
            // listening to the port while it writes EEPROM, so nothing may follow them until
            // they are answered.
            let after_system = f
                .in_flight
                .back()
                .is_some_and(|s| is_system(&lines[s.index].text));
            let fits = match self.cfg.flow {
                _ if after_system => false,
                _ if is_system(&lines[next].text) => f.in_flight.is_empty(),
                FlowControl::CharacterCounting => f.in_flight_bytes + len <= rx_limit,
                FlowControl::SendResponse => f.in_flight.is_empty(),
            };
            if !fits {
                break;
            }
            if !lines[next].preamble {
                self.obs.sending(lines[next].number);
            }
            let bytes = [lines[next].text.as_bytes(), b"\n"].concat();
            if let Err(e) = self.link.write(&bytes) {
                return Err(self.fault(e, f));
            }
            if !lines[next].preamble {
                f.first_byte.get_or_insert_with(Instant::now);
                f.run.bytes += len as u64;
            }
            f.in_flight.push_back(Sent {
                index: next,
                bytes: len,
                polls_before: self.link.polls_sent,
            });
            f.in_flight_bytes += len;
            f.run.max_in_flight = f.run.max_in_flight.max(f.in_flight_bytes);
            f.next += 1;
        }
        Ok(())
    }

    /// Act on one line from Grbl: an answer to the oldest line in flight, a status report, an
    /// alarm or a restart (which end the run), or a message for the front end.
    fn on_reply(
        &mut self,
        f: &mut Flight<'_>,
        line: &str,
        checking: bool,
    ) -> Result<(), MachineError> {
        match Reply::parse(line) {
            Reply::Ok | Reply::Error(_) if f.in_flight.is_empty() => {
                self.obs.message(&format!(
                    "Grbl answered `{line}` with no line waiting; ignored"
                ));
            }
            Reply::Ok => {
                f.ack();
                if let Some(t) = f.first_byte {
                    f.run.elapsed = t.elapsed();
                }
                f.progress.elapsed = self.started.elapsed();
                self.obs.progress(&f.progress);
            }
            Reply::Error(code) => {
                let Some(l) = f.reject() else { return Ok(()) };
                if checking {
                    f.run.rejected.push(CheckRejection {
                        line: l.number,
                        text: l.text.clone(),
                        code,
                    });
                    return Ok(());
                }
                self.settle(Some(f));
                let halt = self.halt(f.run.last_acked, f.resume_at(Some(l.number)));
                return Err(MachineError::Rejected {
                    line: l.number,
                    text: l.text.clone(),
                    code,
                    halt,
                });
            }
            Reply::Alarm(code) => {
                // Grbl has already stopped and dropped its planner: what it held is lost.
                let halt = self.halt(f.run.last_acked, f.resume_at(None));
                return Err(MachineError::Alarm { code, halt });
            }
            Reply::Welcome(..) => {
                // Everything queued was lost with the reset; the laser is off.
                let halt = Halt {
                    last_acked: f.run.last_acked,
                    resume_from: f.resume_at(None),
                    laser: "the controller reset itself, which turns the laser and the air off"
                        .into(),
                    locked: false,
                    position_unsure: Some(
                        "the controller restarted (power or reset) while it may have been moving"
                            .into(),
                    ),
                };
                return Err(MachineError::Restarted { halt });
            }
            Reply::Status(st) => self.on_status(f, st, checking)?,
            Reply::Message(m) => self.obs.message(&format!("Grbl: {m}")),
            Reply::Feedback(fb) => self.obs.message(&format!("Grbl: [{fb}]")),
            Reply::Other(o) => self.obs.message(&format!("Grbl: {o}")),
        }
        Ok(())
    }

    /// A status report: progress, the end of the run (idle with every line answered), and the
    /// stall watch while work is queued.
    fn on_status(
        &mut self,
        f: &mut Flight<'_>,
        st: Status,
        checking: bool,
    ) -> Result<(), MachineError> {
        // Check mode (a job's own `$C`, when allowed) runs nothing: it is as done as Idle.
        f.finished |= f.acked_total == f.lines.len()
            && matches!(st.state, MachineState::Idle | MachineState::Check);
        f.status(&st);
        if !checking {
            let report = self.link.reports_seen;
            if f.lost_replies(&st, report, self.info.planner_blocks, self.info.rx_buffer) {
                let unanswered: Vec<usize> = f
                    .in_flight
                    .iter()
                    .map(|s| f.lines[s.index].number)
                    .collect();
                let all_sent = f.next >= f.lines.len();
                let next_unsent = f.lines.get(f.next).map(|l| l.number);
                self.settle(Some(f));
                let halt = self.halt(f.run.last_acked, f.resume_at(None));
                return Err(MachineError::RepliesLost {
                    port: self.port_name.clone(),
                    lost: Box::new(Unanswered {
                        first: unanswered.first().copied().unwrap_or(0),
                        last: unanswered.last().copied().unwrap_or(0),
                        count: unanswered.len(),
                        all_sent,
                        next_unsent,
                    }),
                    halt,
                });
            }
            // Work is queued: lines in flight, or planner blocks in use (unknown without `Bf:`,
            // then assumed).
            let busy = !f.in_flight.is_empty()
                || st
                    .buffer
                    .is_none_or(|(free, _)| (free as usize) < self.info.planner_blocks);
            if let Some(stuck) = self.stall.observe(self.cfg.clock.0.now(), &st, busy) {
                self.settle(Some(f));
                let halt = self.halt(f.run.last_acked, f.resume_at(None));
                return Err(MachineError::Stalled {
                    port: self.port_name.clone(),
                    still_s: stuck.still_for.as_secs_f64(),
                    bound_s: stuck.bound.as_secs_f64(),
                    position: Box::new(stuck.position),
                    halt,
                });
            }
        }
        f.progress.elapsed = self.started.elapsed();
        self.obs.progress(&f.progress);
        Ok(())
    }
}

/// The state of lines on their way to Grbl.
#[derive(Default)]
pub(super) struct Flight<'l> {
    pub(super) lines: &'l [Outgoing],
    pub(super) start_line: usize,
    /// Lines sent and not yet answered, oldest first.
    pub(super) in_flight: VecDeque<Sent>,
    pub(super) in_flight_bytes: usize,
    /// Lines answered, preamble included.
    pub(super) acked_total: usize,
    pub(super) run: Run,
    pub(super) tracker: Tracker,
    pub(super) progress: Progress,
    /// Index into `lines` of the next line to send.
    pub(super) next: usize,
    /// When the first program byte went out (the run's elapsed time counts from here).
    pub(super) first_byte: Option<Instant>,
    /// Every line answered and the machine seen idle since.
    pub(super) finished: bool,
    /// Status reports in a row that show Grbl idle with empty buffers after it read the oldest
    /// line still waiting for its answer.
    quiet: Option<Quiet>,
}

/// A line sent and not yet answered.
pub(super) struct Sent {
    /// Index into the flight's lines.
    pub(super) index: usize,
    /// Its bytes with the newline (what it holds of Grbl's receive buffer).
    pub(super) bytes: usize,
    /// Status requests written before it ([`super::link::Link::polls_sent`]): only a report
    /// counted later than this was written after Grbl read the line.
    pub(super) polls_before: u64,
}

/// The evidence that one line's answer was lost.
struct Quiet {
    /// The line (index into the flight's lines) the reports are about.
    index: usize,
    /// Reports since it was read that show Grbl idle with empty buffers.
    reports: u32,
    /// When the first of them was read.
    since: Instant,
}

impl<'l> Flight<'l> {
    /// Nothing sent yet; `start_line` is where a stop before any answer resumes.
    fn new(lines: &'l [Outgoing], start_line: usize, planner_blocks: usize) -> Self {
        Flight {
            lines,
            start_line,
            tracker: Tracker {
                planner_blocks,
                ..Tracker::default()
            },
            progress: Progress {
                total: lines.iter().filter(|l| !l.preamble).count(),
                unexecuted_from: start_line,
                ..Progress::default()
            },
            ..Flight::default()
        }
    }

    /// Answers were lost: a status report written after Grbl read the oldest line still
    /// waiting for its `ok` shows Grbl idle with nothing in its planner and nothing left in its
    /// receive buffer (`Bf:`), so it has run that line, and Grbl writes a line's `ok` before any
    /// later report; the serial line keeps that order, so the `ok` was dropped on the wire or
    /// garbled into something that is no answer.
    ///
    /// `report` is the report's count ([`super::link::Link::reports_seen`]): a report counted no
    /// later than the line's [`Sent::polls_before`] may have been written before the line arrived
    /// (a sender that writes lines while earlier reports wait to be read, as a busy computer
    /// does), and proves nothing. The timing of either side plays no part in that rule; the
    /// count and time below only ride out a report written while Grbl is still finishing the
    /// line (three reports over at least a second, without `Bf:` Idle alone over three seconds),
    /// and start again for each line. A dwell (G4) in flight is answered only when it ends, so
    /// it is waited for.
    fn lost_replies(
        &mut self,
        st: &Status,
        report: u64,
        planner_blocks: usize,
        rx_buffer: usize,
    ) -> bool {
        let Some(oldest) = self.in_flight.front() else {
            self.quiet = None;
            return false;
        };
        let dwell = self.in_flight.iter().any(|s| {
            gcode::words(&self.lines[s.index].text, 0)
                .is_ok_and(|w| w.iter().any(|&(l, v)| l == 'G' && v == 4.0))
        });
        let empty = st
            .buffer
            .is_none_or(|(b, rx)| b as usize >= planner_blocks && rx as usize + 1 >= rx_buffer);
        if dwell || st.state != MachineState::Idle || !empty {
            self.quiet = None;
            return false;
        }
        if report <= oldest.polls_before {
            return false;
        }
        let index = oldest.index;
        let quiet = match &mut self.quiet {
            Some(q) if q.index == index => q,
            q => q.insert(Quiet {
                index,
                reports: 0,
                since: Instant::now(),
            }),
        };
        quiet.reports += 1;
        let long = if st.buffer.is_some() { 1.0 } else { 3.0 };
        quiet.reports >= 3 && quiet.since.elapsed().as_secs_f64() >= long
    }

    /// The oldest line in flight was answered: free its bytes.
    pub(super) fn pop(&mut self) -> Option<&'l Outgoing> {
        let sent = self.in_flight.pop_front()?;
        self.in_flight_bytes -= sent.bytes;
        Some(&self.lines[sent.index])
    }

    pub(super) fn ack(&mut self) {
        let Some(l) = self.pop() else { return };
        self.acked_total += 1;
        if !l.preamble {
            self.run.acked += 1;
            self.run.last_acked = Some(l.number);
            if l.motion {
                self.tracker.acked_motion.push(l.number);
            }
        }
        self.progress.acked = self.run.acked;
        self.progress.last_acked_line = self.run.last_acked;
        self.progress.unexecuted_from = self.resume_at(None);
    }

    /// The oldest line in flight was rejected (in check mode it counts as answered).
    pub(super) fn reject(&mut self) -> Option<&'l Outgoing> {
        let l = self.pop()?;
        self.acked_total += 1;
        if !l.preamble {
            self.run.acked += 1;
        }
        self.progress.acked = self.run.acked;
        Some(l)
    }

    pub(super) fn status(&mut self, st: &Status) {
        self.tracker.status(st);
        self.progress.state = Some(st.state.clone());
        self.progress.position = st.position().or(self.progress.position);
        self.progress.overrides = st.overrides.or(self.progress.overrides);
        self.progress.status_line = st.line.or(self.progress.status_line);
        self.progress.unexecuted_from = self.resume_at(None);
    }

    /// Where to resume if the job stops now: the first line not acknowledged (or the rejected
    /// one), or an earlier acknowledged move that may still have been waiting in the planner.
    pub(super) fn resume_at(&self, failed: Option<usize>) -> usize {
        let first_unanswered = failed
            .or_else(|| self.in_flight.front().map(|s| self.lines[s.index].number))
            .or_else(|| self.lines.get(self.acked_total).map(|l| l.number))
            .unwrap_or_else(|| {
                self.lines
                    .last()
                    .map(|l| l.number + 1)
                    .unwrap_or(self.start_line)
            });
        self.tracker
            .first_unexecuted()
            .map_or(first_unanswered, |u| u.min(first_unanswered))
    }
}

/// What a run (or a check pass) did.
#[derive(Default)]
pub(super) struct Run {
    pub(super) acked: usize,
    pub(super) last_acked: Option<usize>,
    pub(super) bytes: u64,
    pub(super) elapsed: Duration,
    pub(super) max_in_flight: usize,
    pub(super) rejected: Vec<CheckRejection>,
}
