//! The virtual Grbl over its pty, byte for byte.

use std::io::{Read, Write};
use std::time::{Duration, Instant};

use serialport::{SerialPort, TTYPort};

use super::*;
use crate::protocol::RT_SOFT_RESET;

fn read_until(port: &mut TTYPort, needle: &str, limit: Duration) -> String {
    let mut got = String::new();
    let end = Instant::now() + limit;
    let mut buf = [0u8; 256];
    port.set_timeout(Duration::from_millis(20)).unwrap();
    while Instant::now() < end && !got.contains(needle) {
        if let Ok(n) = port.read(&mut buf) {
            got.push_str(&String::from_utf8_lossy(&buf[..n]));
        }
    }
    got
}

#[test]
fn banner_ok_errors_and_status() {
    let (vg, mut host) = VirtualGrbl::spawn(VirtualConfig::default()).unwrap();
    let s = read_until(&mut host, "for help]", Duration::from_secs(5));
    assert!(s.contains("Grbl 1.1h ['$' for help]"), "{s:?}");
    host.write_all(b"G1X1\n").unwrap();
    let s = read_until(&mut host, "\r\n", Duration::from_secs(5));
    assert_eq!(s, "error:22\r\n");
    host.write_all(b"G5X1\n$I\n").unwrap();
    let s = read_until(&mut host, "ok\r\n", Duration::from_secs(5));
    assert_eq!(
        s,
        "error:20\r\n[VER:1.1h.20190830:]\r\n[OPT:V,15,128]\r\nok\r\n"
    );
    host.write_all(b"G0X3Y4F100\n?").unwrap();
    let s = read_until(&mut host, ">", Duration::from_secs(5));
    assert!(
        s.starts_with("ok\r\n<Idle|MPos:3.000,4.000,0.000|"),
        "{s:?}"
    );
    // Comments and spaces do not count; 79 characters fit, 80 do not.
    let fits = format!("g0 x1. (a comment){}\n", "0".repeat(74));
    let long = format!("G0X1{}\n", "0".repeat(76));
    host.write_all(fits.as_bytes()).unwrap();
    assert_eq!(
        read_until(&mut host, "\r\n", Duration::from_secs(5)),
        "ok\r\n"
    );
    host.write_all(long.as_bytes()).unwrap();
    let s = read_until(&mut host, "\r\n", Duration::from_secs(5));
    assert_eq!(s, "error:11\r\n");
    let r = vg.stop();
    assert_eq!(r.run_lines()[..4], ["G1X1", "G5X1", "$I", "G0X3Y4F100"]);
    assert_eq!(r.run_lines()[4].len(), 79);
    assert_eq!(r.overflow_bytes, 0);
}

