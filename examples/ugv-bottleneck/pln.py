#!/usr/bin/env python3
"""PLN, the planner of examples/ugv-bottleneck (Python standard library only).

It knows the labyrinth (waypoints in metres north and east of a home) and
each robot's route through it, and gives the moves one at a time over
Petrel's program protocol (docs/programs.md: JSON lines over a socket):

  next    {} -> {move, name, lat, lon}   the robot's next elementary move:
          move "leg" (forward, turn, follow a wall), "gate" (to the
          bottleneck's gate), "end" (the route is done; lat, lon: where it is)
  cross   {} -> {name, lat, lon}         through the bottleneck: its far gate
  detour  {} -> {legs}                   the robot waiting at its gate takes
          the other way round (the outer ring); its next moves are those
  replan  {blocked} -> {action}          a robot is blocked in the bottleneck:
          "detour" when the other one has not crossed yet (it will be sent
          round), "hold" otherwise (nothing to change)

Every call carries the robot it is for ("vehicle": "R1"); a team net's call
(replan) names it in its arguments. The gateway starts it (project.toml:
run = ["python3", "pln.py"]) with PETREL_PROGRAMS (tcp:HOST:PORT or
unix:PATH) and, when set, PETREL_PROGRAMS_TOKEN. By hand:

  python3 pln.py --programs tcp:127.0.0.1:5790 [--home LAT,LON]
"""

import argparse
import json
import math
import os
import socket
import sys

# ArduPilot's LOCATION_SCALING_FACTOR (metres per 1e-7 degree of latitude).
METRES_PER_DEGREE = 0.011131884502145034 * 1e7

# ArduPilot SITL's default home (CMAC), where petrel-sim parks its vehicles.
HOME = (-35.363261, 149.165230)

# The labyrinth, metres (north, east) from home. The bottleneck is the
# corridor between the south gate and the north gate, along east = 0; R1
# starts south-west and goes north, R2 starts north-east and goes south.
SOUTH_GATE = (15.0, 0.0)
NORTH_GATE = (45.0, 0.0)
START = {"R1": (0.0, -20.0), "R2": (60.0, 20.0)}

# Each robot's route: (move, name, point). `gate` ends at the gate where the
# bottleneck begins; the crossing (`cross`) follows it.
ROUTES = {
    "R1": [
        ("leg", "forward", (15.0, -20.0)),
        ("gate", "turn right, follow the right wall to the south gate", SOUTH_GATE),
        ("leg", "forward", (55.0, 0.0)),
        ("leg", "turn left, follow the left wall", (55.0, -20.0)),
    ],
    "R2": [
        ("leg", "forward", (55.0, 20.0)),
        ("gate", "turn right, follow the right wall to the north gate", NORTH_GATE),
        ("leg", "forward", (5.0, 0.0)),
        ("leg", "turn left, follow the left wall", (5.0, 20.0)),
    ],
}

# Through the bottleneck: to the far gate.
CROSSINGS = {"R1": ("enter bottleneck, exit at the north gate", NORTH_GATE),
             "R2": ("enter bottleneck, exit at the south gate", SOUTH_GATE)}

# The other way round, from the gate, along the labyrinth's outer ring.
DETOURS = {
    "R1": [
        ("leg", "turn left, follow the outer wall", (15.0, -30.0)),
        ("leg", "forward along the west ring", (55.0, -30.0)),
        ("leg", "turn right", (55.0, -20.0)),
    ],
    "R2": [
        ("leg", "turn left, follow the outer wall", (45.0, 30.0)),
        ("leg", "forward along the east ring", (5.0, 30.0)),
        ("leg", "turn right", (5.0, 20.0)),
    ],
}

OTHER = {"R1": "R2", "R2": "R1"}


