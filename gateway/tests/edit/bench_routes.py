# Times the editor's routes on a copy of examples/uav-flight-test:
# N edits (add_place on COMMUNICATION), then N undos, then N redos, then
# N GET /version (the cheapest route: the baseline). Loopback only.
import json, sys
from editor_bench import editor, timed

petrel, example, n = sys.argv[1], sys.argv[2], int(sys.argv[3])
with editor(petrel, example) as (req, _, _):
    e = timed("edit", n, lambda i: req("POST", "/edit", json.dumps({"op": "add_place", "net": "COMMUNICATION", "name": f"p{i}"})))
    u = timed("undo", n, lambda i: req("POST", "/undo", "{}"))
    r = timed("redo", n, lambda i: req("POST", "/redo", "{}"))
    v = timed("version", n, lambda i: req("GET", "/version"))
    print(f"ratio undo/edit {u/e:.2f}  redo/edit {r/e:.2f}  edit/version {e/v:.1f}")