#[test]
fn overrides_scale_feed_and_power_and_are_reported() {
    let cfg = VirtualConfig {
        pace: Pace::Timed { speedup: 1.0 },
        ..VirtualConfig::default()
    };
    let (vg, mut host) = VirtualGrbl::spawn(cfg).unwrap();
    read_until(&mut host, "for help]", Duration::from_secs(5));
    host.write_all(b"M3S500\nM8\nG1X100F600\n").unwrap();
    read_until(&mut host, "ok\r\nok\r\nok\r\n", Duration::from_secs(5));
    // +10 % twice, -10 % once on the feed; -10 % on the power; Ov comes at once.
    host.write_all(&[0x91, 0x91, 0x92, 0x9B, b'?']).unwrap();
    let s = read_until(&mut host, ">", Duration::from_secs(5));
    assert!(s.contains("|FS:660,450|"), "{s:?}");
    assert!(s.contains("|Ov:110,100,90|A:SF>"), "{s:?}");
    // Limits: 200 % at most; resets.
    host.write_all(&[0x91; 15]).unwrap();
    host.write_all(&[0x90, 0x99, b'?']).unwrap();
    let s = read_until(&mut host, ">", Duration::from_secs(5));
    assert!(s.contains("|FS:600,500|"), "{s:?}");
    for _ in 0..200 {
        if vg.record().overrides == [100; 3] {
            break;
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    let r = vg.stop();
    assert_eq!(r.overrides, [100; 3]);
    assert!(r.air_on);
    let ov = r
        .events
        .iter()
        .filter(|e| matches!(e, Event::Realtime(b) if *b >= 0x90))
        .count();
    assert_eq!(ov, 4 + 15 + 2);
}

#[test]
fn overrides_stop_at_their_limits() {
    let (vg, mut host) = VirtualGrbl::spawn(VirtualConfig::default()).unwrap();
    read_until(&mut host, "for help]", Duration::from_secs(5));
    host.write_all(&[0x91; 15]).unwrap();
    host.write_all(&[0x9B; 15]).unwrap();
    host.write_all(b"?").unwrap();
    let s = read_until(&mut host, ">", Duration::from_secs(5));
    assert!(s.contains("|Ov:200,100,10"), "{s:?}");
    drop(vg);
}

#[test]
fn overflowing_bytes_are_dropped_and_counted() {
    let cfg = VirtualConfig {
        rx_buffer: 16,
        pace: Pace::Timed { speedup: 1.0 },
        ..VirtualConfig::default()
    };
    let (vg, mut host) = VirtualGrbl::spawn(cfg).unwrap();
    read_until(&mut host, "for help]", Duration::from_secs(5));
    // A long move fills the one-block planner... here 15 blocks; then lines pile up in rx.
    let mut prog = String::from("G1X100F60\n");
    for i in 0..40 {
        prog.push_str(&format!("G1X{}\n", 100 + i));
    }
    host.write_all(prog.as_bytes()).unwrap();
    let end = Instant::now() + Duration::from_secs(5);
    while vg.record().overflow_bytes == 0 && Instant::now() < end {
        std::thread::sleep(Duration::from_millis(10));
    }
    let r = vg.stop();
    assert!(r.overflow_bytes > 0);
    assert!(r.max_rx_used <= 16);
}

#[test]
fn reset_during_motion_locks_until_unlock() {
    let cfg = VirtualConfig {
        pace: Pace::Timed { speedup: 1.0 },
        ..VirtualConfig::default()
    };
    let (vg, mut host) = VirtualGrbl::spawn(cfg).unwrap();
    read_until(&mut host, "for help]", Duration::from_secs(5));
    host.write_all(b"M4S500\nG1X100F60\n").unwrap();
    read_until(&mut host, "ok\r\nok\r\n", Duration::from_secs(5));
    // `ok` means queued: the simulated planner starts the move (and the laser) a moment later.
    let t0 = std::time::Instant::now();
    while !vg.record().laser_on && t0.elapsed() < Duration::from_secs(5) {
        std::thread::sleep(Duration::from_millis(5));
    }
    assert!(vg.record().laser_on);
    host.write_all(&[RT_SOFT_RESET]).unwrap();
    let s = read_until(&mut host, "to unlock]", Duration::from_secs(5));
    assert!(s.contains("ALARM:3") && s.contains("Grbl 1.1h"), "{s:?}");
    // The record is a snapshot the simulator publishes after its replies: wait for it.
    let t0 = std::time::Instant::now();
    while vg.record().laser_on && t0.elapsed() < Duration::from_secs(5) {
        std::thread::sleep(Duration::from_millis(5));
    }
    assert!(!vg.record().laser_on);
    host.write_all(b"G0X1\n").unwrap();
    assert_eq!(
        read_until(&mut host, "\r\n", Duration::from_secs(5)),
        "error:9\r\n"
    );
    host.write_all(b"$X\nG0X1\n").unwrap();
    let s = read_until(&mut host, "ok\r\nok\r\n", Duration::from_secs(5));
    assert!(
        s.ends_with("[MSG:Caution: Unlocked]\r\nok\r\nok\r\n"),
        "{s:?}"
    );
    drop(vg);
}
