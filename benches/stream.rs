//! Link throughput: character counting vs send-response, streaming to the virtual Grbl with its
//! link paced at 115200 baud (10 bits per byte) and a planner that never makes the host wait.
//! Prints both figures and the link utilisation (program bytes × 10 / baud ÷ elapsed time).
//! Run with `cargo bench --bench stream`.

use std::time::Duration;

use stencil_grbl::{
    send, FlowControl, Pace, Program, Quiet, StreamConfig, VirtualConfig, VirtualGrbl,
};

#[path = "../tests/common/job.rs"]
mod job;

const BAUD: u32 = 115_200;

fn run(job: &Program, flow: FlowControl) -> (f64, u64, usize) {
    let vcfg = VirtualConfig {
        pace: Pace::Instant,
        baud: Some(BAUD),
        ..VirtualConfig::default()
    };
    let (vg, mut port) = VirtualGrbl::spawn(vcfg).expect("pty pair");
    let cfg = StreamConfig {
        flow,
        boot_wait: Duration::from_millis(500),
        ..StreamConfig::default()
    };
    let sum = send(&mut port, job, &cfg, None, &mut Quiet).expect("stream");
    let r = vg.stop();
    assert_eq!(r.overflow_bytes, 0);
    (sum.elapsed.as_secs_f64(), sum.bytes, sum.max_in_flight)
}

fn main() {
    let text = job::job_text_scaled(8);
    let job = Program::parse("bench.gcode", &text).expect("job");
    let wire = |bytes: u64| bytes as f64 * 10.0 / BAUD as f64;
    println!(
        "stream bench: {} lines, {} bytes, virtual Grbl at {BAUD} baud, instant planner",
        job.lines.len(),
        job.lines.iter().map(|l| l.text.len() + 1).sum::<usize>()
    );
    for (name, flow, runs) in [
        ("character counting", FlowControl::CharacterCounting, 3),
        ("send-response", FlowControl::SendResponse, 2),
    ] {
        let mut best: Option<(f64, u64, usize)> = None;
        for _ in 0..runs {
            let r = run(&job, flow);
            if best.is_none_or(|b| r.0 < b.0) {
                best = Some(r);
            }
        }
        let Some((secs, bytes, in_flight)) = best else {
            continue;
        };
        println!(
            "{name:>20}: {secs:.3} s (best of {runs}), {:.0} lines/s, {:.0} bytes/s, link {:.1} % busy, at most {in_flight} bytes in flight",
            job.lines.len() as f64 / secs,
            bytes as f64 / secs,
            100.0 * wire(bytes) / secs
        );
    }
}
