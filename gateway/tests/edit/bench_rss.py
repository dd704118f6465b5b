# The editor's resident memory (VmRSS) at start and after N edits of the
# example's largest net file (flight.toml, add_place): the undo history
# holds N changes of that file, before and after. Loopback only.
import http.client, json, os, shutil, subprocess, sys, tempfile, time
petrel, example, n = sys.argv[1], sys.argv[2], int(sys.argv[3])
d = tempfile.mkdtemp(prefix="petrel-edbench-")
for f in os.listdir(example):
    p = os.path.join(example, f)
    if os.path.isfile(p): shutil.copy(p, d)
child = subprocess.Popen([petrel, "edit", "--http", "127.0.0.1:0", d], stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True)
def rss():
    for l in open(f"/proc/{child.pid}/status"):
        if l.startswith("VmRSS:"): return int(l.split()[1])
try:
    for line in child.stderr:
        if line.startswith("edit: "):
            host = line.split()[1].removeprefix("http://").rstrip("/"); break
    def req(method, path, body=None):
        c = http.client.HTTPConnection(host, timeout=30)
        c.request(method, path, body=body, headers={"content-type": "application/json"})
        r = c.getresponse(); data = r.read(); c.close()
        assert r.status == 200, (path, r.status, data)
        return json.loads(data)
    time.sleep(1); start = rss()
    for i in range(n):
        req("POST", "/edit", json.dumps({"op": "add_place", "net": "FLIGHT", "name": f"p{i}"}))
    time.sleep(1)
    depth = req("GET", "/page.json")["undo_depth"]
    after = rss()
    print(f"size of flight.toml now {os.path.getsize(os.path.join(d, 'flight.toml'))} B; undo depth {depth}")
    print(f"VmRSS at start {start} kB, after {n} edits {after} kB: +{after-start} kB, ratio {after/start:.2f}")
finally:
    child.kill(); child.wait(); shutil.rmtree(d)
