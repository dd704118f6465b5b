# What the editor's bench scripts share: a copy of an example in a scratch
# folder, `petrel edit` on it (loopback, a port of its own), a request
# helper, a timer, and cleaning up (the editor killed and reaped, the copy
# removed) whatever happens. Used by bench_routes.py, bench_netops.py and
# bench_rss.py (run from any folder: Python puts the script's own first).
import contextlib, http.client, json, os, shutil, subprocess, tempfile, time


@contextlib.contextmanager
def editor(petrel, example):
    """Yields (req, pid, folder): req(method, path, body=None) asserts a 200
    and returns the decoded JSON (None for an empty body)."""
    d = tempfile.mkdtemp(prefix="petrel-edbench-")
    for f in os.listdir(example):
        p = os.path.join(example, f)
        if os.path.isfile(p):
            shutil.copy(p, d)
    child = subprocess.Popen([petrel, "edit", "--http", "127.0.0.1:0", d],
                             stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True)
    try:
        host = None
        for line in child.stderr:
            if line.startswith("edit: "):
                host = line.split()[1].removeprefix("http://").rstrip("/")
                break
        if host is None:
            raise SystemExit("petrel edit did not say where it listens")

        def req(method, path, body=None):
            c = http.client.HTTPConnection(host, timeout=30)
            c.request(method, path, body=body, headers={"content-type": "application/json"})
            r = c.getresponse()
            data = r.read()
            c.close()
            assert r.status == 200, (path, r.status, data)
            return json.loads(data) if data else None

        yield req, child.pid, d
    finally:
        child.kill()
        child.wait()
        shutil.rmtree(d)


def timed(label, n, f, before=None):
    """Runs f(i) n times (before(i) untimed first); prints and returns the median."""
    ts = []
    for i in range(n):
        if before:
            before(i)
        t = time.perf_counter()
        f(i)
        ts.append(time.perf_counter() - t)
    ts.sort()
    print(f"{label:10} median {ts[n//2]*1e3:7.2f} ms  p90 {ts[int(n*0.9)]*1e3:7.2f} ms")
    return ts[n // 2]