class Planner:
    """Each robot's progress along its route; pure (no I/O)."""

    def __init__(self, home):
        self.home = home
        self.routes = {v: list(r) for v, r in ROUTES.items()}
        self.step = {v: 0 for v in ROUTES}
        # Crossed: asked for its next move after a crossing (CORRIDOR asks
        # `cross` again every 5 s while it waits at its gate: asking is
        # not crossing).
        self.crossing = {v: False for v in ROUTES}
        self.crossed = {v: False for v in ROUTES}
        self.detoured = {v: False for v in ROUTES}
        self.last = dict(START)

    def latlon(self, point):
        north, east = point
        lat = self.home[0] + north / METRES_PER_DEGREE
        lon = self.home[1] + east / (METRES_PER_DEGREE * math.cos(math.radians(self.home[0])))
        return round(lat, 7), round(lon, 7)

    def vehicle(self, v):
        if v not in self.routes:
            raise ValueError(f"no route for vehicle {v!r} (the labyrinth knows R1 and R2)")
        return v

    def next(self, v):
        v = self.vehicle(v)
        if self.crossing[v]:
            self.crossing[v] = False
            self.crossed[v] = True
            self.last[v] = CROSSINGS[v][1]
        route = self.routes[v]
        i = self.step[v]
        if i >= len(route):
            lat, lon = self.latlon(self.last[v])
            return {"move": "end", "name": "route done", "lat": lat, "lon": lon}
        move, name, point = route[i]
        self.step[v] = i + 1
        self.last[v] = point
        lat, lon = self.latlon(point)
        return {"move": move, "name": name, "lat": lat, "lon": lon}

    def cross(self, v):
        v = self.vehicle(v)
        name, point = CROSSINGS[v]
        self.crossing[v] = True
        lat, lon = self.latlon(point)
        return {"name": name, "lat": lat, "lon": lon}

    def detour(self, v):
        v = self.vehicle(v)
        legs = DETOURS[v]
        self.routes[v] = list(legs)
        self.step[v] = 0
        self.detoured[v] = True
        self.crossing[v] = False
        return {"legs": len(legs)}

    def replan(self, blocked):
        other = OTHER[self.vehicle(blocked)]
        # The other robot still has the bottleneck ahead: send it round.
        ahead = not self.crossed[other] and not self.detoured[other]
        return {"action": "detour" if ahead else "hold"}


def serve(planner, address, token):
    if address.startswith("tcp:"):
        host, port = address[4:].rsplit(":", 1)
        sock = socket.create_connection((host, int(port)))
    elif address.startswith("unix:"):
        sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        sock.connect(address[5:])
    else:
        raise SystemExit(f"bad programs address {address!r}: expected tcp:HOST:PORT or unix:PATH")
    out = sock.makefile("w", encoding="utf-8", newline="\n")
    inp = sock.makefile("r", encoding="utf-8", newline="\n")

    def send(obj):
        out.write(json.dumps(obj) + "\n")
        out.flush()

    hello = {"hello": "PLN", "functions": ["next", "cross", "detour", "replan"]}
    if token:
        hello["token"] = token
    send(hello)
    for line in inp:
        line = line.strip()
        if not line:
            continue
        msg = json.loads(line)
        if "welcome" in msg:
            print(f"PLN: welcome, serving {msg['functions']}", file=sys.stderr, flush=True)
            continue
        if "error" in msg:
            print(f"PLN: gateway says: {msg['error']}", file=sys.stderr, flush=True)
            continue
        if "call" not in msg:
            continue
        call, function = msg["call"], msg.get("function")
        args = msg.get("args", {})
        vehicle = msg.get("vehicle")
        try:
            if function == "next":
                params = planner.next(vehicle)
            elif function == "cross":
                params = planner.cross(vehicle)
            elif function == "detour":
                params = planner.detour(vehicle)
            elif function == "replan":
                params = planner.replan(args.get("blocked"))
            else:
                raise ValueError(f"unknown function {function!r}")
        except ValueError as e:
            send({"reply": call, "event": "failed", "params": {"reason": str(e)}})
            continue
        print(f"PLN: {vehicle or 'team'} {function} -> {params}", file=sys.stderr, flush=True)
        send({"reply": call, "event": "done", "params": params})


def main():
    p = argparse.ArgumentParser(description="PLN, the labyrinth planner of examples/ugv-bottleneck")
    p.add_argument("--programs", default=os.environ.get("PETREL_PROGRAMS", "tcp:127.0.0.1:5790"))
    p.add_argument("--home", default=None, help="LAT,LON of the labyrinth's origin (default: SITL's CMAC)")
    a = p.parse_args()
    home = HOME
    if a.home:
        try:
            lat, lon = (float(x) for x in a.home.split(","))
        except ValueError:
            raise SystemExit(f"--home {a.home!r}: expected LAT,LON")
        home = (lat, lon)
    serve(Planner(home), a.programs, os.environ.get("PETREL_PROGRAMS_TOKEN"))


if __name__ == "__main__":
    main()
