//! `chessarm bus-sim` as a driver meets it: faults refused for servos not on the bus, and stray
//! bytes on the line that no longer hold the next packet.

#![allow(clippy::unwrap_used)] // tests

mod common;

use chessarm::app::bus::Protocol;
use chessarm::app::bus::port::SerialLine;
use std::time::Duration;

/// A fault for a servo the bus does not have would never fire: refused before the bus starts
/// (no device printed, no log created), naming the flag, the value and the servos there are.
#[test]
fn a_fault_for_a_servo_not_on_the_bus_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("bus.jsonl");
    for flag in ["--lose-reply", "--overload"] {
        let output =
            common::chessarm(&["--actuator", "sts3215", "bus-sim", "--log", log.to_str().unwrap(), flag, "99@1"]);
        common::assert_one_line_error(&output, &[&format!("{flag} 99@1"), "servo 99", "1, 2, 3, 4"]);
        assert!(output.stdout.is_empty(), "{}", String::from_utf8_lossy(&output.stdout));
        assert!(!log.exists());
    }
}

/// Four stray bytes (`FF FF 01 FF`: a header, ID 1 and a length of 255) once made bus-sim
/// wait for 255 more and take the next packets as theirs. After a silence they are dropped
/// and a ping 200 ms later is answered (within 2 s: the simulator is a process a busy 2-core
/// machine may leave unscheduled for a while; unanswered, it never would be).
#[test]
fn stray_bytes_do_not_hold_the_next_packet() {
    let dir = tempfile::tempdir().unwrap();
    let mut sim = common::BusSim::start(dir.path(), &["--actuator", "sts3215"], &[]);
    let mut line = SerialLine::open(std::path::Path::new(&sim.device), 1_000_000).unwrap();
    line.send(&[0xFF, 0xFF, 0x01, 0xFF]).unwrap();
    std::thread::sleep(Duration::from_millis(200));
    line.send(&Protocol::Feetech.ping(1)).unwrap();
    let mut reply = Vec::new();
    let answered =
        line.receive_until(&mut reply, Duration::from_secs(2), |b| Protocol::Feetech.parse_status(b).is_ok()).unwrap();
    sim.child.kill().unwrap();
    let mut stderr = String::new();
    std::io::Read::read_to_string(&mut sim.child.stderr.take().unwrap(), &mut stderr).unwrap();
    assert!(answered, "no reply: {reply:02X?}; {stderr}");
    assert_eq!(Protocol::Feetech.parse_status(&reply).unwrap().id, 1);
    assert!(stderr.contains("dropped 4 bytes of a packet cut short"), "{stderr}");
}
