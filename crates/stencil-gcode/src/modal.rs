//! The interpreter's state and what one line does, shared by the parser (`grbl`) and the
//! program reader (`interpret`): Grbl's `gc_state`, its limits, and a move.

/// One straight move, in millimetres, absolute machine coordinates.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Move {
    /// Where the move starts.
    pub from: [f64; 3],
    /// Where it ends.
    pub to: [f64; 3],
    /// G0: travel at the machine's rapid rate, laser off.
    pub rapid: bool,
    /// Programmed feed in mm/min (for G1); for G0 the last F seen (unused by Grbl).
    pub feed: f64,
    /// Spindle/laser S value while moving; 0 when the spindle is off (M5) or the move is G0.
    pub power: f64,
    /// The spindle output's S while this move runs, G0 or not; 0 when the spindle is off. A laser
    /// in laser mode stays dark in G0 (`power` is 0), but a pen servo on the spindle output stays
    /// down: [`CutRule`](crate::interpret::CutRule) tells the two apart.
    pub spindle_s: f64,
    /// 1-based line number in the program text.
    pub line: usize,
}

impl Move {
    /// Its length, mm.
    pub fn length(&self) -> f64 {
        dist(self.from, self.to)
    }
}

/// The distance between two points, mm.
pub(crate) fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2) + (b[2] - a[2]).powi(2)).sqrt()
}

/// Grbl's motion modes (modal group 1), numbered as their G words; a probe G38.x is 380 + x.
pub const MOTION_SEEK: u16 = 0;
/// G1.
pub const MOTION_LINEAR: u16 = 1;
/// G2.
pub const MOTION_CW_ARC: u16 = 2;
/// G3.
pub const MOTION_CCW_ARC: u16 = 3;
/// G80.
pub const MOTION_NONE: u16 = 80;

/// Grbl's `$12` default: the largest gap, mm, between an arc and the chords it is cut into.
pub const DEFAULT_ARC_TOLERANCE_MM: f64 = 0.002;

/// The parser's state carried from line to line, as Grbl 1.1's `gc_state` holds it: modes,
/// position in machine coordinates, and the offsets that turn work coordinates into machine
/// ones (the six work systems G10 writes to EEPROM, G92, the tool length offset, and the G28/G30
/// positions).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Modal {
    /// Where the parser has put the head, machine coordinates, mm.
    pub pos: [f64; 3],
    /// [`MOTION_SEEK`] (G0), [`MOTION_LINEAR`] (G1), arcs (G2/G3), [`MOTION_NONE`] (G80), or a
    /// probe (380 + x for G38.x).
    pub motion: u16,
    /// G17 (0, XY), G18 (1, ZX), G19 (2, YZ).
    pub plane: u8,
    /// G90 (else G91).
    pub absolute: bool,
    /// G21 (else G20).
    pub metric: bool,
    /// G93: F is moves per minute, given on every feed move.
    pub inverse_time: bool,
    /// The feed in mm/min (G94); `None` while undefined.
    pub feed: Option<f64>,
    /// The S word in force.
    pub s: f64,
    /// M3/M4 on, M5 off.
    pub spindle_on: bool,
    /// The last spindle command was M4 (laser mode: power scaled with speed) rather than M3.
    pub dynamic: bool,
    /// Coolant output on (M8, flood: air assist on a laser), off with M9.
    pub coolant: bool,
    /// G54..G59 as 0..5.
    pub coord_select: usize,
    /// The six work coordinate systems' offsets (G10 L2/L20 write them; Grbl keeps them in
    /// EEPROM, so they survive a reset).
    pub coords: [[f64; 3]; 6],
    /// G92's offset (cleared by G92.1 and by a reset).
    pub g92: [f64; 3],
    /// G43.1's tool length offset on Z.
    pub tlo: f64,
    /// G28.1 / G30.1's stored positions, machine coordinates.
    pub g28: [f64; 3],
    /// G30's stored position (G30.1).
    pub g30: [f64; 3],
    /// `$12`, mm: how finely arcs are cut.
    pub arc_tolerance: f64,
}

