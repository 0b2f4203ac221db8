#!/usr/bin/python3
"""penumbra-tune on a Dask cluster (issue 34), on lavapipe at a tiny size:

1. the default run (no cluster) and --cluster local:2 open no port on a non-loopback address,
   and a run killed with SIGKILL resumes to the serial run's results;
2. a cluster of a scheduler and two workers started by tools/penumbra-cluster (each its own
   process, as two machines would be) measures the one-knob sweep with the same results as the
   serial run, row for row (GPU times aside), while one worker is killed after the first point:
   no finished point is lost and none is recorded twice;
3. penumbra-bench's quick list on that cluster gives the serial bench's rows, and a worker at
   another commit has its points refused, not mixed in;
4. penumbra-cluster refuses a public address.

usage: cluster_test.py TOOLS_DIR BUILD_DIR WORK_DIR"""
import json
import os
import shutil
import signal
import subprocess
import sys
import time

tools, build, work = sys.argv[1:4]
tune, launcher = os.path.join(tools, "penumbra-tune"), os.path.join(tools, "penumbra-cluster")
bench = os.path.join(tools, "penumbra-bench")
shutil.rmtree(work, ignore_errors=True)
os.makedirs(work)
failures = []


def check(ok, what):
    if not ok:
        failures.append(what)
        print(f"FAIL: {what}", file=sys.stderr)


# A box on a plane under a sun (shared with tune_smoke.py).
with open(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "data", "scene",
                       "tiny-sun.toml")) as f:
    SCENE = f.read()
scene = os.path.join(work, "tiny.toml")
with open(scene, "w") as f:
    f.write(SCENE)
# Every process of the test traces into a cache of its own (so the cluster's truth task traces).
env = dict(os.environ, PENUMBRA_BUILD=build, PENUMBRA_DEVICE="lavapipe",
           PENUMBRA_REFERENCE_CACHE=os.path.join(work, "cache"))
base = [sys.executable, tune, "--scene", scene, "--quick", "--size", "96x54", "--frames", "1",
        "--path-frames", "2", "--one-knob", "--trials", "1"]


def listening_sockets(pids):
    """(address, port) of every TCP socket in LISTEN state that one of `pids` holds."""
    inodes = set()
    for pid in pids:
        try:
            for fd in os.listdir(f"/proc/{pid}/fd"):
                try:
                    target = os.readlink(f"/proc/{pid}/fd/{fd}")
                except OSError:
                    continue
                if target.startswith("socket:["):
                    inodes.add(target[8:-1])
        except OSError:
            continue
    found = []
    for table, v6 in (("/proc/net/tcp", False), ("/proc/net/tcp6", True)):
        try:
            with open(table) as f:
                rows = f.read().splitlines()[1:]
        except OSError:
            continue
        for row in rows:
            cols = row.split()
            if cols[3] != "0A" or cols[9] not in inodes:  # 0A: LISTEN
                continue
            addr, port = cols[1].split(":")
            raw = bytes.fromhex(addr)
            if v6:
                words = [raw[i:i + 4][::-1] for i in range(0, 16, 4)]
                import ipaddress
                ip = str(ipaddress.IPv6Address(b"".join(words)))
            else:
                ip = ".".join(str(b) for b in raw[::-1])
            found.append((ip, int(port, 16)))
    return found


def tree(pid):
    """pid and its descendants."""
    out, todo = [], [pid]
    while todo:
        p = todo.pop()
        out.append(p)
        try:
            with open(f"/proc/{p}/task/{p}/children") as f:
                todo += [int(c) for c in f.read().split()]
        except OSError:
            pass
    return out


def loopback(ip):
    return ip.startswith("127.") or ip in ("::1", "::ffff:127.0.0.1")


def run_watching(args, out):
    """Runs the tuner to its end, watching its processes' listening sockets; returns
    (CompletedProcess-like, sockets seen)."""
    p = subprocess.Popen(base + args + ["--out", out], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True, env=env)
    seen = set()
    while p.poll() is None:
        seen.update(listening_sockets(tree(p.pid)))
        time.sleep(0.05)
    stdout, stderr = p.communicate()
    return subprocess.CompletedProcess(p.args, p.returncode, stdout, stderr), seen


