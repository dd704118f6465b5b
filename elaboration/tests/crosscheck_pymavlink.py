#!/usr/bin/env python3
"""Independent check of `petrel events` against pymavlink.

For every tlog in SHARED/telemetry, pymavlink reads the autopilot's
HEARTBEATs (the first sender with an autopilot other than INVALID that is
not a ground station) and lists the arm, disarm and custom_mode changes
after the first heartbeat; `petrel events FILE --json` must report the same
changes (armed, disarmed, mode_changed with the same custom_mode) at the
same tlog timestamps, within 0.1 s.

usage: crosscheck_pymavlink.py PETREL_BINARY SHARED_DIR
"""

import json
import os
import subprocess
import sys

os.environ.setdefault("MAVLINK20", "1")
from pymavlink import mavutil  # noqa: E402

TOLERANCE_S = 0.1
MAV_TYPE_GCS = 6
MAV_AUTOPILOT_INVALID = 8
ARMED = 128


def reference(path):
    """(time_s, what) for each arm/disarm/mode change, from pymavlink."""
    conn = mavutil.mavlink_connection(path, dialect="ardupilotmega")
    autopilot = None
    last = None
    changes = []
    while True:
        msg = conn.recv_match(type="HEARTBEAT")
        if msg is None:
            break
        src = (msg.get_srcSystem(), msg.get_srcComponent())
        if autopilot is None:
            if msg.type == MAV_TYPE_GCS or msg.autopilot == MAV_AUTOPILOT_INVALID:
                continue
            autopilot = src
        if src != autopilot:
            continue
        armed = bool(msg.base_mode & ARMED)
        t = msg._timestamp
        if last is not None:
            if armed != last[0]:
                changes.append((t, "armed" if armed else "disarmed"))
            if msg.custom_mode != last[1]:
                changes.append((t, f"mode {msg.custom_mode}"))
        last = (armed, msg.custom_mode)
    return changes


def petrel(binary, path):
    out = subprocess.run(
        [binary, "events", path, "--json"], capture_output=True, text=True, check=True
    ).stdout
    changes = []
    for line in out.splitlines():
        e = json.loads(line)
        t = e["time_us"] / 1e6
        if e["event"] in ("armed", "disarmed"):
            changes.append((t, e["event"]))
        elif e["event"] == "mode_changed":
            changes.append((t, f"mode {e['params']['custom_mode']}"))
    return changes


def same(ref, got):
    key = lambda c: (round(c[0], 3), c[1])  # noqa: E731
    ref, got = sorted(ref, key=key), sorted(got, key=key)
    if len(ref) != len(got):
        return False
    return all(r[1] == g[1] and abs(r[0] - g[0]) <= TOLERANCE_S for r, g in zip(ref, got))


def main():
    if len(sys.argv) != 3:
        print(__doc__, file=sys.stderr)
        return 2
    binary, shared = sys.argv[1], sys.argv[2]
    folder = os.path.join(shared, "telemetry")
    logs = sorted(f for f in os.listdir(folder) if f.endswith(".tlog"))
    if not logs:
        print(f"no tlog in {folder}", file=sys.stderr)
        return 1
    failed = 0
    compared = 0
    for name in logs:
        path = os.path.join(folder, name)
        ref, got = reference(path), petrel(binary, path)
        ok = same(ref, got)
        failed += not ok
        compared += len(ref)
        print(f"{'ok  ' if ok else 'FAIL'} {name}: {len(ref)} arm/disarm/mode changes (pymavlink), {len(got)} (petrel)")
        if not ok:
            for c in ref:
                print(f"    pymavlink {c[0]:.3f} {c[1]}")
            for c in got:
                print(f"    petrel    {c[0]:.3f} {c[1]}")
    if compared == 0:
        # Both sides empty everywhere would prove nothing.
        print("FAIL: pymavlink found no arm, disarm or mode change in any log", file=sys.stderr)
        return 1
    print(f"{compared} changes compared in {len(logs)} logs")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
