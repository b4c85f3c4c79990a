#!/usr/bin/env python3
"""Writes a small ROS 2 bag (MCAP) with Python's `mcap` package, an independent writer for
`kincal import-bag`'s test (cli/tests/import_bag.rs), and prints the rows it must give as
JSON on stdout.

The CDR encoding here is written from the CDR rules alone (struct, explicit alignment),
not from kincal's writer: joint readings little-endian, poses big-endian.

Needs `pip install mcap`. Usage: write_test_bag.py OUT.mcap
"""

import json
import struct
import sys

from mcap.writer import CompressionType, Writer

# Standstills: ARIA joint values [rad] and the measured pose (x, y, z [m]; w, x, y, z).
STANDS = [
    ([0.5, 0.7, -1.0, 3.6, 1.1, -2.8], [0.566, 0.354, 0.235], [0.0, 1.0, 0.0, 0.0]),
    ([-0.2, 1.1, -0.5, 2.8, 0.3, -1.8], [0.41, -0.12, 0.33], [0.5, 0.5, -0.5, 0.5]),
    ([0.8, 0.2, -1.3, 3.2, 1.5, -2.1], [0.25, 0.45, 0.18], [0.8, 0.0, 0.6, 0.0]),
]
NAMES = ["joint1", "joint2", "joint3", "joint4", "joint5", "joint6"]
T0 = 1_690_000_000 * 10**9
MOVE = 500_000_000
STAND = 1_500_000_000
JOINT_PERIOD = 20_000_000  # 50 Hz
POSE_PERIOD = 10_000_000  # 100 Hz


class Cdr:
    """Plain CDR; alignment counts from the end of the 4-byte encapsulation header."""

    def __init__(self, big_endian):
        self.e = ">" if big_endian else "<"
        self.b = bytearray(b"\x00\x00\x00\x00" if big_endian else b"\x00\x01\x00\x00")

    def _align(self, n):
        while (len(self.b) - 4) % n:
            self.b.append(0)

    def u32(self, v):
        self._align(4)
        self.b += struct.pack(self.e + "I", v)

    def i32(self, v):
        self._align(4)
        self.b += struct.pack(self.e + "i", v)

    def f64(self, v):
        self._align(8)
        self.b += struct.pack(self.e + "d", v)

    def string(self, s):
        raw = s.encode() + b"\x00"
        self.u32(len(raw))
        self.b += raw

    def header(self, stamp, frame):
        self.i32(stamp // 10**9)
        self.u32(stamp % 10**9)
        self.string(frame)


def joint_state(stamp, q):
    c = Cdr(big_endian=False)
    c.header(stamp, "")
    c.u32(len(NAMES))
    for n in reversed(NAMES):  # reversed: the reader must map by name
        c.string(n)
    c.u32(len(q))
    for v in reversed(q):
        c.f64(v)
    c.u32(0)
    c.u32(0)
    return bytes(c.b)


def pose_stamped(stamp, xyz, wxyz):
    c = Cdr(big_endian=True)
    c.header(stamp, "world")
    for v in xyz:
        c.f64(v)
    w, x, y, z = wxyz
    for v in (x, y, z, w):
        c.f64(v)
    return bytes(c.b)


def state_at(t):
    """(q, xyz, wxyz, standing) at time t from T0."""
    seg = MOVE + STAND
    k = min(t // seg, len(STANDS) - 1)
    q1, p1, r1 = STANDS[k]
    q0, p0, r0 = STANDS[k - 1] if k > 0 else STANDS[0]
    dt = t - k * seg
    if dt >= MOVE:
        return q1, p1, r1, True
    f = dt / MOVE
    q = [a + f * (b - a) for a, b in zip(q0, q1)]
    p = [a + f * (b - a) for a, b in zip(p0, p1)]
    # The orientation is the previous stand's until the arm arrives (continuous at the
    # start of the move, where the previous standstill's last joint reading is taken).
    return q, p, r0, False


def main():
    out = sys.argv[1]
    end = (MOVE + STAND) * len(STANDS)
    msgs = []
    for t in range(0, end, JOINT_PERIOD):
        q, _, _, _ = state_at(t)
        msgs.append((T0 + t + 1_000_000, "/joint_states", joint_state(T0 + t, q)))
    for t in range(0, end, POSE_PERIOD):
        _, p, r, _ = state_at(t)
        msgs.append((T0 + t + 3_000_000, "/tool_pose", pose_stamped(T0 + t, p, r)))
    msgs.sort(key=lambda m: m[0])
    with open(out, "wb") as f:
        w = Writer(f, compression=CompressionType.ZSTD)
        w.start(profile="ros2", library="kincal write_test_bag.py")
        js = w.register_schema(name="sensor_msgs/msg/JointState", encoding="ros2msg", data=b"")
        ps = w.register_schema(name="geometry_msgs/msg/PoseStamped", encoding="ros2msg", data=b"")
        cj = w.register_channel(topic="/joint_states", message_encoding="cdr", schema_id=js)
        cp = w.register_channel(topic="/tool_pose", message_encoding="cdr", schema_id=ps)
        for i, (log, topic, data) in enumerate(msgs):
            cid = cj if topic == "/joint_states" else cp
            w.add_message(channel_id=cid, log_time=log, publish_time=log, data=data, sequence=i)
        w.finish()
    json.dump([{"q": q, "xyz": p, "wxyz": r} for q, p, r in STANDS], sys.stdout)


if __name__ == "__main__":
    main()