def sweep_rows(out):
    """The one-knob sweep's results by label, without what depends on the machine and its load
    (GPU times, seconds, the worker)."""
    rows = {}
    if not os.path.exists(os.path.join(out, "oneknob.jsonl")):
        check(False, f"{out}: no oneknob.jsonl")
        return rows
    with open(os.path.join(out, "oneknob.jsonl")) as f:
        for line in f:
            row = json.loads(line)
            check(row["label"] not in rows, f"{out}: {row['label']} recorded twice")
            r = {k: v for k, v in row["result"].items()
                 if k not in ("ms", "passes", "seconds", "worker")}
            rows[row["label"]] = r
    return rows


# 1. The serial run (the default: no cluster, no port) and a local cluster (loopback only).
serial = os.path.join(work, "serial")
r, seen = run_watching([], serial)
check(r.returncode == 0, f"serial run:\n{r.stdout}{r.stderr}")
check(not seen, f"the default run listens on {sorted(seen)}")
local = os.path.join(work, "local")
r, seen = run_watching(["--cluster", "local:2"], local)
check(r.returncode == 0 and "measuring on tcp://127.0.0.1:" in r.stdout,
      f"--cluster local:2:\n{r.stdout}{r.stderr}")
check(seen and all(loopback(ip) for ip, _ in seen),
      f"--cluster local:2 listens on {sorted(seen)} (only loopback expected)")
want = sweep_rows(serial)
check(len(want) == 3, f"serial sweep rows: {sorted(want)}")
check(sweep_rows(local) == want, "--cluster local:2 measured the sweep otherwise than the serial "
      "run")

# The tuner itself killed (SIGKILL) after its first point, then run again: it resumes and ends
# with the serial run's results, none measured twice.
killed_out = os.path.join(work, "killed")
p = subprocess.Popen(base + ["--out", killed_out], stdout=subprocess.DEVNULL,
                     stderr=subprocess.DEVNULL, env=env)
killed_log = os.path.join(killed_out, "oneknob.jsonl")
while p.poll() is None:
    if os.path.exists(killed_log) and os.path.getsize(killed_log) > 0:
        p.kill()
        break
    time.sleep(0.05)
p.wait()
with open(killed_log) as f:
    first = len(f.read().splitlines())
r = subprocess.run(base + ["--out", killed_out], capture_output=True, text=True, env=env)
check(r.returncode == 0, f"the run after a SIGKILL:\n{r.stdout}{r.stderr}")
check(sweep_rows(killed_out) == want, "a killed and resumed run measured the sweep otherwise than "
      "the serial run")
if first >= 3:  # a machine so busy that the whole sweep ran between two looks: nothing resumed
    print(f"note: the tuner was killed after all {first} sweep points")

# penumbra-bench's quick list on the same scene, serially (the cluster's run is below).
bench_base = [sys.executable, bench, "--quick", "--scene", scene, "--size", "96x54", "--frames",
              "2", "--build", build]
# What depends on the machine and its load: GPU times and the roofline from them.
TIMED = ("shadow_ms", "frame_ms", "resolve_ms", "resolve_floor_ms", "resolve_over_floor", "passes")


def bench_rows(out):
    try:
        with open(os.path.join(out, "bench.json")) as f:
            rows = json.load(f)["rows"]
    except (OSError, ValueError, KeyError):
        check(False, f"{out}: no bench.json")
        return []
    return [{k: v for k, v in r.items() if k not in TIMED} for r in rows]


r = subprocess.run(bench_base + ["--out", os.path.join(work, "bench-serial")], capture_output=True,
                   text=True, env=env)
check(r.returncode == 0, f"serial bench:\n{r.stdout}{r.stderr}")
want_bench = bench_rows(os.path.join(work, "bench-serial"))
check(len(want_bench) == 4, f"{len(want_bench)} serial bench rows (4 configurations expected)")

# 2. A scheduler and two workers of their own, one killed mid-run.
sched_file = os.path.join(work, "scheduler.json")
procs = []


