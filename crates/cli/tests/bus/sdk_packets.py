"""The vendors' own SDKs build the same packets as chessarm's bus module.

Reads a JSON list of cases on stdin — {"protocol": "dynamixel" | "feetech", "kind": "ping" |
"read" | "write" | "sync_write", "id", "address", "length", "data", "goals": [[id, [bytes]]]} —
has ROBOTIS's dynamixel_sdk (Protocol 2.0) or Feetech's scservo_sdk (little-endian STS) build
each with a port that only records what it is given, and prints, per case, the bytes the SDK
sent and the packet as the protocol's byte stuffing makes it ({"sent", "stuffed"}). The two
differ where a Protocol 2.0 packet needs stuffing: dynamixel_sdk 4.1.0's txPacket calls
addStuffing but drops the stuffed list it returns when the packet grows, so it sends the packet
unstuffed; "stuffed" is the SDK's own addStuffing and updateCRC applied to what it sent. The
Rust test (crates/cli/tests/cli_bus.rs) compares them with chessarm's.
"""
import json
import sys

import dynamixel_sdk
import scservo_sdk


class RecordingPort:
    """Enough of the SDKs' PortHandler for their transmit functions: the bytes written."""

    def __init__(self):
        self.is_using = False
        self.written = []

    def clearPort(self):
        pass

    def setPacketTimeout(self, _length):
        pass

    def writePort(self, packet):
        self.written.append(list(packet))
        return len(packet)


def build(case):
    port = RecordingPort()
    if case["protocol"] == "dynamixel":
        sdk = dynamixel_sdk.PacketHandler(2.0)
    else:
        sdk = scservo_sdk.PacketHandler(0)  # 0: little-endian words, the STS series
    kind = case["kind"]
    if kind == "ping":
        # The transmit half of ping: an instruction packet with no parameters.
        if case["protocol"] == "dynamixel":
            packet = [0] * 10
            packet[4], packet[5], packet[6], packet[7] = case["id"], 3, 0, dynamixel_sdk.INST_PING
        else:
            packet = [0] * 6
            packet[2], packet[3], packet[4] = case["id"], 2, scservo_sdk.INST_PING
        sdk.txPacket(port, packet)
    elif kind == "read":
        sdk.readTx(port, case["id"], case["address"], case["length"])
    elif kind == "write":
        sdk.writeTxOnly(port, case["id"], case["address"], len(case["data"]), case["data"])
    elif kind == "sync_write":
        params = [b for gid, data in case["goals"] for b in [gid] + data]
        length = len(case["goals"][0][1])
        sdk.syncWriteTxOnly(port, case["address"], length, params, len(params))
    else:
        raise ValueError(kind)
    assert len(port.written) == 1, port.written
    sent = port.written[0]
    stuffed = list(sent)
    if case["protocol"] == "dynamixel":
        stuffed = sdk.addStuffing(list(sent))
        total = dynamixel_sdk.DXL_MAKEWORD(stuffed[5], stuffed[6]) + 7
        crc = sdk.updateCRC(0, stuffed, total - 2)
        stuffed = stuffed[: total - 2] + [dynamixel_sdk.DXL_LOBYTE(crc), dynamixel_sdk.DXL_HIBYTE(crc)]
    return {"sent": sent, "stuffed": stuffed}


print(json.dumps([build(case) for case in json.load(sys.stdin)]))
