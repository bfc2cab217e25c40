//! The virtual Grbl answers every line as Grbl 1.1h does (issue 26). Each case is one line sent
//! after a short setup, the answer Grbl 1.1h gives (`ok` or `error:N`), and the rule in Grbl's
//! source it comes from (file, and the check there: gcode.c's `[G10 Errors]`-style headings,
//! `STATUS_*` names from report.h). The answers were worked out from Grbl's code, not from ours,
//! and then checked against Grbl 1.1h itself: gnea/grbl's source compiled on a PC with
//! grbl-sim's validator (`gvalidate`, outside this repository), fed each case's setup and line,
//! gives the same answer for all of them.
//!
//! Every case runs twice: through the shared interpreter (what `estimate`, `simulate`, `frame`
//! and the bed check read) and through a virtual Grbl over its pty (what `send --dry-run` talks
//! to), so the two cannot drift apart.

use std::io::{Read, Write};
use std::time::{Duration, Instant};

use serialport::{SerialPort, TTYPort};
use stencil_gcode::interpret::{self as gcode, Modal};
use stencil_grbl::{VirtualConfig, VirtualGrbl};

use crate::common::read_until;

/// (setup lines, the line, Grbl 1.1h's answer, the rule).
pub(crate) type Case = (&'static str, &'static str, &'static str, &'static str);

