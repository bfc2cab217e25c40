//! One block of G-code as Grbl 1.1h's `gc_execute_line` (gcode.c) takes it, read from Grbl's
//! source and written anew: the same three steps (read the words with their modal-group and
//! repeat checks; check the block against the modes; execute it in Grbl's order), so every line
//! gets the `ok` or `error:N` the firmware gives and moves the head where the firmware moves it,
//! in machine coordinates. The rule each refusal comes from is named beside it (`[G10 Errors]`
//! and the like are the headings in gcode.c).
//!
//! Built as the stock `config.h` builds it: no `ENABLE_M7` (M7 is `error:20`), no parking
//! override (M56), tool length offsets on Z, six work coordinate systems (G54–G59).

use crate::arc::{Arc, MAX_ARC_SEGMENTS};
use crate::error::{fail, GcodeError};
use crate::modal::{
    dist, Executed, Flow, Modal, Move, MAX_COORD_MM, MAX_FEED_MM_MIN, MAX_S, MOTION_CCW_ARC,
    MOTION_CW_ARC, MOTION_LINEAR, MOTION_NONE, MOTION_SEEK,
};
use crate::num::num;
use crate::word::next_word;

const MM_PER_INCH: f64 = 25.4;
/// gcode.c's `MAX_LINE_NUMBER`.
const MAX_LINE_NUMBER: f64 = 10_000_000.0;
/// gcode.c's `MAX_TOOL_NUMBER` (a `uint8_t`).
const MAX_TOOL_NUMBER: f64 = 255.0;

/// What the block's axis words are for (gcode.c's `AXIS_COMMAND_*`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
enum AxisCommand {
    #[default]
    None,
    NonModal,
    MotionMode,
    ToolLength,
}

/// Modal group 0 (gcode.h's `NON_MODAL_*`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
enum NonModal {
    #[default]
    None,
    Dwell,
    SetCoordinateData,
    GoHome0,
    SetHome0,
    GoHome1,
    SetHome1,
    AbsoluteOverride,
    SetCoordinateOffset,
    ResetCoordinateOffset,
}

// Modal groups as gcode.h numbers its bits.
const GROUP_G0: u16 = 1 << 0;
const GROUP_G1: u16 = 1 << 1;
const GROUP_G2: u16 = 1 << 2;
const GROUP_G3: u16 = 1 << 3;
const GROUP_G4: u16 = 1 << 4;
const GROUP_G5: u16 = 1 << 5;
const GROUP_G6: u16 = 1 << 6;
const GROUP_G7: u16 = 1 << 7;
const GROUP_G8: u16 = 1 << 8;
const GROUP_G12: u16 = 1 << 9;
const GROUP_G13: u16 = 1 << 10;
const GROUP_M4: u16 = 1 << 11;
const GROUP_M7: u16 = 1 << 12;
const GROUP_M8: u16 = 1 << 13;

// Value words, as gcode.h's `WORD_*` bits.
const WORD_F: u16 = 1 << 0;
const WORD_I: u16 = 1 << 1;
const WORD_J: u16 = 1 << 2;
const WORD_K: u16 = 1 << 3;
const WORD_L: u16 = 1 << 4;
const WORD_N: u16 = 1 << 5;
const WORD_P: u16 = 1 << 6;
const WORD_R: u16 = 1 << 7;
const WORD_S: u16 = 1 << 8;
const WORD_T: u16 = 1 << 9;
const WORD_X: u16 = 1 << 10;
const WORD_Y: u16 = 1 << 11;
const WORD_Z: u16 = 1 << 12;

/// The block being read and checked: gcode.c's `gc_block` with its tracking variables.
#[derive(Default)]
struct Block {
    line: usize,
    modal: Modal,
    /// A `$J=` jog (gcode.c's `GC_PARSER_JOG_MOTION`).
    jog: bool,
    non_modal: NonModal,
    axis_command: AxisCommand,
    commands: u16,
    values: u16,
    axis_words: u8,
    ijk_words: u8,
    xyz: [f64; 3],
    ijk: [f64; 3],
    f: f64,
    l: u8,
    n: f64,
    p: f64,
    r: f64,
    s: f64,
    /// G43.1 (true) or G49 (false) in this block.
    tool_length_dynamic: bool,
    /// The line has an N word (kept for the `Ln:` of status reports).
    has_n: bool,
    flow: Option<Flow>,
    /// G10's coordinate system index (0..6).
    coord_target: usize,
    /// The work coordinate system the block's targets use (G54..G59 as selected in it).
    block_coord: [f64; 3],
}

