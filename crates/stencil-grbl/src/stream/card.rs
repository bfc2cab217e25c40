//! A job that survives the link: uploaded to the controller's own storage (SD card or flash)
//! with the firmware's upload (grblHAL: YModem, started by its first packet; FluidNC: XModem
//! after `$Xmodem/Receive=`), checked on the card (its size in the listing and the file read
//! back line by line), started there (`$F=` / `$SD/Run=`) and followed by status reports (their
//! `SD:` percent field). The controller reads the job from its card, so a USB or WiFi drop
//! cannot starve or kill the cut; feed hold, resume, overrides and the abort (hold, wait for
//! the head to stand, soft reset, laser off) go over the link as real-time bytes as when
//! streaming.

use std::io;
use std::sync::mpsc::Receiver;
use std::time::{Duration, Instant};

use super::config::{Control, StreamConfig};
use super::link::{BytePort, LinkFault};
use super::observe::{ControllerInfo, Observer};
use super::prepare::{allowed, name_differences, outgoing, rescale};
use super::session::Session;
use crate::error::MachineError;
use crate::program::Program;
use crate::protocol::{Firmware, MachineState, Reply, RT_FEED_HOLD, RT_RESUME, RT_STATUS};
use crate::stall;
use crate::xmodem::{packet, ACK, CAN, CRC_MODE, EOT, NAK};

/// How often a damaged packet is sent again before the upload gives up (grblHAL's receiver
/// gives up after 10 errors).
const RETRIES: usize = 10;
/// How long the receiver may take to answer one packet.
const PACKET_WAIT: Duration = Duration::from_secs(5);
/// Status reports asked for while the card job runs.
const POLL_EVERY: Duration = Duration::from_millis(250);

/// What a job run from the card did.
#[derive(Clone, Debug, PartialEq)]
pub struct CardSummary {
    /// The file's name on the card.
    pub file: String,
    /// Bytes uploaded (the file's size on the card).
    pub bytes: usize,
    /// Lines in the file.
    pub lines: usize,
    /// From the start of the run on the card until the controller stood idle with it done.
    pub elapsed: Duration,
    /// What the controller said on connect.
    pub info: ControllerInfo,
}

/// Upload `job` to the controller's card, check it arrived whole, run it there and follow it
/// until it is done. Connecting, the laser settings and the job's placement are as [`super::send`]
/// does them (the check-mode pass too, when asked), then the same lines that would be streamed
/// go to the card. Grbl 1.1h has no card: refused before anything is sent. A link that drops
/// while the card runs the job ends this with [`MachineError::CardLinkLost`]: the cut goes on,
/// and [`watch_card`] follows it again over a new link.
pub fn send_to_card(
    port: &mut dyn BytePort,
    job: &Program,
    cfg: &StreamConfig,
    controls: Option<&Receiver<Control>>,
    obs: &mut dyn Observer,
) -> Result<CardSummary, MachineError> {
    allowed(job, cfg)?;
    let port_name = port.describe();
    if cfg.from_line > 1 || cfg.recovery.is_some() {
        return Err(MachineError::CardWholeJob { port: port_name });
    }
    let stall = stall::stall_bound(stall::slowest_step(job, cfg.rapid_mm_min));
    let mut s = Session::new(port, cfg, controls, obs, stall);
    s.connect()?;
    if s.info.firmware == Firmware::Grbl {
        return Err(MachineError::NoCard {
            port: port_name,
            firmware: s.info.name(),
        });
    }
    name_differences(&mut s, job);
    s.laser_mode()?;
    if let Some(zero) = cfg.place_zero {
        s.place(zero)?;
    }
    let (mut lines, _) = outgoing(job, Vec::new(), 1);
    rescale(&s, job, &mut lines)?;
    if cfg.check_first {
        s.check(job, &lines)?;
    }
    let mut body: Vec<String> = lines.into_iter().map(|l| l.text).collect();
    // The card job ends with the beam and the air off, as a streamed one is made to.
    if job.may_end_laser_on {
        body.push("M5".into());
    }
    if job.may_end_air_on {
        body.push("M9".into());
    }
    let file = card_name(&job.name);
    let mut text: String = body.iter().map(|l| format!("{l}\n")).collect();
    if s.info.firmware == Firmware::FluidNc {
        // XModem has no file size: its last block is padded. Padding with empty lines (to whole
        // 128-byte blocks) keeps the file on the card exactly what was sent, and harmless.
        let whole = text.len().div_ceil(128) * 128;
        text.push_str(&"\n".repeat(whole - text.len()));
    }
    s.obs.message(&format!(
        "uploading {} to the card of {} as {file} ({} lines, {} bytes)",
        job.name,
        s.info.name(),
        body.len(),
        text.len()
    ));
    s.upload(&file, text.as_bytes())?;
    s.verify(&file, text.len(), &body)?;
    s.obs.message(&format!(
        "{file} is on the card whole ({} bytes, read back line for line): running it there; \
         the cut goes on if the link drops",
        text.len()
    ));
    let run = match s.info.firmware {
        Firmware::GrblHal => format!("$F={file}"),
        _ => format!("$SD/Run={file}"),
    };
    // Its answer is read while following: from here on the job may run on the card, so a link
    // that drops is no longer the end of it.
    s.link
        .write(format!("{run}\n").as_bytes())
        .map_err(|f| s.dropped(&file, f))?;
    let elapsed = s.follow(&file, true)?;
    Ok(CardSummary {
        file,
        bytes: text.len(),
        lines: body.len(),
        elapsed,
        info: s.info.clone(),
    })
}

