//! Framing: trace the rectangle a G-code job will cut, tool off (or a laser at a glimmer), so the
//! user sees where it lands on the sheet before anything is cut.
//!
//! Works on any G-code file: the extent is taken from the moves the shared interpreter reads,
//! counting only the moves that cut (a laser's powered feed moves; for a program that never
//! switches a spindle on, a pen or knife on Z, its feed moves in X/Y), so the travel to the first
//! cut and the return home do not inflate the box. The frame is itself a short program streamed
//! like a job, so it has every stop a job has (error, alarm, lost port, abort: laser off).

use super::error::MachineError;
use super::program::{Extent, Program};
use super::protocol::MachineState;
use crate::stream::Console;
use stencil_gcode::num;

/// How the tool is kept from cutting while framing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FrameTool {
    /// A laser: dark (`s` = 0: `M5 S0`), or at `s` in dynamic mode (`M4 S<s>`), so the beam is
    /// dim and lit only while the head moves along the frame; off (`M5 S0`) for the travel.
    Laser {
        /// Laser power while tracing.
        s: f64,
        /// The work Z the job cuts at, taken first (`G0 Z`) when the job sets its own Z (a head
        /// focused at Z5 frames there, not wherever it stood); `None` leaves Z alone.
        z: Option<f64>,
    },
    /// A pen or knife on Z: lifted to `up_mm` (work Z) before any move, and left there.
    ZUp {
        /// Work Z of the lifted tool.
        up_mm: f64,
    },
    /// A pen servo on the spindle output: `M5` keeps it up.
    SpindlePen,
}

/// What to frame and how.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FramePlan {
    /// The rectangle to trace.
    pub extent: Extent,
    /// Where the head is when framing starts (work coordinates): it comes back here.
    pub start: [f64; 2],
    /// How the tool stays off the work.
    pub tool: FrameTool,
    /// Feed along the frame, mm/min.
    pub feed_mm_min: f64,
}

/// The frame as a G-code program: to the first corner at travel, around the rectangle at the
/// framing feed (counter-clockwise from the lower-left corner), back to the start; the laser
/// dark (`M5 S0`) at the end, and air (coolant) off (`M9`) with it.
pub(crate) fn frame_program(p: &FramePlan) -> String {
    let e = &p.extent;
    let (x0, y0, x1, y1) = (num(e.min[0]), num(e.min[1]), num(e.max[0]), num(e.max[1]));
    let f = num(p.feed_mm_min);
    let mut out = vec![
        format!(
            "; frame: X{x0}..{x1} Y{y0}..{y1} mm at F{f}, {}",
            match p.tool {
                FrameTool::Laser { s, .. } if s > 0.0 => format!("laser dim at S{}", num(s)),
                FrameTool::Laser { .. } => "laser off".into(),
                FrameTool::ZUp { up_mm } => format!("tool up at Z{}", num(up_mm)),
                FrameTool::SpindlePen => "pen up (M5)".into(),
            }
        ),
        "G21 G90 G94".into(),
    ];
    match p.tool {
        FrameTool::Laser { z, .. } => {
            out.push("M5 S0".into());
            if let Some(z) = z {
                out.push(format!("G0 Z{}", num(z)));
            }
        }
        FrameTool::ZUp { up_mm } => out.push(format!("G0 Z{}", num(up_mm))),
        FrameTool::SpindlePen => out.push("M5".into()),
    }
    out.push(format!("G0 X{x0} Y{y0}"));
    if let FrameTool::Laser { s, .. } = p.tool {
        if s > 0.0 {
            out.push(format!("M4 S{}", num(s)));
        }
    }
    out.push(format!("G1 X{x1} Y{y0} F{f}"));
    out.push(format!("G1 X{x1} Y{y1}"));
    out.push(format!("G1 X{x0} Y{y1}"));
    out.push(format!("G1 X{x0} Y{y0}"));
    if let FrameTool::Laser { .. } = p.tool {
        out.push("M5 S0".into());
    }
    out.push(format!("G0 X{} Y{}", num(p.start[0]), num(p.start[1])));
    out.push("M9".into());
    out.push(match p.tool {
        FrameTool::Laser { .. } => "M5 S0".into(),
        _ => "M5".into(),
    });
    out.join("\n") + "\n"
}

/// Why a frame did not run, or stopped.
#[allow(missing_docs)] // Each variant's message says when it happens and what its fields are.
#[derive(Debug, thiserror::Error)]
pub enum FrameError {
    #[error(
        "{port}: the machine is locked in alarm; check it, then home it ($H) or unlock it ($X)"
    )]
    Locked { port: String },
    #[error("{port}: the machine is busy ({state}); wait until it is Idle")]
    Busy { port: String, state: String },
    #[error("framing stopped: Grbl rejected `{text}` with error:{code} ({}); {laser}", super::protocol::error_meaning(*code))]
    Rejected {
        text: String,
        code: u8,
        laser: String,
    },
    #[error("framing stopped: ALARM:{code} ({}); {laser}", super::protocol::alarm_meaning(*code))]
    Alarm { code: u8, laser: String },
    #[error("framing aborted by the operator; {laser}")]
    Aborted { laser: String },
    #[error("framing stopped: {port}: the port went away ({detail}); {laser}")]
    PortLost {
        port: String,
        detail: String,
        laser: String,
    },
    #[error("framing stopped: {port}: Grbl has not answered for {secs:.1} s; {laser}")]
    Silent {
        port: String,
        secs: f64,
        laser: String,
    },
    #[error("framing stopped: Grbl restarted (power or reset); {laser}")]
    Restarted { laser: String },
    #[error("framing stopped: {0}")]
    Machine(Box<MachineError>),
}

