//! `stencil jog` against the virtual Grbl: each key's effect on the machine (position after jogs,
//! work zero after `0`, the alarm cleared by `u`, homing, the jog cancel), Grbl's refusals worded,
//! and every way out ending with the jog cancelled and the laser and air off.

use std::collections::VecDeque;
use std::io::Write;
use std::process::Command;
use std::time::Duration;

use stencil_grbl::{
    jog_session, parse_keys, Console, Event, FaultKind, JogKey, Jogger, Observer, Pace, Record,
    Script, StreamConfig, VirtualConfig, VirtualGrbl,
};

use crate::common::faulty;

#[derive(Default)]
struct Log(Vec<String>);
impl Observer for Log {
    fn message(&mut self, text: &str) {
        self.0.push(text.to_string());
    }
}

fn cfg() -> StreamConfig {
    StreamConfig {
        boot_wait: Duration::from_millis(300),
        timeout: Duration::from_millis(1500),
        ..StreamConfig::default()
    }
}

/// Run `keys` against a virtual Grbl set up as `vcfg` (after `before`, raw bytes sent before
/// connecting); the final record, the messages, the status lines shown, and the outcome.
fn jog(
    vcfg: VirtualConfig,
    before: &[&[u8]],
    keys: &str,
    step: f64,
) -> (Record, Vec<String>, Vec<String>, Result<String, String>) {
    let (vg, mut host) = VirtualGrbl::spawn(vcfg).unwrap();
    for b in before {
        host.write_all(b).unwrap();
        std::thread::sleep(Duration::from_millis(150));
    }
    let mut log = Log::default();
    let mut shown = Vec::new();
    let c = cfg();
    let result = {
        let mut console = Console::connect(&mut host, &c, None, &mut log).unwrap();
        let mut j = Jogger::new(&mut console, step, 1000.0);
        let mut script = Script(VecDeque::from(parse_keys(keys).unwrap()));
        jog_session(&mut j, &mut script, &mut |l: &str| {
            shown.push(l.to_string())
        })
        .map_err(|e| e.to_string())
    };
    (vg.stop(), log.0, shown, result)
}

fn jog_lines(r: &Record) -> Vec<&str> {
    r.run_lines()
        .into_iter()
        .filter(|l| l.starts_with("$J="))
        .collect()
}

/// Left with the laser and the air off: M9 then M5 were the last lines, and the laser is off.
fn left_dark(r: &Record) {
    let lines = r.run_lines();
    assert_eq!(lines[lines.len() - 2..], ["M9", "M5"], "{lines:?}");
    assert!(!r.laser_on);
}

#[test]
fn arrows_and_page_keys_jog_by_the_step() {
    let (r, _, shown, res) = jog(
        VirtualConfig::default(),
        &[],
        "right,right,up,pgup,left,down,down,pgdn,pgdn",
        1.0,
    );
    res.unwrap();
    assert_eq!(r.position, [1.0, -1.0, -1.0]);
    assert_eq!(
        jog_lines(&r),
        [
            "$J=G91G21X1F1000",
            "$J=G91G21X1F1000",
            "$J=G91G21Y1F1000",
            "$J=G91G21Z1F1000",
            "$J=G91G21X-1F1000",
            "$J=G91G21Y-1F1000",
            "$J=G91G21Y-1F1000",
            "$J=G91G21Z-1F1000",
            "$J=G91G21Z-1F1000",
        ]
    );
    // Jogs never fire the laser, and the status line follows the head.
    assert!(r.moves.iter().all(|m| !m.beam));
    assert!(
        shown
            .last()
            .unwrap()
            .contains("X    1.000 Y   -1.000 Z  -1.000"),
        "{shown:?}"
    );
    left_dark(&r);
}

#[test]
fn step_keys_change_the_step() {
    let (r, _, shown, _) = jog(
        VirtualConfig::default(),
        &[],
        "1,right,3,right,-,up,+,+,up,2,down",
        2.5,
    );
    // 0.1 + 10 in X; 2.5 then 10 in Y (2.5 lies between 1 and 10); then -1.
    assert_eq!(r.position, [10.1, 11.5, 0.0]);
    assert!(shown.iter().any(|l| l.contains("step 0.1 mm")), "{shown:?}");
}

#[test]
fn zero_sets_work_zero_where_the_head_is() {
    let (r, msgs, shown, res) = jog(
        VirtualConfig::default(),
        &[],
        "right,right,up,0,right",
        10.0,
    );
    res.unwrap();
    assert!(r.run_lines().contains(&"G10L20P1X0Y0"));
    // Machine position kept; the work offset is where zero was set, so work X is the last jog.
    assert_eq!(r.position, [30.0, 10.0, 0.0]);
    assert_eq!(r.wco, [20.0, 10.0, 0.0]);
    assert!(
        shown.last().unwrap().contains("X   10.000 Y    0.000"),
        "{shown:?}"
    );
    assert!(msgs.iter().any(|m| m.contains("work zero set")), "{msgs:?}");
}

