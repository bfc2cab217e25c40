//! The card of a grblHAL or FluidNC board (SD card or flash): files received over the stream
//! (grblHAL's YModem, trapped by the SOH/STX that starts it; FluidNC's XModem after
//! `$Xmodem/Receive=`), listed, read back, and run from the card. A job on the card is fed to
//! the board's own line buffer without the host: its answers go nowhere, status reports carry
//! `SD:percent,name`, the host's lines are dropped (its real-time bytes still act), and it runs
//! on when the link to the host drops.

use super::record::{lock, Event};
use super::sim::Sim;
use super::storage::{CardRun, Upload};
use crate::protocol::Firmware;
use crate::xmodem::{crc16, ACK, CAN, CRC_MODE, EOT, NAK, SOH, STX};

impl Sim {
    /// Whether this build has a card (grblHAL and FluidNC do here; Grbl 1.1h never has one).
    pub(super) fn has_card(&self) -> bool {
        self.cfg.firmware != Firmware::Grbl
    }

    /// A byte off the wire while a file arrives, or the SOH/STX that starts grblHAL's YModem:
    /// true when the card took it.
    pub(super) fn card_byte(&mut self, b: u8) -> bool {
        if self.upload.is_none() {
            // grblHAL takes SOH/STX wherever they come as the start of a YModem transfer.
            let trap = self.cfg.firmware == Firmware::GrblHal && (b == SOH || b == STX);
            if !trap {
                return false;
            }
            self.upload = Some(Upload {
                name: None,
                ymodem: true,
                size: None,
                data: Vec::new(),
                packet: Vec::new(),
                next: 0,
                answer: None,
            });
        }
        let Some(mut up) = self.upload.take() else {
            return false;
        };
        if up.packet.is_empty() {
            match b {
                SOH | STX => up.packet.push(b),
                EOT => {
                    self.raw(&[ACK]);
                    if up.ymodem {
                        self.raw(&[CRC_MODE]);
                    }
                    return self.store(up);
                }
                CAN => return true,
                // Noise between packets is purged.
                _ => {}
            }
            self.upload = Some(up);
            return true;
        }
        up.packet.push(b);
        let len = if up.packet[0] == SOH { 128 } else { 1024 };
        if up.packet.len() < 3 + len + 2 {
            self.upload = Some(up);
            return true;
        }
        let p = std::mem::take(&mut up.packet);
        let payload = &p[3..3 + len];
        let crc = u16::from_be_bytes([p[3 + len], p[4 + len]]);
        if p[1] != !p[2] || crc16(payload) != crc {
            self.raw(&[NAK]);
        } else if p[1] == up.next.wrapping_sub(1) && !(up.ymodem && up.next == 0) {
            // A repeat of a packet whose ACK was lost.
            self.raw(&[ACK]);
        } else if p[1] != up.next {
            self.raw(&[CAN, CAN]);
            return true;
        } else if up.ymodem && up.next == 0 {
            let mut fields = payload.split(|&c| c == 0);
            let name = String::from_utf8_lossy(fields.next().unwrap_or(&[])).into_owned();
            if name.is_empty() {
                // The batch's closing packet: no more files.
                self.raw(&[ACK]);
                return true;
            }
            up.size = fields
                .next()
                .and_then(|f| String::from_utf8_lossy(f).split(' ').next()?.parse().ok());
            up.name = Some(name);
            up.next = 1;
            self.raw(&[ACK, CRC_MODE]);
        } else {
            up.data.extend_from_slice(payload);
            up.next = up.next.wrapping_add(1);
            self.raw(&[ACK]);
        }
        self.upload = Some(up);
        true
    }