/// Grbl's `int_value` (a `uint8_t` from `trunc`) and `mantissa` (`round(100 · fraction)`).
fn int_and_mantissa(v: f64) -> (i64, i64) {
    let t = v.trunc();
    ((t as i64).rem_euclid(256), (100.0 * (v - t)).round() as i64)
}

/// Run one cleaned line (no spaces or comments, upper case) against `modal`, as Grbl does. On an
/// error nothing of the line takes effect.
pub(crate) fn execute(modal: &mut Modal, clean: &str, line: usize) -> Result<Executed, GcodeError> {
    let mut blk = read_block(modal, clean, line, false)?;
    blk.check(modal)?;
    Ok(blk.run(modal))
}

/// [`interpret::jog`](crate::interpret::jog), as `gc_execute_line` takes a jog with its jog flag:
/// G1 and G94 forced (a target with no axis word is machine zero, as Grbl's).
pub(crate) fn jog(modal: &Modal, body: &str, line: usize) -> Result<([f64; 3], f64), GcodeError> {
    let mut blk = read_block(modal, body, line, true)?;
    blk.check(modal)?;
    if blk.commands & !(GROUP_G3 | GROUP_G6 | GROUP_G0) != 0
        || !matches!(blk.non_modal, NonModal::None | NonModal::AbsoluteOverride)
    {
        return Err(blk.err(
            16,
            "a jog takes only G20/G21, G90/G91, G53, axis words, F and N",
        ));
    }
    Ok((blk.xyz, blk.f))
}

/// STEP 1 and 2: the block's words read against a copy of the modes.
fn read_block(modal: &Modal, clean: &str, line: usize, jog: bool) -> Result<Block, GcodeError> {
    let mut blk = Block {
        line,
        modal: *modal,
        jog,
        block_coord: modal.coords[modal.coord_select],
        ..Block::default()
    };
    if jog {
        blk.modal.motion = MOTION_LINEAR;
        blk.modal.inverse_time = false;
    }
    let mut i = 0;
    while let Some((letter, v)) = next_word(clean, &mut i, line)? {
        blk.word(letter, v)?;
    }
    Ok(blk)
}

impl Block {
    fn err(&self, code: u8, msg: impl Into<String>) -> GcodeError {
        fail(self.line, code, msg)
    }

    /// STEP 2: one word, with the checks gcode.c makes while reading.
    fn word(&mut self, letter: char, v: f64) -> Result<(), GcodeError> {
        match letter {
            'G' => self.g_word(v),
            'M' => self.m_word(v),
            _ => self.value_word(letter, v),
        }
    }

    /// A second word of one modal group: `error:21` (`STATUS_GCODE_MODAL_GROUP_VIOLATION`).
    fn group(&mut self, bit: u16, word: &str) -> Result<(), GcodeError> {
        if self.commands & bit != 0 {
            return Err(self.err(
                21,
                format!("{word} is a second command of its modal group on one line"),
            ));
        }
        self.commands |= bit;
        Ok(())
    }

    /// G10/28/30/92 and G0/1/2/3/38 and G43.1/49 on one line: `error:24`
    /// (`STATUS_GCODE_AXIS_COMMAND_CONFLICT`), they would each use the axis words.
    fn claim_axes(&mut self, kind: AxisCommand, word: &str) -> Result<(), GcodeError> {
        if self.axis_command != AxisCommand::None {
            return Err(self.err(
                24,
                format!("{word} and another command on the line both use the axis words"),
            ));
        }
        self.axis_command = kind;
        Ok(())
    }

