"""A vendor's own SDK talks to chessarm's simulated servo bus (`chessarm bus-sim`).

Usage: sdk_talk.py dynamixel|feetech DEVICE ID1,ID2,ID3,ID4

With ROBOTIS's dynamixel_sdk (Protocol 2.0) or Feetech's scservo_sdk (STS, little-endian) over
pyserial, as a maker's own script would: pings every servo (its model number), reads each
present position alone and all four with the SDK's GroupSyncRead, turns the torque on, moves
the first joint (the base, which gravity does not load) 200 ticks with the SDK's GroupSyncWrite,
follows it with GroupSyncRead every 20 ms for 1.5 s, turns the torque off. Prints one JSON
object; the Rust test (crates/cli/tests/cli_bus.rs) checks it against the servo model.
"""
import json
import sys
import time

protocol, device, ids = sys.argv[1], sys.argv[2], [int(i) for i in sys.argv[3].split(",")]

if protocol == "dynamixel":
    import dynamixel_sdk as sdk

    port = sdk.PortHandler(device)
    handler = sdk.PacketHandler(2.0)
    TORQUE, GOAL, PRESENT, WIDTH = 64, 116, 132, 4
    OK = sdk.COMM_SUCCESS
else:
    import scservo_sdk as sdk

    port = sdk.PortHandler(device)
    handler = sdk.PacketHandler(0)
    TORQUE, GOAL, PRESENT, WIDTH = 40, 42, 56, 2
    OK = sdk.COMM_SUCCESS

assert port.openPort(), "cannot open " + device
assert port.setBaudRate(1000000), "cannot set the baud rate"


def check(result, error, what):
    if result != OK:
        raise SystemExit(f"{what}: {handler.getTxRxResult(result)}")
    if error != 0:
        raise SystemExit(f"{what}: servo error {error}")


def read_position(servo):
    if WIDTH == 4:
        value, result, error = handler.read4ByteTxRx(port, servo, PRESENT)
        if value >= 2**31:
            value -= 2**32
    else:
        value, result, error = handler.read2ByteTxRx(port, servo, PRESENT)
    check(result, error, f"read present position of {servo}")
    return value


def encode(value):
    value &= (1 << (8 * WIDTH)) - 1
    return [(value >> (8 * k)) & 0xFF for k in range(WIDTH)]


models = {}
for servo in ids:
    model, result, error = handler.ping(port, servo)
    check(result, error, f"ping {servo}")
    models[servo] = model

single = {servo: read_position(servo) for servo in ids}

reader = sdk.GroupSyncRead(port, handler, PRESENT, WIDTH)
for servo in ids:
    assert reader.addParam(servo)


def read_all():
    result = reader.txRxPacket()
    if result != OK:
        raise SystemExit(f"sync read: {handler.getTxRxResult(result)}")
    out = {}
    for servo in ids:
        value = reader.getData(servo, PRESENT, WIDTH)
        if WIDTH == 4 and value >= 2**31:
            value -= 2**32
        out[servo] = value
    return out


synced = read_all()
for servo in ids:
    result, error = handler.write1ByteTxRx(port, servo, TORQUE, 1)
    check(result, error, f"torque on {servo}")

start = read_all()
goal = start[ids[0]] + 200
writer = sdk.GroupSyncWrite(port, handler, GOAL, WIDTH)
for servo in ids:
    assert writer.addParam(servo, encode(goal if servo == ids[0] else start[servo]))
result = writer.txPacket()
assert result == OK, handler.getTxRxResult(result)
began = time.monotonic()
followed = []
while time.monotonic() - began < 1.5:
    time.sleep(0.02)
    followed.append([time.monotonic() - began, read_all()[ids[0]]])

for servo in ids:
    result, error = handler.write1ByteTxRx(port, servo, TORQUE, 0)
    check(result, error, f"torque off {servo}")
port.closePort()
print(json.dumps({
    "models": models,
    "single": single,
    "synced": synced,
    "start": start,
    "goal": goal,
    "followed": followed,
}))