    /// The end of a transfer: the file is written to the card.
    fn store(&mut self, mut up: Upload) -> bool {
        match up.size {
            Some(n) => up.data.truncate(n),
            // XModem pads its last block with SUB (0x1A).
            None => {
                while up.data.last() == Some(&0x1A) {
                    up.data.pop();
                }
            }
        }
        if let Some(name) = up.name {
            let name = name.trim_start_matches('/').to_string();
            lock(&self.shared)
                .events
                .push(Event::CardFile(name.clone()));
            self.card.insert(name, up.data);
        }
        if let Some(idx) = up.answer {
            self.done(idx);
        }
        true
    }

    /// A card command (`clean` as the line buffer holds it, `raw` as it came, for file names):
    /// false when it is none.
    pub(super) fn card_command(&mut self, clean: &str, idx: usize) -> bool {
        if !self.has_card() {
            return false;
        }
        let arg = self
            .last_raw
            .split_once('=')
            .map(|(_, v)| v.trim().trim_start_matches("/sd/").trim_start_matches('/'))
            .unwrap_or("")
            .to_string();
        let hal = self.cfg.firmware == Firmware::GrblHal;
        let idle = self.planner.is_empty() && self.pending.is_none() && self.card_run.is_none();
        match clean {
            "$FM" if hal => self.done(idx),
            "$F" | "$F+" if hal => self.list_card(idx),
            "$SDLIST" if !hal => self.list_card(idx),
            c if hal && c.starts_with("$F<=") || !hal && c.starts_with("$SDSHOW=") => {
                match self.card.get(&arg).cloned() {
                    Some(data) => {
                        for l in String::from_utf8_lossy(&data).lines() {
                            self.say(l);
                        }
                        self.done(idx);
                    }
                    None => self.reply_error(if hal { 61 } else { 65 }),
                }
            }
            c if hal && c.starts_with("$F=") || !hal && c.starts_with("$SDRUN=") => {
                if !idle {
                    self.reply_error(8);
                    return true;
                }
                match self.card.get(&arg).cloned() {
                    Some(data) => {
                        self.done(idx);
                        self.unheard += data.iter().filter(|&&b| b == b'\n').count();
                        self.card_run = Some(CardRun {
                            name: arg,
                            size: data.len(),
                        });
                        self.backlog = data.into();
                    }
                    None => self.reply_error(if hal { 61 } else { 65 }),
                }
            }
            c if !hal && c.starts_with("$XMODEMRECEIVE=") => {
                self.upload = Some(Upload {
                    name: Some(arg),
                    ymodem: false,
                    size: None,
                    data: Vec::new(),
                    packet: Vec::new(),
                    next: 1,
                    answer: Some(idx),
                });
                // The receiver asks for CRC mode.
                self.raw(&[CRC_MODE]);
            }
            _ => return false,
        }
        true
    }

    fn list_card(&mut self, idx: usize) {
        let files: Vec<String> = self
            .card
            .iter()
            .map(|(n, d)| format!("[FILE:/{n}|SIZE:{}]", d.len()))
            .collect();
        for f in files {
            self.say(&f);
        }
        self.done(idx);
    }

    /// The job on the card is over once it is all read and every move has run.
    pub(super) fn card_tick(&mut self) {
        let over = self.backlog.is_empty()
            && self.rx.is_empty()
            && self.planner.is_empty()
            && self.pending.is_none()
            && self.waiting.is_none();
        if self.card_run.is_some() && over {
            self.card_run = None;
            self.unheard = 0;
        }
    }

    /// `|SD:percent,name` for a status report while a job runs from the card.
    pub(super) fn card_field(&self) -> Option<String> {
        let run = self.card_run.as_ref()?;
        let read = run.size - self.backlog.len() - self.rx.len().min(run.size);
        let pct = (read as f64 / run.size.max(1) as f64 * 100.0).min(99.9);
        Some(format!("|SD:{pct:.1},{}", run.name))
    }

    /// Bytes for the host outside the line protocol (the transfer's ACK, NAK, CAN and `C`).
    fn raw(&mut self, bytes: &[u8]) {
        let at = self.out_clock.max(std::time::Instant::now());
        self.out_clock = at;
        self.wire_out.push_back((at, bytes.to_vec()));
    }
}