    fn g_word(&mut self, v: f64) -> Result<(), GcodeError> {
        let (int, mut mantissa) = int_and_mantissa(v);
        let name = format!("G{}", num(v));
        let unsupported = |b: &Block| b.err(20, format!("{name} is not a command Grbl 1.1 has"));
        let bit = match int {
            10 | 28 | 30 | 92 | 4 | 53 => {
                if matches!(int, 10 | 28 | 30 | 92) && mantissa == 0 {
                    self.claim_axes(AxisCommand::NonModal, &name)?;
                }
                if matches!(int, 28 | 30 | 92) {
                    if mantissa != 0 && mantissa != 10 {
                        return Err(unsupported(self));
                    }
                    self.non_modal = match (int, mantissa) {
                        (28, 0) => NonModal::GoHome0,
                        (28, _) => NonModal::SetHome0,
                        (30, 0) => NonModal::GoHome1,
                        (30, _) => NonModal::SetHome1,
                        (_, 0) => NonModal::SetCoordinateOffset,
                        _ => NonModal::ResetCoordinateOffset,
                    };
                    mantissa = 0;
                } else {
                    self.non_modal = match int {
                        10 => NonModal::SetCoordinateData,
                        4 => NonModal::Dwell,
                        _ => NonModal::AbsoluteOverride,
                    };
                }
                GROUP_G0
            }
            0..=3 | 38 | 80 => {
                if int != 80 {
                    self.claim_axes(AxisCommand::MotionMode, &name)?;
                }
                self.modal.motion = int as u16;
                if int == 38 {
                    if ![20, 30, 40, 50].contains(&mantissa) {
                        return Err(unsupported(self));
                    }
                    self.modal.motion = 380 + (mantissa / 10) as u16;
                    mantissa = 0;
                }
                GROUP_G1
            }
            17..=19 => {
                self.modal.plane = (int - 17) as u8;
                GROUP_G2
            }
            90 | 91 if mantissa == 0 => {
                self.modal.absolute = int == 90;
                GROUP_G3
            }
            90 | 91 => {
                // G91.1 (IJK incremental) is Grbl's only arc mode; G90.1 is not supported.
                if mantissa != 10 || int == 90 {
                    return Err(unsupported(self));
                }
                mantissa = 0;
                GROUP_G4
            }
            93 | 94 => {
                self.modal.inverse_time = int == 93;
                GROUP_G5
            }
            20 | 21 => {
                self.modal.metric = int == 21;
                GROUP_G6
            }
            40 => GROUP_G7,
            43 | 49 => {
                self.claim_axes(AxisCommand::ToolLength, &name)?;
                if int == 49 {
                    self.tool_length_dynamic = false;
                } else if mantissa == 10 {
                    self.tool_length_dynamic = true;
                } else {
                    return Err(unsupported(self));
                }
                mantissa = 0;
                GROUP_G8
            }
            54..=59 => {
                self.modal.coord_select = (int - 54) as usize;
                GROUP_G12
            }
            61 => {
                if mantissa != 0 {
                    return Err(unsupported(self));
                }
                GROUP_G13
            }
            _ => return Err(unsupported(self)),
        };
        if mantissa > 0 {
            return Err(self.err(23, format!("{name}: Grbl has no such Gxx.x command")));
        }
        self.group(bit, &name)
    }

    fn m_word(&mut self, v: f64) -> Result<(), GcodeError> {
        let (int, mantissa) = int_and_mantissa(v);
        let name = format!("M{}", num(v));
        if mantissa > 0 {
            return Err(self.err(23, format!("{name}: Grbl has no Mxx.x commands")));
        }
        let bit = match int {
            0 | 1 | 2 | 30 => {
                // M1 (optional stop) is read and ignored, as Grbl does.
                self.flow = match int {
                    0 => Some(Flow::Pause),
                    1 => None,
                    _ => Some(Flow::End),
                };
                GROUP_M4
            }
            3..=5 => {
                self.modal.spindle_on = int != 5;
                if int != 5 {
                    self.modal.dynamic = int == 4;
                }
                GROUP_M7
            }
            8 | 9 => {
                self.modal.coolant = int == 8;
                GROUP_M8
            }
            7 => {
                return Err(self.err(
                    20,
                    "M7 (mist coolant) is not in Grbl's default build (ENABLE_M7)",
                ))
            }
            _ => return Err(self.err(20, format!("{name} is not a command Grbl 1.1 has"))),
        };
        self.group(bit, &name)
    }