/// Follow a job the controller runs from its card (named `file`) until it is done, over a link
/// opened anew (after a drop): only status reports are asked for and the operator's real-time
/// commands passed on; the controller is never reset or sent a line.
pub fn watch_card(
    port: &mut dyn BytePort,
    file: &str,
    cfg: &StreamConfig,
    controls: Option<&Receiver<Control>>,
    obs: &mut dyn Observer,
) -> Result<Duration, MachineError> {
    let mut s = Session::new(port, cfg, controls, obs, cfg.timeout);
    s.follow(file, false)
}

/// The job's name on the card: its file name without folders, reduced to letters, digits, `-`,
/// `_` and `.` (what every card's file system and the firmware's commands take), at most 40
/// characters (grblHAL's limit), ending in `.nc` (a type grblHAL's listing shows).
fn card_name(job: &str) -> String {
    let base = std::path::Path::new(job)
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let mut stem: String = base
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .take(37)
        .collect();
    if stem.is_empty() {
        stem = "job".into();
    }
    format!("{stem}.nc")
}

impl Session<'_, '_> {
    fn upload_failed(&self, file: &str, detail: impl Into<String>) -> MachineError {
        MachineError::CardUpload {
            port: self.port_name.clone(),
            file: file.to_string(),
            detail: detail.into(),
        }
    }

    /// Send `data` as `file` by the firmware's own upload.
    fn upload(&mut self, file: &str, data: &[u8]) -> Result<(), MachineError> {
        let fluid = self.info.firmware == Firmware::FluidNc;
        if fluid {
            self.link
                .write(format!("$Xmodem/Receive=/sd/{file}\n").as_bytes())
                .map_err(|f| self.lost(f))?;
            // The receiver asks for the first packet with `C` (CRC mode).
            self.await_byte(file, &[CRC_MODE])?;
        } else {
            // grblHAL: mounted first (ok when it already is); no card refuses it.
            if let Err(e) = self.command("$FM") {
                return Err(match e {
                    MachineError::Setup { code, .. } => MachineError::CardMissing {
                        port: self.port_name.clone(),
                        firmware: self.info.name(),
                        detail: format!("$FM answered error:{code}"),
                    },
                    e => e,
                });
            }
            // YModem's packet 0: the name and the size.
            let mut head = format!("{file}\0{}", data.len()).into_bytes();
            head.push(0);
            self.packet(file, &packet(0, &head, 0))?;
            self.await_byte(file, &[CRC_MODE])?;
        }
        // 1024-byte packets, the rest in 128-byte ones (the least padding).
        let whole = data.len() / 1024 * 1024;
        let chunks = data[..whole].chunks(1024).chain(data[whole..].chunks(128));
        for (i, chunk) in chunks.enumerate() {
            let n = (i + 1) as u8;
            self.packet(file, &packet(n, chunk, 0x1A))?;
        }
        self.packet(file, &[EOT])?;
        if fluid {
            // FluidNC answers its command once the transfer is over.
            self.until_ok(file)?;
        } else {
            // grblHAL asks for the next file (`C`); the batch ends with an empty packet 0.
            self.await_byte(file, &[CRC_MODE])?;
            self.packet(file, &packet(0, &[], 0))?;
        }
        Ok(())
    }

    /// Write one packet and wait for its ACK, sending it again after a NAK or silence.
    fn packet(&mut self, file: &str, p: &[u8]) -> Result<(), MachineError> {
        for _ in 0..RETRIES {
            self.link.write(p).map_err(|f| self.lost(f))?;
            match self.await_byte(file, &[ACK, NAK, CAN]) {
                Ok(ACK) => return Ok(()),
                Ok(CAN) => return Err(self.upload_failed(file, "the controller cancelled it")),
                Ok(_) | Err(MachineError::CardUpload { .. }) => continue,
                Err(e) => return Err(e),
            }
        }
        Err(self.upload_failed(
            file,
            format!("a packet was refused {RETRIES} times (damaged on the way?)"),
        ))
    }