pub(crate) const CASES: &[Case] = &[
    // ---- Words as read (gcode.c STEP 2, nuts_bolts.c read_float) ----
    ("", "G0X1", "ok", "gcode.c: G0 with an axis word"),
    (
        "",
        "%",
        "error:1",
        "gcode.c STEP 2: letter not A-Z -> STATUS_EXPECTED_COMMAND_LETTER",
    ),
    (
        "",
        "1G0",
        "error:1",
        "gcode.c STEP 2: a line must start with a letter",
    ),
    (
        "",
        "G0X1#",
        "error:1",
        "gcode.c STEP 2: '#' is not a letter (no parameters)",
    ),
    (
        "",
        "G0X1=2",
        "error:1",
        "gcode.c STEP 2: '=' is not a letter (no expressions)",
    ),
    ("", "*", "error:1", "gcode.c STEP 2: not a letter"),
    (
        "",
        "G0X1.2.3",
        "error:1",
        "read_float stops at a second '.', which is then no letter",
    ),
    (
        "",
        "X",
        "error:2",
        "read_float: no digits -> STATUS_BAD_NUMBER_FORMAT",
    ),
    ("", "G", "error:2", "read_float: no digits"),
    ("", "G0X", "error:2", "read_float: no digits after X"),
    ("", "G0X-", "error:2", "read_float: a sign without digits"),
    ("", "G0X--1", "error:2", "read_float: one sign only"),
    ("", "G0X+5", "ok", "read_float: a leading '+'"),
    ("", "G0X.5", "ok", "read_float: digits after the point only"),
    ("", "G0X5.", "ok", "read_float: a trailing point"),
    (
        "",
        "G0X1.23456789",
        "ok",
        "read_float: digits past MAX_INT_DIGITS dropped",
    ),
    (
        "",
        "G0X1E3",
        "error:20",
        "read_float has no exponent; E is an unsupported word",
    ),
    (
        "",
        "G0X1A2",
        "error:20",
        "gcode.c STEP 2: A axis not supported -> UNSUPPORTED_COMMAND",
    ),
    ("", "G0X1B2", "error:20", "gcode.c STEP 2: B not supported"),
    ("", "G0X1C2", "error:20", "gcode.c STEP 2: C not supported"),
    ("", "D1", "error:20", "gcode.c STEP 2: D not supported"),
    ("", "H1", "error:20", "gcode.c STEP 2: H not supported"),
    ("", "O100", "error:20", "gcode.c STEP 2: O not supported"),
    (
        "",
        "G1X1Q1F10",
        "error:20",
        "gcode.c STEP 2: Q not supported",
    ),
    ("", "g0x1", "ok", "protocol.c: lower case is upcased"),
    ("", "G0 X 1", "ok", "protocol.c: spaces dropped"),
    (
        "",
        "G0X1(a comment)",
        "ok",
        "protocol.c: ( ) comments dropped",
    ),
    (
        "",
        "G0X1(unclosed",
        "ok",
        "protocol.c: a ( comment runs to the line end",
    ),
    (
        "",
        "(only a comment)",
        "ok",
        "protocol.c: an empty line is ok",
    ),
    (
        "",
        "; a comment",
        "ok",
        "protocol.c: ';' comment to the line end",
    ),
    ("", "/G0X1", "ok", "protocol.c: block delete '/' ignored"),
    // ---- G commands (gcode.c STEP 2 'G') ----
    (
        "",
        "G5X1",
        "error:20",
        "gcode.c 'G' default: UNSUPPORTED_COMMAND",
    ),
    ("", "G60", "error:20", "gcode.c 'G' default"),
    (
        "",
        "G81X1",
        "error:20",
        "gcode.c: canned cycles not supported",
    ),
    (
        "",
        "G41",
        "error:20",
        "gcode.c: cutter radius compensation not supported",
    ),
    (
        "",
        "G42",
        "error:20",
        "gcode.c: cutter radius compensation not supported",
    ),
    ("", "G40", "ok", "gcode.c: G40 accepted for program headers"),
    (
        "",
        "G64",
        "error:20",
        "gcode.c 'G' default: G64 not supported",
    ),
    ("", "G61", "ok", "gcode.c case 61"),
    (
        "",
        "G61.1",
        "error:20",
        "gcode.c case 61: G61.1 not supported",
    ),
    (
        "",
        "G0.1X1",
        "error:23",
        "gcode.c: mantissa > 0 -> COMMAND_VALUE_NOT_INTEGER",
    ),
    ("", "G1.5X1F10", "error:23", "gcode.c: mantissa > 0"),
    ("", "G1.0X1F10", "ok", "gcode.c: G1.0 has mantissa 0"),
    ("", "G4.1P1", "error:23", "gcode.c: G4.x has mantissa > 0"),
    (
        "",
        "G10.5L2P1X0",
        "error:23",
        "gcode.c: G10.x has mantissa > 0",
    ),
    ("", "G17.1", "error:23", "gcode.c: G17.x has mantissa > 0"),
    (
        "",
        "G59.1",
        "error:23",
        "gcode.c: G59.x not supported (mantissa > 0)",
    ),
    (
        "",
        "G38.1X1F10",
        "error:20",
        "gcode.c case 38: only G38.2..G38.5",
    ),
    (
        "",
        "G28.2",
        "error:20",
        "gcode.c case 28: mantissa must be 0 or 10",
    ),
    (
        "",
        "G92.2",
        "error:20",
        "gcode.c case 92: G92.2 not supported",
    ),
    (
        "",
        "G30.5",
        "error:20",
        "gcode.c case 30: mantissa must be 0 or 10",
    ),
    (
        "",
        "G90.1",
        "error:20",
        "gcode.c case 90: G90.1 not supported",
    ),
    ("", "G91.2", "error:20", "gcode.c case 91: only G91.1"),
    (
        "",
        "G91.1",
        "ok",
        "gcode.c case 91: G91.1 accepted (IJK incremental is Grbl's only mode)",
    ),
    (
        "",
        "G91G91.1",
        "ok",
        "gcode.c: G91 (group 3) and G91.1 (group 4) differ",
    ),
    ("", "G43", "error:20", "gcode.c case 43: only G43.1"),
    ("", "G43.2Z1", "error:20", "gcode.c case 43: only G43.1"),
    // ---- Modal group violations (gcode.c: MODAL_GROUP_VIOLATION) ----
    ("", "G17G18", "error:21", "gcode.c 'G': group 2 twice"),
    ("", "G20G21", "error:21", "gcode.c 'G': group 6 twice"),
    (
        "",
        "G20G20",
        "error:21",
        "gcode.c 'G': group 6 twice, same word",
    ),
    ("", "G90G91", "error:21", "gcode.c 'G': group 3 twice"),
    ("", "G93G94", "error:21", "gcode.c 'G': group 5 twice"),
    ("", "G54G55", "error:21", "gcode.c 'G': group 12 twice"),
    (
        "",
        "G54G54",
        "error:21",
        "gcode.c 'G': group 12 twice, same word",
    ),
    (
        "",
        "G0G80",
        "error:21",
        "gcode.c 'G': group 1 twice (G80 claims no axes)",
    ),
    ("", "G80G0X1", "error:21", "gcode.c 'G': group 1 twice"),
    ("", "G28.1G30.1", "error:21", "gcode.c 'G': group 0 twice"),
    ("", "G4G53P1", "error:21", "gcode.c 'G': group 0 twice"),
    ("", "G92G4X1P1", "error:21", "gcode.c 'G': group 0 twice"),
    ("", "M3M5", "error:21", "gcode.c 'M': group M7 twice"),
    ("", "M3M4", "error:21", "gcode.c 'M': group M7 twice"),
    (
        "",
        "M3M3",
        "error:21",
        "gcode.c 'M': group M7 twice, same word",
    ),
    ("", "M8M9", "error:21", "gcode.c 'M': group M8 twice"),
    ("", "M0M2", "error:21", "gcode.c 'M': group M4 twice"),
    ("", "M2M30", "error:21", "gcode.c 'M': group M4 twice"),
    ("", "M3M8", "ok", "gcode.c 'M': groups M7 and M8 differ"),
    // ---- Axis command conflicts (gcode.c: AXIS_COMMAND_CONFLICT) ----
    (
        "",
        "G0G1X1",
        "error:24",
        "gcode.c case 0-3: second motion command claims the axes",
    ),
    (
        "F10",
        "G1G2X1I1",
        "error:24",
        "gcode.c case 0-3: axis command conflict",
    ),
    (
        "",
        "G0X1G0Y1",
        "error:24",
        "gcode.c case 0: G0 twice is a conflict before the group check",
    ),
    (
        "",
        "G10L2P1X0G0",
        "error:24",
        "gcode.c case 0: G0 after G10",
    ),
    (
        "",
        "G0G10L2P1X0",
        "error:24",
        "gcode.c case 10: G10 after G0",
    ),
    ("", "G28G30", "error:24", "gcode.c case 30: G30 after G28"),
    ("", "G28G0X1", "error:24", "gcode.c case 0: G0 after G28"),
    ("", "G92G0X1", "error:24", "gcode.c case 0: G0 after G92"),
    (
        "",
        "G43.1Z1G0X1",
        "error:24",
        "gcode.c case 0: G0 after G43.1",
    ),
    (
        "",
        "G0X1G43.1Z1",
        "error:24",
        "gcode.c case 43: G43.1 after G0",
    ),
    (
        "",
        "G92.1G0X1",
        "ok",
        "gcode.c case 92: G92.1 claims no axes",
    ),
    // ---- Value words (gcode.c STEP 2 default; WORD_REPEATED, NEGATIVE_VALUE) ----
    (
        "",
        "G1X1X2F10",
        "error:25",
        "gcode.c: X repeated -> WORD_REPEATED",
    ),
    ("", "G0X1Y1Y2", "error:25", "gcode.c: Y repeated"),
    ("", "F100F200", "error:25", "gcode.c: F repeated"),
    ("", "S1S2", "error:25", "gcode.c: S repeated"),
    ("", "N1N2", "error:25", "gcode.c: N repeated"),
    ("", "G4P1P2", "error:25", "gcode.c: P repeated"),
    (
        "",
        "G1X1F-100",
        "error:4",
        "gcode.c: F negative -> NEGATIVE_VALUE",
    ),
    ("", "M3S-1", "error:4", "gcode.c: S negative"),
    ("", "N-1G0X1", "error:4", "gcode.c: N negative"),
    ("", "G4P-1", "error:4", "gcode.c: P negative"),
    ("", "T-1", "error:4", "gcode.c: T negative"),
    ("", "G0X-1", "ok", "gcode.c: axis words may be negative"),
    ("", "T1", "ok", "gcode.c [5. Select tool]: T tracked only"),
    ("", "T255", "ok", "gcode.c 'T': at most MAX_TOOL_NUMBER"),
    (
        "",
        "T256",
        "error:38",
        "gcode.c 'T': > MAX_TOOL_NUMBER -> MAX_VALUE_EXCEEDED",
    ),
    ("", "F100", "ok", "gcode.c [3. Set feed rate]"),
    (
        "",
        "F0",
        "ok",
        "gcode.c: F0 alone is no error (undefined feed)",
    ),
    ("", "S100", "ok", "gcode.c [4. Set spindle speed]"),
    // ---- Line numbers (gcode.c [0.]: INVALID_LINE_NUMBER) ----
    ("", "N1G0X1", "ok", "gcode.c 'N'"),
    ("", "N10000000", "ok", "gcode.c: N up to MAX_LINE_NUMBER"),
    (
        "",
        "N10000001G0X1",
        "error:27",
        "gcode.c: N > MAX_LINE_NUMBER",
    ),
    ("", "N1.5G0X1", "ok", "gcode.c 'N': trunc(value)"),
    ("", "N1", "ok", "gcode.c: a line number alone"),
    // ---- Unused words (gcode.c [0. Non-specific error-checks]: UNUSED_WORDS) ----
    ("", "G0X1I5", "error:36", "gcode.c: I unused outside an arc"),
    ("", "G0X1R5", "error:36", "gcode.c: R unused outside an arc"),
    ("", "G0X1P1", "error:36", "gcode.c: P unused outside G4/G10"),
    ("", "G0X1L2", "error:36", "gcode.c: L unused outside G10"),
    ("F10", "G1X1K1", "error:36", "gcode.c: K unused"),
    ("", "I1", "error:36", "gcode.c: I alone"),
    ("", "J1", "error:36", "gcode.c: J alone"),
    ("", "L2", "error:36", "gcode.c: L alone"),
    ("", "P1", "error:36", "gcode.c: P alone"),
    ("", "R1", "error:36", "gcode.c: R alone"),
    (
        "F10",
        "G2X10I5R5",
        "error:36",
        "gcode.c [G2/3 Radius-Mode]: R used, I unused",
    ),
    (
        "F10",
        "G2X10I5P1",
        "error:36",
        "gcode.c: P unused with an arc",
    ),
    (
        "",
        "G10L20P1R1X0",
        "error:36",
        "gcode.c [G10 L20]: R is not used",
    ),
    (
        "",
        "G10L2P1X0I1",
        "error:36",
        "gcode.c [G10]: I is not used",
    ),
    // ---- Feed (gcode.c [2./3.] and [20. Motion modes]: UNDEFINED_FEED_RATE) ----
    ("", "G1X1", "error:22", "gcode.c [20.]: G1 with feed rate 0"),
    (
        "",
        "G1",
        "error:22",
        "gcode.c [20.]: G1 claims the axes even without axis words",
    ),
    (
        "",
        "G1F100",
        "ok",
        "gcode.c [20.]: G1 with a feed and no axis words does nothing",
    ),
    (
        "",
        "G1X1F0",
        "error:22",
        "gcode.c [20.]: F0 is an undefined feed",
    ),
    (
        "F100",
        "G1X1",
        "ok",
        "gcode.c [3.]: the last F is kept in G94",
    ),
    (
        "",
        "G0",
        "ok",
        "gcode.c [20.]: G0 without axis words does nothing",
    ),
    (
        "",
        "X1Y1Z1",
        "ok",
        "gcode.c [0.]: axis words alone use the motion mode (G0)",
    ),
    (
        "F10",
        "G93G1X1",
        "error:22",
        "gcode.c [2.]: G93 needs F on every feed move",
    ),
    ("", "G93G1X1F2", "ok", "gcode.c [2.]: G93 with F"),
    ("", "G93G0X1", "ok", "gcode.c [2.]: G0 needs no F in G93"),
    (
        "F10\nG93",
        "G1X1",
        "error:22",
        "gcode.c [2.]: in G93 the last F does not carry over",
    ),
    (
        "F10\nG93",
        "G94G1X1",
        "error:22",
        "gcode.c [3.]: G93 to G94 leaves the feed undefined",
    ),
    (
        "F10\nG93",
        "G94G1X1F5",
        "ok",
        "gcode.c [3.]: G94 with its own F",
    ),
    (
        "",
        "G20G1X1F4",
        "ok",
        "gcode.c [3.]: F in inches per minute",
    ),
    // ---- Dwell (gcode.c [10. Dwell]: VALUE_WORD_MISSING) ----
    ("", "G4", "error:28", "gcode.c [10.]: G4 without P"),
    ("", "G4P0.01", "ok", "gcode.c [10.]: dwell"),
    ("", "G4P0", "ok", "gcode.c [10.]: a zero dwell"),
    (
        "",
        "G4X1P0.01",
        "ok",
        "gcode.c [0.]: G4 claims no axes; X1 runs in G0",
    ),
    // ---- G10 (gcode.c [G10 Errors]) ----
    ("", "G10L2P1X5", "ok", "gcode.c [G10 L2]: set G54"),
    (
        "",
        "G10L20P1X5",
        "ok",
        "gcode.c [G10 L20]: set G54 from here",
    ),
    ("", "G10L2P6X5", "ok", "gcode.c [G10]: P6 is G59"),
    (
        "",
        "G10L2P0X5",
        "ok",
        "gcode.c [G10]: P0 is the active system",
    ),
    (
        "",
        "G10L2X5",
        "ok",
        "gcode.c [G10]: only P and L both missing is an error; P0 assumed",
    ),
    (
        "",
        "G10L2P1",
        "error:26",
        "gcode.c [G10]: no axis words -> NO_AXIS_WORDS",
    ),
    (
        "",
        "G10X5",
        "error:28",
        "gcode.c [G10]: P and L missing -> VALUE_WORD_MISSING",
    ),
    (
        "",
        "G10P1X5",
        "error:20",
        "gcode.c [G10]: L missing reads as L0, unsupported",
    ),
    ("", "G10L3P1X5", "error:20", "gcode.c [G10]: L3 unsupported"),
    (
        "",
        "G10L2P7X5",
        "error:29",
        "gcode.c [G10]: P > N_COORDINATE_SYSTEM -> UNSUPPORTED_COORD_SYS",
    ),
    (
        "",
        "G10L2P1R1X5",
        "error:20",
        "gcode.c [G10 L2]: R not supported",
    ),
    ("", "G10L2P1.5X5", "ok", "gcode.c [G10]: P truncated to 1"),
    ("", "G10L2P-1X5", "error:4", "gcode.c STEP 2: P negative"),
    // ---- G92 (gcode.c [G92 Errors]) and G28/G30 ----
    ("", "G92X0Y0", "ok", "gcode.c [G92]"),
    ("", "G92", "error:26", "gcode.c [G92]: no axis words"),
    ("", "G92.1", "ok", "gcode.c: G92.1 clears the offset"),
    (
        "",
        "G92.1X1",
        "ok",
        "gcode.c [19.]: axis words with G92.1 move in the motion mode",
    ),
    ("", "G28", "ok", "gcode.c [G28]: to the stored position"),
    ("", "G28X5", "ok", "gcode.c [G28]: via X5"),
    (
        "",
        "G28G91X0",
        "ok",
        "gcode.c [G28]: intermediate point in G91",
    ),
    ("", "G28.1", "ok", "gcode.c: store G28 position"),
    ("", "G30Z5", "ok", "gcode.c [G30]: via Z5"),
    ("", "G30.1", "ok", "gcode.c: store G30 position"),
    (
        "",
        "G28.1X1",
        "ok",
        "gcode.c [19.]: axis words with G28.1 move in the motion mode",
    ),
    // ---- G53 (gcode.c [G53 Errors]: G53_INVALID_MOTION_MODE) ----
    ("", "G53G0X1", "ok", "gcode.c [G53]: with G0"),
    ("", "G53X1", "ok", "gcode.c [G53]: G0 active"),
    ("", "G53G1X1F10", "ok", "gcode.c [G53]: with G1"),
    ("", "G53G91X1", "ok", "gcode.c [G53]: distance mode ignored"),
    ("", "G53", "ok", "gcode.c [G53]: alone, G0 active"),
    ("F10", "G53G2X10I5", "error:30", "gcode.c [G53]: G2 active"),
    (
        "F10\nG2X0I1",
        "G53X1",
        "error:30",
        "gcode.c [G53]: G2 still active from the last line",
    ),
    ("G80", "G53X1", "error:30", "gcode.c [G53]: G80 active"),
    // ---- G80 (gcode.c [G80 Errors]: AXIS_WORDS_EXIST) ----
    ("", "G80", "ok", "gcode.c: motion cancelled"),
    ("", "G80X1", "error:31", "gcode.c [G80]: axis words"),
    (
        "G80",
        "X1",
        "error:31",
        "gcode.c [G80]: axis words with G80 active",
    ),
    (
        "G80",
        "G92X0",
        "error:31",
        "gcode.c [G80]: even G92's axis words",
    ),
    ("G80", "G0X1", "ok", "gcode.c: G0 leaves G80"),
    // ---- Arcs (gcode.c [G2/3 Errors]) ----
    (
        "F100",
        "G2X10Y0R5",
        "ok",
        "gcode.c [G2/3 Radius]: a half circle",
    ),
    ("F100", "G3X10R5", "ok", "gcode.c [G2/3 Radius]: Y kept"),
    (
        "F100",
        "G2X10Y10R-10",
        "ok",
        "gcode.c [G2/3 Radius]: negative R, the long way",
    ),
    (
        "F100",
        "G2X10R4",
        "error:34",
        "gcode.c [G2/3 Radius]: 4r^2 < d^2 -> ARC_RADIUS_ERROR",
    ),
    (
        "F100",
        "G2X0Y0R5",
        "error:33",
        "gcode.c [G2/3 Radius]: target = position -> INVALID_TARGET",
    ),
    ("F100", "G2R5", "error:26", "gcode.c [G2/3]: no axis words"),
    ("F100", "G2", "error:26", "gcode.c [G2/3]: no axis words"),
    (
        "F100",
        "G2Z1R5",
        "error:32",
        "gcode.c [G2/3]: no axis word in the plane (G17)",
    ),
    (
        "F100",
        "G2X10I5",
        "ok",
        "gcode.c [G2/3 Offset]: centre (5,0)",
    ),
    ("F100", "G2X10I5J0", "ok", "gcode.c [G2/3 Offset]: I and J"),
    (
        "F100",
        "G2X10",
        "error:35",
        "gcode.c [G2/3 Offset]: no offsets -> NO_OFFSETS_IN_PLANE",
    ),
    (
        "F100",
        "G2X10K5",
        "error:35",
        "gcode.c [G2/3 Offset]: K is not in the XY plane",
    ),
    (
        "F100",
        "G2X10I4",
        "error:33",
        "gcode.c [G2/3 Offset]: radii differ by 2 mm > 0.5",
    ),
    (
        "F100",
        "G2X10I5.002",
        "ok",
        "gcode.c [G2/3 Offset]: radii differ by 0.004 <= 0.005",
    ),
    (
        "F100",
        "G2X10I5.004",
        "error:33",
        "gcode.c [G2/3 Offset]: 0.008 > 0.005 and > 0.1% of r",
    ),
    (
        "F100",
        "G2X200I100.04",
        "ok",
        "gcode.c [G2/3 Offset]: 0.08 within 0.1% of r=100.04",
    ),
    (
        "F100",
        "G2X200I100.2",
        "error:33",
        "gcode.c [G2/3 Offset]: 0.4 over 0.1% of r",
    ),
    (
        "F100",
        "G2X0Y0I5",
        "ok",
        "gcode.c / mc_arc: a full circle (target = start)",
    ),
    (
        "F100",
        "G3X0Y0J5",
        "ok",
        "mc_arc: a full circle counter-clockwise",
    ),
    ("F100", "G2X10Y0Z3R5", "ok", "mc_arc: a helix"),
    (
        "F100",
        "G18G2X10I5",
        "ok",
        "gcode.c [11.]: ZX plane, I in plane",
    ),
    (
        "F100",
        "G18G2Y10J5",
        "error:32",
        "gcode.c [G2/3]: Y not in the ZX plane",
    ),
    ("F100", "G19G2Y10J5", "ok", "gcode.c [11.]: YZ plane"),
    (
        "F100",
        "G19G2Y10I5",
        "error:35",
        "gcode.c [G2/3 Offset]: I not in the YZ plane",
    ),
    (
        "F100",
        "G2X10I5G3",
        "error:24",
        "gcode.c case 3: second motion command",
    ),
    (
        "F10",
        "G20G2X1I0.5",
        "ok",
        "gcode.c [12.]: inches, I converted",
    ),
    (
        "",
        "G93G2X10I5",
        "error:22",
        "gcode.c [2.]: G93 arc without F",
    ),
    ("", "G93G2X10I5F2", "ok", "gcode.c [2.]: G93 arc with F"),
    (
        "",
        "G2X10I5",
        "error:22",
        "gcode.c [20.]: arc without a feed",
    ),
    ("F100\nG2X10I5", "X0I-5", "ok", "gcode.c: G2 stays modal"),
    // ---- Probing without a probe (gcode.c [G38 Errors], motion_control.c mc_probe_cycle) ----
    (
        "",
        "G38.2X1F100",
        "ok",
        "mc_probe_cycle: no contact -> ALARM:5, then ok",
    ),
    (
        "",
        "G38.3X1F100",
        "ok",
        "mc_probe_cycle: no contact, no error",
    ),
    (
        "",
        "G38.4X1F100",
        "ok",
        "mc_probe_cycle: away, no contact -> ALARM:5, then ok",
    ),
    ("", "G38.5X1F100", "ok", "mc_probe_cycle: away, no error"),
    (
        "",
        "G38.2X0F100",
        "error:33",
        "gcode.c [G38]: target = position -> INVALID_TARGET",
    ),
    ("", "G38.2F100", "error:26", "gcode.c [G38]: no axis words"),
    (
        "",
        "G38.2X1",
        "error:22",
        "gcode.c [20.]: probe without a feed",
    ),
    // ---- Tool length (gcode.c [14.]: G43_DYNAMIC_AXIS_ERROR) ----
    ("", "G43.1Z1", "ok", "gcode.c [14.]: G43.1 Z"),
    ("", "G43.1X1", "error:37", "gcode.c [14.]: G43.1 on X"),
    ("", "G43.1", "error:37", "gcode.c [14.]: G43.1 without Z"),
    (
        "",
        "G43.1Z1X1",
        "error:37",
        "gcode.c [14.]: G43.1 with another axis",
    ),
    ("", "G49", "ok", "gcode.c [14.]: cancel"),
    (
        "",
        "G49X1",
        "ok",
        "gcode.c [0.]: G49 claims the axis words, nothing moves",
    ),
    // ---- Work coordinate systems, units, distance, plane, feed mode ----
    ("", "G54", "ok", "gcode.c [15.]"),
    ("", "G55", "ok", "gcode.c [15.]"),
    ("", "G59", "ok", "gcode.c [15.]"),
    ("", "G17", "ok", "gcode.c [11.]"),
    ("", "G18", "ok", "gcode.c [11.]"),
    ("", "G19", "ok", "gcode.c [11.]"),
    ("", "G20", "ok", "gcode.c [12.]"),
    ("", "G21", "ok", "gcode.c [12.]"),
    ("", "G90", "ok", "gcode.c [17.]"),
    ("", "G91", "ok", "gcode.c [17.]"),
    ("", "G93", "ok", "gcode.c [2.]"),
    ("", "G94", "ok", "gcode.c [2.]"),
    (
        "",
        "G21G90G17G94G54G40G49G80",
        "ok",
        "a common program header",
    ),
    // ---- The line buffer (protocol.c: LINE_BUFFER_SIZE 80, overflow at 79 characters kept) ----
    (
        "",
        "G0X1.00000000000000000000000000000000000000000000000000000000000000000000000000",
        "ok",
        "protocol.c: 79 characters fit the line buffer",
    ),
    (
        "",
        "G0X1.000000000000000000000000000000000000000000000000000000000000000000000000000",
        "error:11",
        "protocol.c: the 80th character kept sets LINE_FLAG_OVERFLOW -> STATUS_OVERFLOW",
    ),
    (
        "",
        "G1 X11111111111111111111111111111111111111111111111111111111111111111111111111111111 F100",
        "error:11",
        "protocol.c: an 80-digit number overflows the line before read_float sees it",
    ),
    (
        "",
        "G0 X1. 0000000000 0000000000 0000000000 0000000000 0000000000 0000000000 00000000000000",
        "ok",
        "protocol.c: spaces never enter the line buffer (79 characters kept)",
    ),
    (
        "",
        "G0X1(a comment that is long enough to pass eighty characters on the line)Y2",
        "ok",
        "protocol.c: comments never enter the line buffer",
    ),
    (
        "",
        "G10 L2 P1",
        "error:26",
        "gcode.c [G10]: no axis words, spaced as typed",
    ),
    (
        "",
        "G10 L20 P1",
        "error:26",
        "gcode.c [G10]: no axis words (L20)",
    ),
    // ---- M commands (gcode.c 'M'; config.h default build) ----
    ("", "M1", "ok", "gcode.c case 1: optional stop ignored"),
    ("", "M2", "ok", "gcode.c [21.]: program end"),
    ("", "M30", "ok", "gcode.c [21.]: program end"),
    ("", "M2.0", "ok", "gcode.c 'M': mantissa 0"),
    ("", "M3", "ok", "gcode.c [7.]"),
    ("", "M4", "ok", "gcode.c [7.]"),
    ("", "M5", "ok", "gcode.c [7.]"),
    ("", "M3S1000", "ok", "gcode.c [4.]/[7.]"),
    (
        "",
        "M7",
        "error:20",
        "config.h: ENABLE_M7 off in the default build",
    ),
    ("", "M8", "ok", "gcode.c [8.]"),
    ("", "M9", "ok", "gcode.c [8.]"),
    (
        "",
        "M6",
        "error:20",
        "gcode.c 'M' default: tool change not supported",
    ),
    (
        "",
        "M56",
        "error:20",
        "config.h: ENABLE_PARKING_OVERRIDE_CONTROL off",
    ),
    ("", "M48", "error:20", "gcode.c 'M' default"),
    ("", "M62P1", "error:20", "gcode.c 'M' default"),
    ("", "M3.5", "error:23", "gcode.c 'M': mantissa > 0"),
    (
        "",
        "M0",
        "ok after ~",
        "gcode.c [21.]: M0 holds until cycle start",
    ),
];