impl From<MachineError> for FrameError {
    /// A stop while framing, worded for a frame (a frame has no line to resume from).
    fn from(e: MachineError) -> Self {
        match e {
            MachineError::Rejected {
                text, code, halt, ..
            } => FrameError::Rejected {
                text,
                code,
                laser: halt.laser,
            },
            MachineError::Alarm { code, halt } => FrameError::Alarm {
                code,
                laser: halt.laser,
            },
            MachineError::Aborted { halt } => FrameError::Aborted { laser: halt.laser },
            MachineError::PortLost { port, detail, halt } => FrameError::PortLost {
                port,
                detail,
                laser: halt.laser,
            },
            MachineError::Silent { port, secs, halt } => FrameError::Silent {
                port,
                secs,
                laser: halt.laser,
            },
            MachineError::Restarted { halt } => FrameError::Restarted { laser: halt.laser },
            e => FrameError::Machine(Box::new(e)),
        }
    }
}

/// What a frame did.
#[derive(Clone, Debug, PartialEq)]
pub struct Framed {
    /// What was traced.
    pub plan: FramePlan,
    /// The program that was streamed.
    pub program: String,
    /// Work position before, mm.
    pub start: [f64; 3],
    /// Work position after, mm.
    pub end: [f64; 3],
}

/// Trace `extent` on the machine behind `console`: read where the head is, stream the frame
/// program (which comes back there), and read where it ended. The machine must be idle and not
/// locked.
pub fn frame(
    console: &mut Console<'_>,
    extent: Extent,
    tool: FrameTool,
    feed_mm_min: f64,
) -> Result<Framed, FrameError> {
    let port = console.port_name().to_string();
    if console.locked() {
        return Err(FrameError::Locked { port });
    }
    let before = console.position()?;
    match before.status.state {
        MachineState::Idle => {}
        MachineState::Alarm => return Err(FrameError::Locked { port }),
        ref s => {
            return Err(FrameError::Busy {
                port,
                state: s.to_string(),
            })
        }
    }
    let plan = FramePlan {
        extent,
        start: [before.work[0], before.work[1]],
        tool,
        feed_mm_min,
    };
    let program = frame_program(&plan);
    let job = Program::parse("frame", &program)?;
    console.run(&job)?;
    let after = console.position()?;
    Ok(Framed {
        plan,
        program,
        start: before.work,
        end: after.work,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::program::cut_extent;
    use stencil_gcode::interpret::interpret;

    #[test]
    fn extent_counts_only_cutting_moves() {
        // Laser: the travel to (100, 100) and back home does not count.
        let p = "G0 X100 Y100\nG0 X10 Y20 S0\nM4 S500\nG1 X30 F600\nG1 Y50\nG0 X0 Y0 S0\nM5\n";
        let e = cut_extent(&interpret(p).unwrap()).unwrap();
        assert_eq!((e.min, e.max, e.moves), ([10.0, 20.0], [30.0, 50.0], 2));
        // Knife on Z: feed moves in X/Y cut; the plunge (Z only) does not move the box.
        let k = "G0 Z3\nG0 X5 Y5\nG1 Z-0.3 F300\nG1 X15 F900\nG1 Y25\nG0 Z3\nG0 X0 Y0\n";
        let e = cut_extent(&interpret(k).unwrap()).unwrap();
        assert_eq!((e.min, e.max), ([5.0, 5.0], [15.0, 25.0]));
        assert!(cut_extent(&interpret("G0 X1\n").unwrap()).is_none());
    }

    #[test]
    fn program_traces_the_box_and_returns() {
        let plan = FramePlan {
            extent: Extent {
                min: [10.0, 20.0],
                max: [30.0, 50.0],
                moves: 2,
            },
            start: [1.5, 2.0],
            tool: FrameTool::Laser { s: 10.0, z: None },
            feed_mm_min: 3000.0,
        };
        let text = frame_program(&plan);
        let moves = interpret(&text).unwrap();
        let ends: Vec<[f64; 2]> = moves.iter().map(|m| [m.to[0], m.to[1]]).collect();
        assert_eq!(
            ends,
            [
                [10.0, 20.0],
                [30.0, 20.0],
                [30.0, 50.0],
                [10.0, 50.0],
                [10.0, 20.0],
                [1.5, 2.0]
            ]
        );
        // Dim while tracing, dark on the travels.
        let powers: Vec<f64> = moves.iter().map(|m| m.power).collect();
        assert_eq!(powers, [0.0, 10.0, 10.0, 10.0, 10.0, 0.0]);
        assert!(text.trim_end().ends_with("M9\nM5 S0"), "{text}");
        let dark = frame_program(&FramePlan {
            tool: FrameTool::Laser { s: 0.0, z: None },
            ..plan
        });
        assert!(!dark.contains("M4") && !dark.contains("M3"), "{dark}");
        let knife = frame_program(&FramePlan {
            tool: FrameTool::ZUp { up_mm: 3.0 },
            ..plan
        });
        let km = interpret(&knife).unwrap();
        assert_eq!(km[0].to, [0.0, 0.0, 3.0]);
        assert!(km.iter().all(|m| m.to[2] == 3.0 && m.power == 0.0));
    }
}