    fn value_word(&mut self, letter: char, v: f64) -> Result<(), GcodeError> {
        let (int, _) = int_and_mantissa(v);
        let bit = match letter {
            'F' => {
                self.f = v;
                WORD_F
            }
            'I' | 'J' | 'K' => {
                let a = (letter as u8 - b'I') as usize;
                self.ijk[a] = v;
                self.ijk_words |= 1 << a;
                [WORD_I, WORD_J, WORD_K][a]
            }
            'L' => {
                self.l = int as u8;
                WORD_L
            }
            'N' => {
                self.n = v.trunc();
                self.has_n = true;
                WORD_N
            }
            'P' => {
                self.p = v;
                WORD_P
            }
            'R' => {
                self.r = v;
                WORD_R
            }
            'S' => {
                self.s = v;
                WORD_S
            }
            'T' => {
                if v > MAX_TOOL_NUMBER {
                    return Err(self.err(38, format!("tool number T{} is over 255", v)));
                }
                WORD_T
            }
            'X' | 'Y' | 'Z' => {
                let a = (letter as u8 - b'X') as usize;
                self.xyz[a] = v;
                self.axis_words |= 1 << a;
                [WORD_X, WORD_Y, WORD_Z][a]
            }
            _ => return Err(self.err(20, format!("'{letter}' is not a word Grbl 1.1 knows"))),
        };
        if self.values & bit != 0 {
            return Err(self.err(25, format!("'{letter}' is given twice on one line")));
        }
        if bit & (WORD_F | WORD_N | WORD_P | WORD_T | WORD_S) != 0 && v < 0.0 {
            return Err(self.err(4, format!("'{letter}' cannot be negative")));
        }
        self.values |= bit;
        Ok(())
    }

    /// STEP 3: the block against the modes, in gcode.c's order; targets computed on the way.
    fn check(&mut self, st: &Modal) -> Result<(), GcodeError> {
        if self.axis_words != 0 && self.axis_command == AxisCommand::None {
            self.axis_command = AxisCommand::MotionMode;
        }
        if self.values & WORD_N != 0 && self.n > MAX_LINE_NUMBER {
            return Err(self.err(27, "line number N is over 10000000"));
        }
        self.check_feed(st)?;
        if self.values & WORD_S == 0 {
            self.s = st.s;
        } else if self.s > MAX_S {
            return Err(beyond(self.line, "S", self.s, MAX_S, ""));
        }
        if self.non_modal == NonModal::Dwell {
            if self.values & WORD_P == 0 {
                return Err(self.err(28, "G4 needs P (the dwell in seconds)"));
            }
            self.values &= !WORD_P;
        }
        if !self.modal.metric {
            for a in 0..3 {
                if self.axis_words & (1 << a) != 0 {
                    self.xyz[a] *= MM_PER_INCH;
                }
            }
        }
        if self.axis_command == AxisCommand::ToolLength
            && self.tool_length_dynamic
            && self.axis_words != 0b100
        {
            return Err(self.err(37, "G43.1 takes one Z word and no other axis"));
        }
        self.block_coord = st.coords[self.modal.coord_select];
        self.check_non_modal(st)?;
        self.check_motion(st)?;
        // A jog uses F and N only: S and T on it are unused words.
        self.values &= if self.jog {
            !(WORD_N | WORD_F)
        } else {
            !(WORD_N | WORD_F | WORD_S | WORD_T)
        };
        if self.axis_command != AxisCommand::None {
            self.values &= !(WORD_X | WORD_Y | WORD_Z);
        }
        if self.values != 0 {
            let unused: String = "FIJKLNPRSTXYZ"
                .chars()
                .enumerate()
                .filter(|(k, _)| self.values & (1 << k) != 0)
                .map(|(_, c)| c)
                .collect();
            return Err(self.err(
                36,
                format!("word {unused} is not used by any command on the line"),
            ));
        }
        self.check_range(st)
    }

