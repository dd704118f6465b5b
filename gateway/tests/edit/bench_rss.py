# The editor's resident memory (VmRSS) at start and after N edits of the
# example's largest net file (flight.toml, add_place): the undo history
# holds N changes of that file, before and after. Loopback only.
import json, os, sys, time
from editor_bench import editor

petrel, example, n = sys.argv[1], sys.argv[2], int(sys.argv[3])
with editor(petrel, example) as (req, pid, d):
    def rss():
        for l in open(f"/proc/{pid}/status"):
            if l.startswith("VmRSS:"): return int(l.split()[1])
    time.sleep(1); start = rss()
    for i in range(n):
        req("POST", "/edit", json.dumps({"op": "add_place", "net": "FLIGHT", "name": f"p{i}"}))
    time.sleep(1)
    depth = req("GET", "/page.json")["undo_depth"]
    after = rss()
    print(f"size of flight.toml now {os.path.getsize(os.path.join(d, 'flight.toml'))} B; undo depth {depth}")
    print(f"VmRSS at start {start} kB, after {n} edits {after} kB: +{after-start} kB, ratio {after/start:.2f}")
