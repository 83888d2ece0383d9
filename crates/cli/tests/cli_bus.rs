//! The servo buses' packets (`chessarm::bus`) against the vendors' own SDKs from PyPI:
//! ROBOTIS's `dynamixel-sdk` (Protocol 2.0) and Feetech's `feetech-servo-sdk` (`scservo_sdk`)
//! build the same bytes for pings, reads, writes and synchronised writes, byte stuffing
//! included (`tests/bus/sdk_packets.py`; the Python SDK's own transmit leaves a packet that
//! needs stuffing unstuffed, so those are compared with its `addStuffing`).

#![allow(clippy::unwrap_used)] // tests

mod common;

use chessarm::bus::{dynamixel, feetech};
use serde_json::{Value, json};

/// Seeded cases (a small LCG: reproducible, no crate), with data that holds the header's
/// `FF FF FD` pattern to exercise Protocol 2.0's stuffing.
fn cases() -> Vec<(Value, Vec<u8>)> {
    let mut state = 12345u64;
    let mut next = move |n: u64| {
        state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (state >> 33) % n
    };
    let mut out = Vec::new();
    for k in 0..60 {
        let id = 1 + next(20) as u8;
        let mut data: Vec<u8> = (0..1 + next(6)).map(|_| next(256) as u8).collect();
        if k % 5 == 0 {
            data = vec![0xFF, 0xFF, 0xFD, next(256) as u8];
        }
        let goals: Vec<(u8, Vec<u8>)> = (1..=1 + next(5) as u8)
            .map(|g| {
                (g, if k % 7 == 0 { vec![0xFF, 0xFF, 0xFD, 0x00] } else { (0..4).map(|_| next(256) as u8).collect() })
            })
            .collect();
        let goal_refs: Vec<(u8, &[u8])> = goals.iter().map(|(g, d)| (*g, d.as_slice())).collect();
        let goals_json: Vec<Value> = goals.iter().map(|(g, d)| json!([g, d])).collect();
        let address = next(140) as u16;
        let length = 1 + next(8) as u16;
        for protocol in ["dynamixel", "feetech"] {
            let dxl = protocol == "dynamixel";
            let ours = match k % 4 {
                0 => {
                    if dxl {
                        dynamixel::instruction(id, dynamixel::PING, &[])
                    } else {
                        feetech::instruction(id, feetech::PING, &[])
                    }
                }
                1 => {
                    if dxl {
                        dynamixel::read(id, address, length)
                    } else {
                        feetech::read(id, address as u8, length as u8)
                    }
                }
                2 => {
                    if dxl {
                        dynamixel::write(id, address, &data)
                    } else {
                        feetech::write(id, address as u8, &data)
                    }
                }
                _ => {
                    if dxl {
                        dynamixel::sync_write(address, &goal_refs)
                    } else {
                        feetech::sync_write(address as u8, &goal_refs)
                    }
                }
            };
            let kind = ["ping", "read", "write", "sync_write"][k % 4];
            out.push((
                json!({"protocol": protocol, "kind": kind, "id": id, "address": address, "length": length, "data": data, "goals": goals_json}),
                ours,
            ));
        }
    }
    out
}

#[test]
#[cfg_attr(
    not(tool_python),
    ignore = "needs CHESSARM_PYTHON, a Python with dynamixel-sdk and feetech-servo-sdk; see docs/testing.md"
)]
fn the_vendors_sdks_build_the_same_packets() {
    let python = common::python_with("dynamixel_sdk, scservo_sdk")
        .expect("CHESSARM_PYTHON (or python3) with dynamixel-sdk and feetech-servo-sdk installed");
    let cases = cases();
    let input: Vec<&Value> = cases.iter().map(|(c, _)| c).collect();
    let script = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/bus/sdk_packets.py");
    let mut child = std::process::Command::new(&python)
        .arg(&script)
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    std::io::Write::write_all(&mut child.stdin.take().unwrap(), serde_json::to_string(&input).unwrap().as_bytes())
        .unwrap();
    let output = child.wait_with_output().unwrap();
    assert!(output.status.success(), "{}", String::from_utf8_lossy(&output.stderr));
    let theirs: Vec<Value> = serde_json::from_slice(&output.stdout).unwrap();
    assert_eq!(theirs.len(), cases.len());
    let mut stuffed = 0;
    for ((case, ours), theirs) in cases.iter().zip(&theirs) {
        let bytes = |key: &str| -> Vec<u8> { serde_json::from_value(theirs[key].clone()).unwrap() };
        assert_eq!(ours, &bytes("stuffed"), "{case}");
        if bytes("sent") != bytes("stuffed") {
            stuffed += 1;
            // Only a stuffing tells them apart: the SDK sent the same packet unstuffed.
            assert!(ours.windows(4).any(|w| w == [0xFF, 0xFF, 0xFD, 0xFD]), "{case}");
        }
    }
    // The stuffing was exercised, not only plain packets.
    assert!(stuffed >= 5, "{stuffed}");
}