    /// [2. Set feed rate mode] and [3. Set feed rate].
    fn check_feed(&mut self, st: &Modal) -> Result<(), GcodeError> {
        if self.jog {
            if self.values & WORD_F == 0 {
                return Err(self.err(22, "a jog needs its F"));
            }
            if !self.modal.metric {
                self.f *= MM_PER_INCH;
            }
        } else if self.modal.inverse_time {
            if self.axis_command == AxisCommand::MotionMode
                && self.modal.motion != MOTION_NONE
                && self.modal.motion != MOTION_SEEK
                && self.values & WORD_F == 0
            {
                return Err(self.err(22, "in inverse time (G93) every feed move needs its F"));
            }
        } else if !st.inverse_time {
            if self.values & WORD_F != 0 {
                if !self.modal.metric {
                    self.f *= MM_PER_INCH;
                }
            } else {
                self.f = st.feed.unwrap_or(0.0);
            }
        } else if self.values & WORD_F != 0 && !self.modal.metric {
            // Out of G93 into G94: the feed is undefined unless given here.
            self.f *= MM_PER_INCH;
        }
        if !self.modal.inverse_time && self.f > MAX_FEED_MM_MIN {
            return Err(beyond(
                self.line,
                "feed",
                self.f,
                MAX_FEED_MM_MIN,
                " mm/min",
            ));
        }
        Ok(())
    }

    /// [19. Remaining non-modal actions]: G10, G92 and the targets of everything else.
    fn check_non_modal(&mut self, st: &Modal) -> Result<(), GcodeError> {
        match self.non_modal {
            NonModal::SetCoordinateData => self.check_g10(st),
            NonModal::SetCoordinateOffset => {
                if self.axis_words == 0 {
                    return Err(self.err(26, "G92 needs at least one axis word"));
                }
                for a in 0..3 {
                    self.xyz[a] = if self.axis_words & (1 << a) != 0 {
                        let tlo = if a == 2 { st.tlo } else { 0.0 };
                        st.pos[a] - self.block_coord[a] - self.xyz[a] - tlo
                    } else {
                        st.g92[a]
                    };
                }
                Ok(())
            }
            _ => {
                if self.axis_command != AxisCommand::ToolLength && self.axis_words != 0 {
                    for a in 0..3 {
                        if self.axis_words & (1 << a) == 0 {
                            self.xyz[a] = st.pos[a];
                        } else if self.non_modal != NonModal::AbsoluteOverride {
                            if self.modal.absolute {
                                self.xyz[a] += self.block_coord[a] + st.g92[a];
                                if a == 2 {
                                    self.xyz[a] += st.tlo;
                                }
                            } else {
                                self.xyz[a] += st.pos[a];
                            }
                        }
                    }
                }
                match self.non_modal {
                    NonModal::GoHome0 | NonModal::GoHome1 => {
                        self.ijk = if self.non_modal == NonModal::GoHome0 {
                            st.g28
                        } else {
                            st.g30
                        };
                        if self.axis_words != 0 {
                            for a in 0..3 {
                                if self.axis_words & (1 << a) == 0 {
                                    self.ijk[a] = st.pos[a];
                                }
                            }
                        } else {
                            self.axis_command = AxisCommand::None;
                        }
                    }
                    NonModal::AbsoluteOverride
                        if !matches!(self.modal.motion, MOTION_SEEK | MOTION_LINEAR) =>
                    {
                        return Err(self.err(30, "G53 works only with G0 or G1 active"));
                    }
                    _ => {}
                }
                Ok(())
            }
        }
    }