def start(args, name):
    log = open(os.path.join(work, name + ".log"), "w")
    p = subprocess.Popen([sys.executable, launcher] + args, stdout=log, stderr=subprocess.STDOUT,
                         env=env, start_new_session=True)
    procs.append(p)
    return p


def stop_all():
    for p in procs:
        if p.poll() is None:
            os.killpg(p.pid, signal.SIGTERM)
    for p in procs:
        try:
            p.wait(timeout=30)
        except subprocess.TimeoutExpired:
            os.killpg(p.pid, signal.SIGKILL)
            p.wait()


try:
    start(["scheduler", "--scheduler-file", sched_file], "scheduler")
    for _ in range(600):
        if os.path.exists(sched_file):
            break
        time.sleep(0.1)
    check(os.path.exists(sched_file), "the scheduler wrote no scheduler file")
    w1 = start(["worker", sched_file, "--device-class", "lavapipe", "--no-nanny", "--name", "w1"],
               "worker1")
    start(["worker", sched_file, "--device-class", "lavapipe", "--no-nanny", "--name", "w2"],
          "worker2")
    time.sleep(1)
    two = os.path.join(work, "two")
    p = subprocess.Popen(base + ["--cluster", sched_file, "--out", two], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True, env=env)
    log = os.path.join(two, "oneknob.jsonl")
    killed = False
    while p.poll() is None:
        if not killed and os.path.exists(log) and os.path.getsize(log) > 0:
            os.killpg(w1.pid, signal.SIGKILL)  # mid-run: the sweep has more points to go
            killed = True
        time.sleep(0.05)
    stdout, stderr = p.communicate()
    check(p.returncode == 0, f"cluster run:\n{stdout}{stderr}")
    check(killed, "the run ended before a worker could be killed")
    check(sweep_rows(two) == want, "the cluster with a killed worker measured the sweep otherwise "
          "than the serial run")

    # The bench on the same cluster (one worker left): the serial rows.
    r = subprocess.run(bench_base + ["--out", os.path.join(work, "bench-cluster"), "--cluster",
                                     sched_file], capture_output=True, text=True, env=env)
    check(r.returncode == 0 and "measuring on" in r.stdout, f"bench on a cluster:\n{r.stdout}{r.stderr}")
    check(bench_rows(os.path.join(work, "bench-cluster")) == want_bench,
          "the bench on a cluster measured otherwise than the serial bench")

    # 3. A worker at another commit: its points are refused (the only worker left offering the
    # class is this one once the good one is stopped).
    for q in procs[1:]:
        if q.poll() is None:
            os.killpg(q.pid, signal.SIGTERM)
            q.wait(timeout=30)
    foreign_env = dict(env, PENUMBRA_COMMIT="0000000")
    q = subprocess.Popen([sys.executable, launcher, "worker", sched_file, "--device-class",
                          "lavapipe", "--no-nanny"], stdout=subprocess.DEVNULL,
                         stderr=subprocess.DEVNULL, env=foreign_env, start_new_session=True)
    procs.append(q)
    time.sleep(2)
    foreign = os.path.join(work, "foreign")
    r = subprocess.run(base + ["--cluster", sched_file, "--out", foreign], capture_output=True,
                       text=True, env=env, timeout=600)
    check("refused a point from worker" in r.stderr and "commit" in r.stderr,
          f"a foreign worker's points were not refused:\n{r.stdout}{r.stderr}")
    if os.path.exists(os.path.join(foreign, "oneknob.jsonl")):
        with open(os.path.join(foreign, "oneknob.jsonl")) as f:
            check(not f.read().strip(), "a foreign worker's point was recorded")
finally:
    stop_all()

# 4. No public address.
r = subprocess.run([sys.executable, launcher, "scheduler", "--host", "8.8.8.8"],
                   capture_output=True, text=True, env=env)
check(r.returncode != 0 and "not a loopback or private address" in r.stderr,
      f"a public --host was not refused:\n{r.stderr}")

if failures:
    sys.exit(f"{len(failures)} check(s) failed")
print("penumbra-tune on a cluster: loopback only by default, the serial results row for row with "
      "a worker killed, a foreign worker refused, no public address")