fn interpreter_answer(setup: &str, line: &str) -> String {
    let mut m = Modal::default();
    for (i, l) in setup.lines().enumerate() {
        gcode::step(&mut m, l, i + 1).unwrap_or_else(|e| panic!("setup {l:?}: {e}"));
    }
    match gcode::step(&mut m, line, 99) {
        Ok(_) => "ok".into(),
        Err(e) => format!("error:{}", e.code),
    }
}

/// Read from the virtual Grbl until a line's answer (`ok` or `error:N`), returning every line.
fn answer(port: &mut TTYPort, limit: Duration) -> Vec<String> {
    let mut got = String::new();
    let end = Instant::now() + limit;
    let mut buf = [0u8; 256];
    port.set_timeout(Duration::from_millis(10)).unwrap();
    loop {
        let lines: Vec<String> = got.split("\r\n").map(str::to_string).collect();
        let complete = &lines[..lines.len() - 1];
        if complete
            .iter()
            .any(|l| l == "ok" || l.starts_with("error:"))
            || Instant::now() > end
        {
            return complete.to_vec();
        }
        if let Ok(n) = port.read(&mut buf) {
            got.push_str(&String::from_utf8_lossy(&buf[..n]));
        }
    }
}

fn virtual_answer(setup: &str, line: &str) -> (String, Vec<String>) {
    let (vg, mut port) = VirtualGrbl::spawn(VirtualConfig::default()).unwrap();
    read_until(&mut port, "for help]\r\n");
    for l in setup.lines() {
        port.write_all(format!("{l}\n").as_bytes()).unwrap();
        let a = answer(&mut port, Duration::from_secs(5));
        assert_eq!(
            a.last().map(String::as_str),
            Some("ok"),
            "setup {l:?}: {a:?}"
        );
    }
    port.write_all(format!("{line}\n").as_bytes()).unwrap();
    let mut a = answer(&mut port, Duration::from_millis(400));
    let mut last = a.last().cloned().unwrap_or_default();
    if last.is_empty() {
        // M0 holds: the answer comes with cycle start.
        port.write_all(b"~").unwrap();
        a = answer(&mut port, Duration::from_secs(5));
        last = match a.last() {
            Some(l) => format!("{l} after ~"),
            None => "nothing".into(),
        };
    }
    drop(vg);
    (last, a)
}