    /// `[G10 Errors]`: L2 (offset given) or L20 (offset from here), P0..P6, axis words.
    fn check_g10(&mut self, st: &Modal) -> Result<(), GcodeError> {
        if self.axis_words == 0 {
            return Err(self.err(26, "G10 needs at least one axis word"));
        }
        if self.values & (WORD_P | WORD_L) == 0 {
            return Err(self.err(28, "G10 needs L2 or L20 and P"));
        }
        let p = self.p.trunc();
        if p > 6.0 {
            return Err(self.err(29, format!("G10 P{p}: Grbl has work systems P0..P6 only")));
        }
        if self.l != 20 && (self.l != 2 || self.values & WORD_R != 0) {
            return Err(self.err(20, "G10 takes L2 or L20 (and L2 no R)"));
        }
        self.values &= !(WORD_L | WORD_P);
        self.coord_target = if p > 0.0 {
            p as usize - 1
        } else {
            self.modal.coord_select
        };
        self.ijk = st.coords[self.coord_target];
        for a in 0..3 {
            if self.axis_words & (1 << a) != 0 {
                self.ijk[a] = if self.l == 20 {
                    let tlo = if a == 2 { st.tlo } else { 0.0 };
                    st.pos[a] - st.g92[a] - self.xyz[a] - tlo
                } else {
                    self.xyz[a]
                };
            }
        }
        Ok(())
    }

    /// [20. Motion modes]: G80 with axis words, feeds, arcs' geometry, probe targets.
    fn check_motion(&mut self, st: &Modal) -> Result<(), GcodeError> {
        if self.modal.motion == MOTION_NONE {
            if self.axis_words != 0 {
                return Err(self.err(31, "axis words with G80 (motion cancelled)"));
            }
            return Ok(());
        }
        if self.axis_command != AxisCommand::MotionMode {
            return Ok(());
        }
        if self.modal.motion == MOTION_SEEK {
            if self.axis_words == 0 {
                self.axis_command = AxisCommand::None;
            }
            return Ok(());
        }
        if self.f == 0.0 {
            return Err(self.err(
                22,
                format!(
                    "G{} with no feed rate set (F)",
                    motion_word(self.modal.motion)
                ),
            ));
        }
        match self.modal.motion {
            MOTION_LINEAR => {
                if self.axis_words == 0 {
                    self.axis_command = AxisCommand::None;
                }
                Ok(())
            }
            MOTION_CW_ARC | MOTION_CCW_ARC => self.check_arc(st),
            _ => {
                if self.axis_words == 0 {
                    return Err(self.err(26, "G38 needs an axis word"));
                }
                if st.pos == self.xyz {
                    return Err(self.err(33, "G38 target is where the head already is"));
                }
                Ok(())
            }
        }
    }

    /// `[G2/3 Errors]`: axis words in the plane; R mode's radius; IJK mode's centre.
    fn check_arc(&mut self, st: &Modal) -> Result<(), GcodeError> {
        let (a0, a1, _) = plane_axes(self.modal.plane);
        if self.axis_words == 0 {
            return Err(self.err(26, "an arc needs axis words"));
        }
        if self.axis_words & ((1 << a0) | (1 << a1)) == 0 {
            return Err(self.err(32, "an arc needs an axis word in its plane"));
        }
        let x = self.xyz[a0] - st.pos[a0];
        let y = self.xyz[a1] - st.pos[a1];
        if self.values & WORD_R != 0 {
            self.values &= !WORD_R;
            if st.pos == self.xyz {
                return Err(self.err(33, "an R arc that ends where it starts has no centre"));
            }
            if !self.modal.metric {
                self.r *= MM_PER_INCH;
            }
            let h4 = 4.0 * self.r * self.r - x * x - y * y;
            if h4 < 0.0 {
                return Err(self.err(
                    34,
                    format!("radius {} is less than half the chord", num(self.r.abs())),
                ));
            }
            let mut h = -h4.sqrt() / x.hypot(y);
            if self.modal.motion == MOTION_CCW_ARC {
                h = -h;
            }
            if self.r < 0.0 {
                h = -h;
                self.r = -self.r;
            }
            self.ijk[a0] = 0.5 * (x - y * h);
            self.ijk[a1] = 0.5 * (y + x * h);
        } else {
            if self.ijk_words & ((1 << a0) | (1 << a1)) == 0 {
                return Err(self.err(35, "an arc needs I, J or K offsets in its plane"));
            }
            self.values &= !(WORD_I | WORD_J | WORD_K);
            if !self.modal.metric {
                for a in 0..3 {
                    if self.ijk_words & (1 << a) != 0 {
                        self.ijk[a] *= MM_PER_INCH;
                    }
                }
            }
            let target_r = (x - self.ijk[a0]).hypot(y - self.ijk[a1]);
            self.r = self.ijk[a0].hypot(self.ijk[a1]);
            let delta = (target_r - self.r).abs();
            if delta > 0.005 && (delta > 0.5 || delta > 0.001 * self.r) {
                return Err(self.err(
                    33,
                    format!(
                        "the arc's end is {} mm off its circle (Grbl allows 0.005 mm, or 0.1 % \
                         of the radius up to 0.5 mm)",
                        num(delta)
                    ),
                ));
            }
        }
        Ok(())
    }