    /// The next byte that is one of `want`, skipping any other (a message's text); an error
    /// when none comes within [`PACKET_WAIT`].
    fn await_byte(&mut self, file: &str, want: &[u8]) -> Result<u8, MachineError> {
        let end = Instant::now() + PACKET_WAIT;
        while Instant::now() < end {
            if !self.link.buf.is_empty() {
                let b = self.link.buf.remove(0);
                if want.contains(&b) {
                    return Ok(b);
                }
                continue;
            }
            let wait = end.saturating_duration_since(Instant::now());
            self.link
                .port
                .set_read_timeout(wait.max(Duration::from_millis(1)))
                .map_err(|e| self.lost(LinkFault::Lost(e.to_string())))?;
            let mut chunk = [0u8; 64];
            match self.link.port.read(&mut chunk) {
                Ok(0) => {}
                Ok(n) => {
                    self.link.last_heard = Instant::now();
                    self.link.buf.extend_from_slice(&chunk[..n]);
                }
                Err(e)
                    if matches!(
                        e.kind(),
                        io::ErrorKind::TimedOut | io::ErrorKind::WouldBlock
                    ) => {}
                Err(e) => return Err(self.lost(LinkFault::Lost(e.to_string()))),
            }
        }
        Err(self.upload_failed(
            file,
            format!("no answer to the transfer for {} s", PACKET_WAIT.as_secs()),
        ))
    }

    /// Read lines until `ok` (an `error:` fails the upload).
    fn until_ok(&mut self, file: &str) -> Result<(), MachineError> {
        let end = Instant::now() + self.cfg.timeout;
        while Instant::now() < end {
            match self.link.line(Duration::from_millis(50)) {
                Ok(Some(l)) => match Reply::parse(&l) {
                    Reply::Ok => return Ok(()),
                    Reply::Error(code) => {
                        return Err(self.upload_failed(file, format!("error:{code}")))
                    }
                    Reply::Message(m) => self.obs.message(&format!("Grbl: {m}")),
                    _ => {}
                },
                Ok(None) => {}
                Err(f) => return Err(self.lost(f)),
            }
        }
        Err(self.no_answer())
    }

    /// The card lists `file` at the size sent, and reading it back gives the lines sent.
    fn verify(&mut self, file: &str, size: usize, body: &[String]) -> Result<(), MachineError> {
        let (list, show) = match self.info.firmware {
            Firmware::GrblHal => ("$F+".to_string(), format!("$F<={file}")),
            _ => ("$SD/List".to_string(), format!("$SD/Show={file}")),
        };
        let mismatch = |s: &Self, detail: String| MachineError::CardMismatch {
            port: s.port_name.clone(),
            file: file.to_string(),
            detail,
        };
        let listed = self.command(&list)?.into_iter().find_map(|r| match r {
            Reply::Feedback(f) => listed_size(&f, file),
            _ => None,
        });
        match listed {
            Some(n) if n == size => {}
            Some(n) => {
                return Err(mismatch(
                    self,
                    format!("the card lists {n} bytes, {size} were sent"),
                ))
            }
            None => return Err(mismatch(self, "the card does not list it".into())),
        }
        let back: Vec<String> = self
            .command(&show)?
            .into_iter()
            .filter_map(|r| match r {
                Reply::Other(o) => Some(o),
                _ => None,
            })
            .filter(|l| !l.trim().is_empty())
            .collect();
        if let Some(i) = (0..body.len().max(back.len()))
            .find(|&i| back.get(i).map(|l| l.trim()) != body.get(i).map(|l| l.trim()))
        {
            return Err(mismatch(
                self,
                format!(
                    "line {} reads back as `{}`, `{}` was sent",
                    i + 1,
                    back.get(i).map_or("(nothing)", |l| l.as_str()),
                    body.get(i).map_or("(nothing)", |l| l.as_str())
                ),
            ));
        }
        Ok(())
    }