#[test]
fn unlock_clears_the_alarm_that_refused_the_jog() {
    let vcfg = VirtualConfig {
        pace: Pace::Timed { speedup: 1.0 },
        ..VirtualConfig::default()
    };
    // A reset while moving leaves Grbl locked (ALARM:3).
    let (r, msgs, _, res) = jog(vcfg, &[b"G1X100F60\n", &[0x18]], "right,u,right,wait", 1.0);
    res.unwrap();
    let pos_x = r.position[0];
    let refused = msgs
        .iter()
        .find(|m| m.contains("refused `$J="))
        .expect("jog refused in alarm");
    assert!(
        refused.contains("locked in alarm") && refused.contains("press u"),
        "{refused}"
    );
    assert!(msgs.iter().any(|m| m.contains("unlocked ($X)")), "{msgs:?}");
    // Only the jog after the unlock moved the head: one step from where the reset stopped it.
    let jogs: Vec<_> = r.moves.iter().filter(|m| m.idx > 1).collect();
    assert_eq!(jogs.len(), 1, "{jogs:?}");
    assert!(
        (pos_x - jogs[0].from[0] - 1.0).abs() < 1e-6,
        "{pos_x} {:?}",
        jogs[0]
    );
    assert_eq!(r.state, "Idle");
    left_dark(&r);
}

#[test]
fn home_homes_or_says_homing_is_disabled() {
    let (r, msgs, _, res) = jog(VirtualConfig::default(), &[], "right,up,0,right,h", 5.0);
    res.unwrap();
    assert_eq!(r.position, [0.0, 0.0, 0.0], "homed to machine zero");
    assert!(msgs.iter().any(|m| m == "homed"), "{msgs:?}");
    let vcfg = VirtualConfig {
        homing: false,
        ..VirtualConfig::default()
    };
    let (r, msgs, _, res) = jog(vcfg, &[], "right,h", 5.0);
    res.unwrap();
    assert_eq!(r.position, [5.0, 0.0, 0.0], "nothing moved");
    let m = msgs
        .iter()
        .find(|m| m.contains("error:5"))
        .expect("error:5 worded");
    assert!(
        m.contains("homing is not enabled")
            && m.contains("error:5")
            && m.contains("$22=1")
            && m.contains("Press u"),
        "{m}"
    );
}

#[test]
fn a_released_key_or_quit_cancels_the_running_jog() {
    let vcfg = VirtualConfig {
        pace: Pace::Timed { speedup: 1.0 },
        ..VirtualConfig::default()
    };
    // 10 mm at 1000 mm/min takes 0.6 s: cancelled long before.
    let (r, _, _, res) = jog(vcfg.clone(), &[], "right,release", 10.0);
    res.unwrap();
    assert!(r.events.contains(&Event::Realtime(0x85)));
    assert!(
        r.position[0] > 0.0 && r.position[0] < 10.0,
        "{:?}",
        r.position
    );
    assert_eq!(r.state, "Idle");
    left_dark(&r);
    let (r, _, _, res) = jog(vcfg, &[], "right,q", 10.0);
    res.unwrap();
    assert!(r.events.contains(&Event::Realtime(0x85)));
    assert!(r.position[0] < 10.0, "{:?}", r.position);
    left_dark(&r);
}

#[test]
fn a_lost_port_or_a_silent_machine_ends_the_session_saying_so() {
    // The first G-code line (the work zero) pulls the cable.
    let vcfg = faulty(FaultKind::ClosePort, 1);
    let (r, _, _, res) = jog(vcfg, &[], "right,0,right", 1.0);
    let e = res.unwrap_err();
    assert!(e.contains("make sure the laser and the air are off"), "{e}");
    assert!(r.closed && !r.laser_on);
    let vcfg = faulty(FaultKind::Silence, 1);
    let (r, _, _, res) = jog(vcfg, &[], "right,0,right", 1.0);
    let e = res.unwrap_err();
    assert!(e.contains("laser"), "{e}");
    assert!(
        r.events.contains(&Event::SoftReset),
        "stopped with a soft reset"
    );
    assert!(!r.laser_on);
}

#[test]
fn cli_jog_with_keys_and_from_a_pipe() {
    let out = Command::new(env!("CARGO_BIN_EXE_stencil"))
        .args([
            "jog",
            "--dry-run",
            "--keys",
            "right,right,up,3,right,wait,0,left,q",
        ])
        .output()
        .unwrap();
    let so = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(so.contains("X  -10.000 Y    0.000"), "{so}");
    assert!(so.contains("laser off (M5), air off (M9)"), "{so}");
    assert!(
        so.contains("machine at X 2.000 Y 1.000") && so.contains("work offset X 12.000 Y 1.000"),
        "{so}"
    );
    let mut child = Command::new(env!("CARGO_BIN_EXE_stencil"))
        .args(["jog", "--dry-run", "--step", "0.5"])
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    child
        .stdin
        .take()
        .unwrap()
        .write_all(b"up up\npgup\nnot-a-key\n")
        .unwrap();
    let out = child.wait_with_output().unwrap();
    let (so, se) = (
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr),
    );
    assert!(out.status.success(), "{se}");
    assert!(so.contains("machine at X 0.000 Y 1.000 Z 0.500"), "{so}");
    assert!(se.contains("'not-a-key' is not a key"), "{se}");
    let out = Command::new(env!("CARGO_BIN_EXE_stencil"))
        .args(["jog", "--dry-run", "--keys", "left,fly"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("'fly' is not a key"));
    let _ = JogKey::Wait;
}