    /// Not Grbl's: numbers beyond any machine are refused whole before they reach one.
    fn check_range(&self, st: &Modal) -> Result<(), GcodeError> {
        let moving = self.axis_command != AxisCommand::None
            && self.non_modal != NonModal::SetCoordinateOffset
            && self.non_modal != NonModal::SetCoordinateData;
        let mut points = vec![];
        if moving {
            points.push(self.xyz);
        }
        if matches!(self.non_modal, NonModal::GoHome0 | NonModal::GoHome1) {
            points.push(self.ijk);
        }
        for p in points {
            for (axis, &v) in ["X", "Y", "Z"].into_iter().zip(&p) {
                if v.abs() > MAX_COORD_MM {
                    return Err(beyond(self.line, axis, v, MAX_COORD_MM, " mm"));
                }
            }
        }
        for (what, v) in [("G10 offset", self.ijk), ("G92 offset", self.xyz)] {
            let applies = match what {
                "G10 offset" => self.non_modal == NonModal::SetCoordinateData,
                _ => self.non_modal == NonModal::SetCoordinateOffset,
            };
            if applies && v.iter().any(|c| c.abs() > MAX_COORD_MM) {
                let worst = v.iter().fold(0f64, |m, c| m.max(c.abs()));
                return Err(beyond(self.line, what, worst, MAX_COORD_MM, " mm"));
            }
        }
        if moving && matches!(self.modal.motion, MOTION_CW_ARC | MOTION_CCW_ARC) {
            let n = self.arc(st).segments(st.arc_tolerance);
            if n > MAX_ARC_SEGMENTS {
                return Err(GcodeError::out_of_range(
                    self.line,
                    format!(
                        "the arc needs {n} segments at arc tolerance {} mm; Grbl counts at most \
                         {MAX_ARC_SEGMENTS}",
                        num(st.arc_tolerance)
                    ),
                ));
            }
        }
        Ok(())
    }

    fn arc(&self, st: &Modal) -> Arc {
        Arc {
            from: st.pos,
            to: self.xyz,
            offset: self.ijk,
            radius: self.r,
            axes: plane_axes(self.modal.plane),
            clockwise: self.modal.motion == MOTION_CW_ARC,
        }
    }

