# Sets the scheduling of a running latency bench's `petrel run` from
# outside, so that one binary gives every row of BENCHMARKS.md's "Under
# load (issue 15)": run it beside `cargo bench -p gateway --bench latency`.
#
# Usage: threads.py MODE SECONDS
#   before   both threads: normal policy, the kernel's default slice
#            (what petrel did before it asked for anything)
#   shipped  leave them as petrel set them (prints their ids)
#   fifo     both threads SCHED_FIFO 10 (needs the privilege)
#   nice     both threads normal policy, nice -10 (needs the privilege)
import ctypes, os, struct, subprocess, sys, time

libc = ctypes.CDLL(None, use_errno=True)
SYS_SCHED_SETATTR = 314  # x86_64


def setattr(tid, policy, runtime, nice=0, prio=0):
    attr = struct.pack("IIQiIQQQII", 56, policy, 0, nice, prio, runtime, 0, 0, 0, 0)
    buf = ctypes.create_string_buffer(attr, 56)
    return libc.syscall(SYS_SCHED_SETATTR, tid, buf, 0), ctypes.get_errno()


mode, end = sys.argv[1], time.time() + float(sys.argv[2])
done = set()
while time.time() < end:
    found = subprocess.run(["pgrep", "-f", "gateway/benches/latency"], capture_output=True, text=True)
    for pid in found.stdout.split():
        try:
            cmd = open(f"/proc/{pid}/cmdline").read()
            tids = os.listdir(f"/proc/{pid}/task")
        except OSError:
            continue
        if not cmd.startswith("/") or "\0run\0" not in cmd:
            continue
        for tid in tids:
            if tid in done:
                continue
            try:
                comm = open(f"/proc/{pid}/task/{tid}/comm").read().strip()
            except OSError:
                continue
            if comm != "petrel-recorder" and tid != pid:
                continue
            if mode == "before":
                r = setattr(int(tid), 0, 0)
            elif mode == "fifo":
                r = setattr(int(tid), 1, 0, 0, 10)
            elif mode == "nice":
                r = setattr(int(tid), 0, 0, -10)
            else:
                r = "left as petrel set it"
            print(comm, tid, mode, r)
            done.add(tid)
    time.sleep(0.05)