    /// Follow the card job by status reports until the controller stands idle with it done,
    /// passing the operator's commands on; the elapsed time. `started_here`: the command that
    /// starts it was just sent, and a report before its `ok` still shows the board before it.
    fn follow(&mut self, file: &str, started_here: bool) -> Result<Duration, MachineError> {
        let mut begun = !started_here;
        let started = Instant::now();
        let mut next_ask = Instant::now();
        let mut said = (-1i64, String::new());
        self.link.last_heard = Instant::now();
        loop {
            self.card_controls()?;
            if Instant::now() >= next_ask {
                self.link
                    .write(&[RT_STATUS])
                    .map_err(|f| self.dropped(file, f))?;
                next_ask = Instant::now() + POLL_EVERY;
            }
            let line = self
                .link
                .line(Duration::from_millis(50))
                .map_err(|f| self.dropped(file, f))?;
            let Some(line) = line else { continue };
            match Reply::parse(&line) {
                Reply::Status(st) => {
                    if let Some((pct, _)) = &st.card {
                        // Said every 10 %, and when the state changes (held, resumed).
                        let step = ((*pct / 10.0).floor() as i64, st.state.to_string());
                        if step.0 > said.0 || step.1 != said.1 {
                            said = step;
                            self.obs
                                .message(&format!("card: {pct:.1} % of {file} ({})", st.state));
                        }
                    } else if st.state == MachineState::Idle && begun {
                        self.obs
                            .message(&format!("card: {file} is done; the controller stands idle"));
                        return Ok(started.elapsed());
                    }
                    if let MachineState::Alarm = st.state {
                        return Err(MachineError::CardAlarm {
                            port: self.port_name.clone(),
                            file: file.into(),
                            code: 0,
                        });
                    }
                }
                Reply::Alarm(code) => {
                    return Err(MachineError::CardAlarm {
                        port: self.port_name.clone(),
                        file: file.into(),
                        code,
                    })
                }
                Reply::Error(code) => {
                    return Err(MachineError::CardJobError {
                        port: self.port_name.clone(),
                        file: file.into(),
                        text: line.clone(),
                        code,
                    })
                }
                // grblHAL: `error:N in SD file at line L`.
                Reply::Other(o) if o.starts_with("error:") => {
                    let code = o[6..]
                        .split(|c: char| !c.is_ascii_digit())
                        .next()
                        .and_then(|n| n.parse().ok())
                        .unwrap_or(0);
                    return Err(MachineError::CardJobError {
                        port: self.port_name.clone(),
                        file: file.into(),
                        text: o,
                        code,
                    });
                }
                Reply::Message(m) => self.obs.message(&format!("Grbl: {m}")),
                Reply::Ok => begun = true,
                _ => {}
            }
        }
    }

    /// The link failed while the card runs the job: the cut goes on there.
    fn dropped(&self, file: &str, f: LinkFault) -> MachineError {
        MachineError::CardLinkLost {
            port: self.port_name.clone(),
            file: file.into(),
            detail: match f {
                LinkFault::Lost(d) => d,
                LinkFault::Silent(secs) => format!("no answer for {secs:.1} s"),
            },
        }
    }

    /// The operator's commands while the card runs the job, as real-time bytes; an abort takes
    /// the same way down as a streamed job's (hold, wait for the head to stand, soft reset,
    /// laser off), which also ends the job on the card.
    fn card_controls(&mut self) -> Result<(), MachineError> {
        let Some(rx) = self.controls else {
            return Ok(());
        };
        while let Ok(c) = rx.try_recv() {
            let byte = match c {
                Control::FeedHold => RT_FEED_HOLD,
                Control::Resume => RT_RESUME,
                Control::Override(o) => o.byte(),
                Control::Abort => {
                    self.settle(None);
                    let halt = self.halt(None, 1);
                    return Err(MachineError::Aborted { halt });
                }
            };
            self.link.write(&[byte]).map_err(|f| self.lost(f))?;
            match c {
                Control::FeedHold => self
                    .obs
                    .message("feed hold (!): press r to resume, a to abort"),
                Control::Resume => self.obs.message("resuming (~)"),
                _ => {}
            }
        }
        Ok(())
    }
}

/// The size in a listing line `FILE:/name|SIZE:n` (brackets taken off), if it is `file`'s.
fn listed_size(line: &str, file: &str) -> Option<usize> {
    let rest = line.strip_prefix("FILE:")?;
    let (path, rest) = rest.split_once('|')?;
    let name = path.rsplit('/').next()?;
    if !name.eq_ignore_ascii_case(file) {
        return None;
    }
    rest.strip_prefix("SIZE:")?
        .split('|')
        .next()?
        .trim()
        .parse()
        .ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn card_names_are_plain_and_short() {
        assert_eq!(card_name("/tmp/my job (2).gcode"), "my_job__2_.nc");
        assert_eq!(card_name(""), "job.nc");
        assert_eq!(card_name(&"x".repeat(80)).len(), 40);
    }

    #[test]
    fn a_listing_gives_the_size_of_the_named_file_only() {
        assert_eq!(listed_size("FILE:/a.nc|SIZE:120", "a.nc"), Some(120));
        assert_eq!(
            listed_size("FILE:/sd/A.NC|SIZE:7|UNUSABLE", "a.nc"),
            Some(7)
        );
        assert_eq!(listed_size("FILE:/b.nc|SIZE:120", "a.nc"), None);
    }
}
