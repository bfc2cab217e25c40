//! `stencil send --to-card`: the job uploaded to the controller's card and run there, followed
//! by status reports; after a dropped network link the controller is reached again and the job
//! followed to its end (never reset: the cut went on).

use std::process::ExitCode;
use std::sync::mpsc::{Receiver, Sender};

use stencil_grbl::{BytePort, Control, MachineError, Program, StreamConfig, VirtualGrbl};

use super::super::operator::{abort_cause, Keys};
use super::output::print_virtual;

/// The opened link, and what is behind it.
pub(super) struct Run {
    pub(super) port: Box<dyn BytePort>,
    pub(super) label: String,
    pub(super) virtual_grbl: Option<VirtualGrbl>,
    pub(super) tcp: Option<String>,
}

/// Prints what the card run says.
struct Say;
impl stencil_grbl::Observer for Say {
    fn message(&mut self, text: &str) {
        println!("{text}");
    }
}

pub(super) fn run(
    r: Run,
    job: &Program,
    cfg: &StreamConfig,
    tx: Sender<Control>,
    rx: &Receiver<Control>,
) -> anyhow::Result<ExitCode> {
    let Run {
        mut port,
        label,
        virtual_grbl,
        tcp,
    } = r;
    let keys = Keys::start(tx);
    if keys.raw {
        println!("keys: {}", stencil_grbl::SEND_KEY_HELP);
    }
    let result = stencil_grbl::send_to_card(port.as_mut(), job, cfg, Some(rx), &mut Say);
    let done = match result {
        Ok(sum) => {
            println!(
                "{}: {} ran from the card of {} ({} lines, {} bytes uploaded) in {:.1} s",
                label,
                sum.file,
                sum.info.name(),
                sum.lines,
                sum.bytes,
                sum.elapsed.as_secs_f64()
            );
            Ok(())
        }
        Err(MachineError::CardLinkLost { file, .. }) if tcp.is_some() => {
            let tcp = tcp.unwrap_or_default();
            eprintln!(
                "the network link to tcp://{tcp} dropped while the controller runs {file} from \
                 its card: the cut goes on there; reaching it again to follow the job (it is not \
                 reset)"
            );
            // The old connection is given up before the controller is reached again.
            drop(port);
            match super::super::port::reach(&tcp) {
                Some(mut port) => {
                    match stencil_grbl::watch_card(&mut port, &file, cfg, Some(rx), &mut Say) {
                        Ok(t) => {
                            println!(
                                "{}: {file} ran to its end from the card ({:.1} s followed after \
                                 the link came back), never reset",
                                label,
                                t.as_secs_f64()
                            );
                            Ok(())
                        }
                        Err(e) => Err(worded(e)),
                    }
                }
                None => Err(anyhow::anyhow!(
                    "tcp://{tcp} could not be reached again: the job on the card runs on; watch \
                     it at the machine"
                )),
            }
        }
        Err(e) => Err(worded(e)),
    };
    drop(keys);
    if let Some(vg) = virtual_grbl {
        print_virtual(vg);
    }
    done.map(|()| ExitCode::SUCCESS)
}

/// A card run's error, with what the operator asked (an abort) and the option hints.
fn worded(e: MachineError) -> anyhow::Error {
    let text = match &e {
        MachineError::Aborted { halt } => format!(
            "{}: the job on the card was stopped (feed hold, soft reset); {}",
            abort_cause(),
            halt.laser
        ),
        e => e.to_string(),
    };
    anyhow::anyhow!("{text}{}", super::super::port::machine_hint(&e))
}