    /// STEP 4: execute, in Grbl's order; the state changes only here.
    fn run(self, st: &mut Modal) -> Executed {
        let mut out = Executed {
            n: self.has_n.then_some(self.n as u32),
            ..Executed::default()
        };
        st.inverse_time = self.modal.inverse_time;
        st.feed = (self.f > 0.0).then_some(self.f);
        st.s = self.s;
        st.spindle_on = self.modal.spindle_on;
        st.dynamic = self.modal.dynamic;
        st.coolant = self.modal.coolant;
        if self.non_modal == NonModal::Dwell {
            out.dwell_s = self.p;
        }
        st.plane = self.modal.plane;
        st.metric = self.modal.metric;
        if self.axis_command == AxisCommand::ToolLength {
            st.tlo = if self.tool_length_dynamic {
                self.xyz[2]
            } else {
                0.0
            };
        }
        st.coord_select = self.modal.coord_select;
        st.absolute = self.modal.absolute;
        match self.non_modal {
            NonModal::SetCoordinateData => st.coords[self.coord_target] = self.ijk,
            NonModal::GoHome0 | NonModal::GoHome1 => {
                if self.axis_command != AxisCommand::None {
                    self.line_to(st, self.xyz, true, &mut out);
                }
                self.line_to(st, self.ijk, true, &mut out);
            }
            NonModal::SetHome0 => st.g28 = st.pos,
            NonModal::SetHome1 => st.g30 = st.pos,
            NonModal::SetCoordinateOffset => st.g92 = self.xyz,
            NonModal::ResetCoordinateOffset => st.g92 = [0.0; 3],
            _ => {}
        }
        st.motion = self.modal.motion;
        if st.motion != MOTION_NONE && self.axis_command == AxisCommand::MotionMode {
            match st.motion {
                MOTION_SEEK => self.line_to(st, self.xyz, true, &mut out),
                MOTION_LINEAR => self.line_to(st, self.xyz, false, &mut out),
                MOTION_CW_ARC | MOTION_CCW_ARC => self.arc_to(st, &mut out),
                probe => {
                    // No probe is wired: the move runs its whole length (G38.2/.4 then alarm).
                    out.probe = Some(probe);
                    self.line_to(st, self.xyz, false, &mut out);
                }
            }
        }
        out.flow = self.flow;
        if self.flow == Some(Flow::End) {
            st.end_program();
        }
        out
    }

    /// One straight move (`mc_line`) to `to`, machine coordinates.
    fn line_to(&self, st: &mut Modal, to: [f64; 3], rapid: bool, out: &mut Executed) {
        let from = st.pos;
        let feed = if rapid || !st.inverse_time {
            st.feed.unwrap_or(0.0)
        } else {
            // Inverse time: F is moves per minute, so the move takes 1/F minutes.
            dist(from, to) * self.f
        };
        out.moves.push(self.make_move(st, from, to, rapid, feed));
        st.pos = to;
    }

    /// An arc as `mc_arc` cuts it; in G93 the whole arc takes 1/F minutes.
    fn arc_to(&self, st: &mut Modal, out: &mut Executed) {
        let arc = self.arc(st);
        let points = arc.points(st.arc_tolerance);
        let feed = if st.inverse_time {
            let mut len = 0.0;
            let mut p = st.pos;
            for q in &points {
                len += dist(p, *q);
                p = *q;
            }
            len * self.f
        } else {
            st.feed.unwrap_or(0.0)
        };
        for q in points {
            let from = st.pos;
            out.moves.push(self.make_move(st, from, q, false, feed));
            st.pos = q;
        }
    }

    fn make_move(&self, st: &Modal, from: [f64; 3], to: [f64; 3], rapid: bool, feed: f64) -> Move {
        let spindle_s = if st.spindle_on { st.s } else { 0.0 };
        Move {
            from,
            to,
            rapid,
            feed,
            power: if rapid { 0.0 } else { spindle_s },
            spindle_s,
            line: self.line,
        }
    }
}

/// The plane's two arc axes and its linear axis (gcode.c's `axis_0`, `axis_1`, `axis_linear`).
pub(crate) fn plane_axes(plane: u8) -> (usize, usize, usize) {
    match plane {
        0 => (0, 1, 2),
        1 => (2, 0, 1),
        _ => (1, 2, 0),
    }
}

/// A motion mode as its G word (`38.2` for a probe).
pub fn motion_word(m: u16) -> String {
    if m >= 380 {
        format!("38.{}", m - 380)
    } else {
        m.to_string()
    }
}

/// A number beyond [`MAX_COORD_MM`], [`MAX_FEED_MM_MIN`] or [`MAX_S`]: the program is refused
/// whole. Huge values are shown in scientific notation so the message stays one short line.
pub(crate) fn beyond(line: usize, what: &str, v: f64, max: f64, unit: &str) -> GcodeError {
    let v = if v.abs() < 1e9 {
        v.to_string()
    } else {
        format!("{v:.3e}")
    };
    GcodeError::out_of_range(
        line,
        format!("{what} {v} is beyond what any machine does (at most {max}{unit})"),
    )
}
