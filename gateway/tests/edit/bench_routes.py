# Times the editor's routes on a copy of examples/uav-flight-test:
# N edits (add_place on COMMUNICATION), then N undos, then N redos, then
# N GET /version (the cheapest route: the baseline). Loopback only.
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
    def timed(label, f):
        ts = []
        for i in range(n):
            t = time.perf_counter(); f(i); ts.append(time.perf_counter() - t)
        ts.sort()
        print(f"{label:8} median {ts[n//2]*1e3:7.2f} ms  p90 {ts[int(n*0.9)]*1e3:7.2f} ms")
        return ts[n//2]
    e = timed("edit", lambda i: req("POST", "/edit", json.dumps({"op": "add_place", "net": "COMMUNICATION", "name": f"p{i}"})))
    u = timed("undo", lambda i: req("POST", "/undo", "{}"))
    r = timed("redo", lambda i: req("POST", "/redo", "{}"))
    v = timed("version", lambda i: req("GET", "/version"))
    print(f"ratio undo/edit {u/e:.2f}  redo/edit {r/e:.2f}  edit/version {e/v:.1f}")
finally:
    child.kill(); child.wait(); shutil.rmtree(d)