#[test]
fn every_case_answers_as_grbl_1_1h() {
    assert!(CASES.len() >= 150, "{} cases", CASES.len());
    let mut wrong = Vec::new();
    for &(setup, line, want, rule) in CASES {
        let offline = interpreter_answer(setup, line);
        let want_offline = want.trim_end_matches(" after ~");
        if offline != want_offline {
            wrong.push(format!(
                "interpreter: {line:?} -> {offline}, Grbl {want} ({rule})"
            ));
        }
        let (got, _) = virtual_answer(setup, line);
        if got != want {
            wrong.push(format!(
                "virtual Grbl: {line:?} -> {got}, Grbl {want} ({rule})"
            ));
        }
    }
    assert!(
        wrong.is_empty(),
        "{} of {} differ:\n{}",
        wrong.len(),
        CASES.len(),
        wrong.join("\n")
    );
}

#[test]
fn a_probe_without_contact_alarms_as_grbl_does() {
    for (line, alarm) in [
        ("G38.2X1F100", true),
        ("G38.3X1F100", false),
        ("G38.4X1F100", true),
        ("G38.5X1F100", false),
    ] {
        let (last, all) = virtual_answer("", line);
        assert_eq!(last, "ok", "{line}: {all:?}");
        assert_eq!(all.iter().any(|l| l == "ALARM:5"), alarm, "{line}: {all:?}");
    }
    // Locked in the alarm: G-code is refused with error:9 until $X.
    let (vg, mut port) = VirtualGrbl::spawn(VirtualConfig::default()).unwrap();
    read_until(&mut port, "for help]\r\n");
    for (l, want) in [
        ("G38.2X1F100", "ok"),
        ("G0X0", "error:9"),
        ("$X", "ok"),
        ("G0X0", "ok"),
    ] {
        port.write_all(format!("{l}\n").as_bytes()).unwrap();
        let a = answer(&mut port, Duration::from_secs(5));
        assert_eq!(a.last().map(String::as_str), Some(want), "{l}: {a:?}");
    }
    drop(vg);
}