impl Default for Modal {
    fn default() -> Self {
        Modal {
            pos: [0.0; 3],
            motion: MOTION_SEEK,
            plane: 0,
            absolute: true,
            metric: true,
            inverse_time: false,
            feed: None,
            s: 0.0,
            spindle_on: false,
            dynamic: false,
            coolant: false,
            coord_select: 0,
            coords: [[0.0; 3]; 6],
            g92: [0.0; 3],
            tlo: 0.0,
            g28: [0.0; 3],
            g30: [0.0; 3],
            arc_tolerance: DEFAULT_ARC_TOLERANCE_MM,
        }
    }
}

impl Modal {
    /// The work coordinate offset in force (Grbl's `WCO:`): the selected work system plus G92
    /// plus the tool length offset on Z. Work position = machine position − this.
    pub fn wco(&self) -> [f64; 3] {
        let c = self.coords[self.coord_select];
        [
            c[0] + self.g92[0],
            c[1] + self.g92[1],
            c[2] + self.g92[2] + self.tlo,
        ]
    }

    /// The state after a soft reset (`gc_init`): modes back to their defaults and G92 gone, but
    /// the position, the work systems and G28/G30 positions (EEPROM) and `$12` kept.
    pub fn after_reset(&self) -> Modal {
        Modal {
            pos: self.pos,
            coords: self.coords,
            g28: self.g28,
            g30: self.g30,
            arc_tolerance: self.arc_tolerance,
            ..Modal::default()
        }
    }

    /// `M2` / `M30`: what Grbl 1.1 resets at a program end (gcode.c, `PROGRAM_FLOW_COMPLETED`):
    /// G1, G17, G90, G94, G54, spindle off (M5) and coolant off (M9); F, S, units and G92 kept.
    pub fn end_program(&mut self) {
        self.motion = MOTION_LINEAR;
        self.plane = 0;
        self.absolute = true;
        self.inverse_time = false;
        self.coord_select = 0;
        self.spindle_on = false;
        self.coolant = false;
    }
}

/// The largest coordinate (absolute value, mm, after inches are converted) a program may reach:
/// 1 km, more than any machine's travel. Beyond it estimates overflow into nonsense (a 400-digit
/// number reads as infinity).
pub const MAX_COORD_MM: f64 = 1e6;

/// The largest feed (mm/min) and S value a program may give: far above any machine's.
pub const MAX_FEED_MM_MIN: f64 = 1e6;
/// The largest S value accepted.
pub const MAX_S: f64 = 1e6;

/// The most moves (arc segments counted) one program may make: 4 million, far more than any
/// job (a day of cutting), and a bound on memory (about 90 bytes a move).
pub const MAX_MOVES: usize = 4_000_000;

/// M0 or a program end: program flow (Grbl's modal group M4). M1 is read and ignored.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Flow {
    /// M0: Grbl finishes the queued motion, then holds until cycle start (`~`).
    Pause,
    /// M2 / M30: Grbl finishes the queued motion, resets some modes, says `[MSG:Pgm End]`.
    End,
}

/// What one line did: its moves (an arc as Grbl's chords), a dwell, a pause or end, a probe.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Executed {
    /// The moves the line makes.
    pub moves: Vec<Move>,
    /// G4 P: seconds Grbl waits after the queued motion ends.
    pub dwell_s: f64,
    /// A program stop or end, when the line has one.
    pub flow: Option<Flow>,
    /// A probe move (380 + x for G38.x): on a machine without a probe it runs its whole length,
    /// then G38.2 and G38.4 raise `ALARM:5` (no contact), G38.3 and G38.5 do not.
    pub probe: Option<u16>,
    /// The line's N number, if it has one.
    pub n: Option<u32>,
}
