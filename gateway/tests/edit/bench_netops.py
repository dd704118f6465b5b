# Times renaming and deleting a net through the editor's routes on a copy
# of examples/uav-flight-test, beside the baseline of an ordinary edit
# (add_place on COMMUNICATION), in the same session: N add_place, N
# rename_net (OPERATIONS <-> OPS: operations.toml, flight.toml and
# catastrophic.toml written), N undos of those renames, N (add_net NEW,
# delete_net NEW) pairs timed on the delete, N set_active toggling
# FLIGHT (project.toml only written). Loopback only.
import json, sys
from editor_bench import editor, timed

petrel, example, n = sys.argv[1], sys.argv[2], int(sys.argv[3])
with editor(petrel, example) as (req, _, _):
    def edit(op): req("POST", "/edit", json.dumps(op))
    e = timed("add_place", n, lambda i: edit({"op": "add_place", "net": "COMMUNICATION", "name": f"p{i}"}))
    names = ["OPERATIONS", "OPS"]
    r = timed("rename_net", n, lambda i: edit({"op": "rename_net", "name": names[i % 2], "to": names[(i + 1) % 2]}))
    u = timed("undo", n, lambda i: req("POST", "/undo", "{}"))
    x = timed("delete_net", n, lambda i: edit({"op": "delete_net", "name": "NEW"}),
              before=lambda i: edit({"op": "add_net", "name": "NEW"}))
    a = timed("set_active", n, lambda i: edit({"op": "set_active", "name": "FLIGHT", "active": i % 2 == 0}))
    print(f"ratio rename/add_place {r/e:.2f}  undo(rename)/add_place {u/e:.2f}  delete/add_place {x/e:.2f}  set_active/add_place {a/e:.2f}")