#[test]
fn a_program_end_says_so() {
    let (last, all) = virtual_answer("", "M2");
    assert_eq!(last, "ok");
    assert!(all.iter().any(|l| l == "[MSG:Pgm End]"), "{all:?}");
}

/// `$J=` jogs, answered by gc_execute_line with its jog flag (gcode.c `GC_PARSER_JOG_MOTION`);
/// checked against Grbl 1.1h's own parser the same way as [`CASES`].
const JOG_CASES: &[(&str, &str, &str)] = &[
    ("$J=X1F100", "ok", "gcode.c: a jog in G1, G94"),
    (
        "$J=F100",
        "ok",
        "gcode.c: no axis words is no error (the target is machine zero)",
    ),
    ("$J=G91X1F100", "ok", "gcode.c jog: G91 allowed"),
    ("$J=G53X1F100", "ok", "gcode.c jog: G53 allowed"),
    ("$J=G20X1F10", "ok", "gcode.c jog: G20 allowed, F in inches"),
    ("$J=N5X1F100", "ok", "gcode.c jog: N allowed"),
    ("$J=X1", "error:22", "gcode.c [2.] jog: F required"),
    ("$J=F0X1", "error:22", "gcode.c [20.]: F0 is no feed"),
    ("$J=X1F-5", "error:4", "gcode.c STEP 2: F negative"),
    (
        "$J=M3X1",
        "error:22",
        "gcode.c: the F check comes before the jog's command check",
    ),
    (
        "$J=M3X1F100",
        "error:16",
        "gcode.c jog: M commands -> INVALID_JOG_COMMAND",
    ),
    (
        "$J=G1X1F100",
        "error:16",
        "gcode.c jog: motion commands not allowed",
    ),
    (
        "$J=G28X1F10",
        "error:16",
        "gcode.c jog: non-modal other than G53",
    ),
    (
        "$J=G4X1F100",
        "error:28",
        "gcode.c [10.]: G4's P check comes first",
    ),
    ("$J=X1I1F100", "error:36", "gcode.c: I unused"),
    (
        "$J=X1F100S1",
        "error:36",
        "gcode.c jog: S is unused on a jog",
    ),
    (
        "$J=T1X1F10",
        "error:36",
        "gcode.c jog: T is unused on a jog",
    ),
    ("$J=G90G91X1F10", "error:21", "gcode.c: group 3 twice"),
    ("$J=X1X2F10", "error:25", "gcode.c: X repeated"),
];

#[test]
fn jogs_answer_as_grbl_1_1h() {
    let mut wrong = Vec::new();
    for &(line, want, rule) in JOG_CASES {
        let body = line.strip_prefix("$J=").unwrap();
        let offline = match gcode::jog(&Modal::default(), body, 1) {
            Ok(_) => "ok".to_string(),
            Err(e) => format!("error:{}", e.code),
        };
        if offline != want {
            wrong.push(format!(
                "interpreter: {line} -> {offline}, Grbl {want} ({rule})"
            ));
        }
        let (got, _) = virtual_answer("", line);
        if got != want {
            wrong.push(format!(
                "virtual Grbl: {line} -> {got}, Grbl {want} ({rule})"
            ));
        }
    }
    assert!(wrong.is_empty(), "{}", wrong.join("\n"));
}
