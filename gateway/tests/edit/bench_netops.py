# Times renaming and deleting a net through the editor's routes on a copy
# of examples/uav-flight-test, beside the baseline of an ordinary edit
# (add_place on COMMUNICATION), in the same session: N add_place, N
# rename_net (OPERATIONS <-> OPS: operations.toml, flight.toml and
# catastrophic.toml written), N undos of those renames, N (add_net NEW,
# delete_net NEW) pairs timed on the delete, N set_active toggling
# FLIGHT (project.toml only written). Loopback only.
import http.client, json, os, shutil, subprocess, sys, tempfile, time
petrel, example, n = sys.argv[1], sys.argv[2], int(sys.argv[3])
d = tempfile.mkdtemp(prefix="petrel-edbench-")
for f in os.listdir(example):
    p = os.path.join(example, f)
    if os.path.isfile(p): shutil.copy(p, d)
child = subprocess.Popen([petrel, "edit", "--http", "127.0.0.1:0", d], stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True)
try:
    for line in child.stderr:
        if line.startswith("edit: "):
            host = line.split()[1].removeprefix("http://").rstrip("/"); break
    def req(method, path, body=None):
        c = http.client.HTTPConnection(host, timeout=30)
        c.request(method, path, body=body, headers={"content-type": "application/json"})
        r = c.getresponse(); data = r.read(); c.close()
        assert r.status == 200, (path, r.status, data)
    def edit(op): req("POST", "/edit", json.dumps(op))
    def timed(label, f, before=None):
        ts = []
        for i in range(n):
            if before: before(i)
            t = time.perf_counter(); f(i); ts.append(time.perf_counter() - t)
        ts.sort()
        print(f"{label:10} median {ts[n//2]*1e3:7.2f} ms  p90 {ts[int(n*0.9)]*1e3:7.2f} ms")
        return ts[n//2]
    e = timed("add_place", lambda i: edit({"op": "add_place", "net": "COMMUNICATION", "name": f"p{i}"}))
    names = ["OPERATIONS", "OPS"]
    r = timed("rename_net", lambda i: edit({"op": "rename_net", "name": names[i % 2], "to": names[(i + 1) % 2]}))
    u = timed("undo", lambda i: req("POST", "/undo", "{}"))
    x = timed("delete_net", lambda i: edit({"op": "delete_net", "name": "NEW"}),
              before=lambda i: edit({"op": "add_net", "name": "NEW"}))
    a = timed("set_active", lambda i: edit({"op": "set_active", "name": "FLIGHT", "active": i % 2 == 0}))
    print(f"ratio rename/add_place {r/e:.2f}  undo(rename)/add_place {u/e:.2f}  delete/add_place {x/e:.2f}  set_active/add_place {a/e:.2f}")
finally:
    child.kill(); child.wait(); shutil.rmtree(d)
