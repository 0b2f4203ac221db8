"""penumbra-tune on a small scene: the outputs and the defaults' point, a resumed run measures only
the rest, an interrupted run keeps what it measured, a pick is written into the scene file
atomically and reads back, an impossible budget, an unknown objective, a scene without lights and
a scene with a typo each fail with a message naming what is wrong; the scene patcher on its own.
Usage: tune_smoke.py TUNE BUILD_DIR WORK_DIR"""
import csv
import json
import math
import os
import shutil
import signal
import subprocess
import sys
import time

tune, build, work = sys.argv[1:4]
sys.path.insert(0, os.path.dirname(os.path.abspath(tune)))
from penumbra import scenefile  # noqa: E402

shutil.rmtree(work, ignore_errors=True)
os.makedirs(work)
failures = []


def check(ok, what):
    if not ok:
        failures.append(what)


# A box on a plane under a sun (shared with cluster_test.py).
with open(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "data", "scene",
                       "tiny-sun.toml")) as f:
    SCENE = f.read()
scene = os.path.join(work, "tiny.toml")
with open(scene, "w") as f:
    f.write(SCENE)
env = dict(os.environ, PENUMBRA_BUILD=build)
base = [sys.executable, tune, "--scene", scene, "--quick", "--size", "96x54", "--frames", "1",
        "--path-frames", "2"]


def run(args, **kw):
    return subprocess.run(base + args, capture_output=True, text=True, env=env, **kw)


def _num(text):
    try:
        return float(text)
    except (TypeError, ValueError):
        return None


def points(out):
    with open(os.path.join(out, "points.jsonl")) as f:
        return [json.loads(line) for line in f if line.strip()]


out = os.path.join(work, "out")
r = run(["--trials", "3", "--out", out])
check(r.returncode == 0, f"a 3-point run exited {r.returncode}:\n{r.stdout}{r.stderr}")
for name in ("points.csv", "frontier.csv", "tune.json", "frontier.png", "study.db",
             "points.jsonl"):
    check(os.path.isfile(os.path.join(out, name)), f"{name} missing")
if os.path.isfile(os.path.join(out, "tune.json")):
    with open(os.path.join(out, "tune.json")) as f:
        summary = json.load(f)
    check(summary["points"] == 3, f"{summary['points']} points, expected 3")
    d = summary["defaults"]
    check(d is not None and d["defaults"], "the defaults were not measured")
    if d:
        # The scene's own settings, as the search space names them (a sun: its cascades).
        check(d["sets"].get("shadows.filter") == "pcf" and d["sets"].get("shadows.pcf_radius")
              == "1" and d["sets"].get("shadows.cascades") == "2" and
              d["sets"].get("shadows.resolution") == "512", f"defaults' settings {d['sets']}")
        check("contact.steps" not in d["sets"], "a scene without [contact] searches no contact "
              f"keys: {d['sets']}")
    for p in summary["frontier"]:
        for k in ("ms", "path_error", "flicker", "acne", "gap", "still_error"):
            v = p[k]
            check(math.isfinite(v) and v >= 0.0, f"trial {p['trial']}: {k} = {v}")
        check(p["ms"] > 0 and p["path_error"] <= 1 and p["flicker"] <= 1 and p["acne"] <= 1,
              f"trial {p['trial']}: out of range {p}")
    check(isinstance(summary["defaults_on_frontier"], bool), "defaults_on_frontier")
    with open(os.path.join(out, "points.csv")) as f:
        check(len(list(csv.DictReader(f))) == 3, "points.csv rows")

# Resumed: the same command with more trials measures only the new ones.
r = run(["--trials", "4", "--out", out])
check(r.returncode == 0 and "resuming" in r.stdout and "3 points measured, 1 to go" in r.stdout,
      f"resume:\n{r.stdout}{r.stderr}")
check(len(points(out)) <= 4, f"{len(points(out))} measured in points.jsonl")

# Interrupted after the first point: it stops there, keeps it and says how to resume.
out2 = os.path.join(work, "interrupted")
p = subprocess.Popen(base + ["--trials", "50", "--out", out2], stdout=subprocess.PIPE,
                     stderr=subprocess.PIPE, text=True, env=env)
deadline = time.monotonic() + 600
while time.monotonic() < deadline and p.poll() is None:
    if os.path.isfile(os.path.join(out2, "points.jsonl")) and points(out2):
        p.send_signal(signal.SIGINT)
        break
    time.sleep(0.2)
stdout, stderr = p.communicate(timeout=600)
check(p.returncode == 0 and "run the same command again to resume" in stderr,
      f"interrupted run exited {p.returncode}:\n{stdout}{stderr[-2000:]}")
check(1 <= len(points(out2)) < 50, f"interrupted run kept {len(points(out2))} points")
check(os.path.isfile(os.path.join(out2, "tune.json")), "interrupted run wrote no tune.json")

# A pick written into a copy of the scene: atomically, read back by penumbra-view.
copy = os.path.join(work, "copy.toml")
shutil.copy(scene, copy)
r = subprocess.run([sys.executable, tune, "--scene", copy, "--quick", "--size", "96x54",
                    "--frames", "1", "--path-frames", "2", "--trials", "3", "--out",
                    os.path.join(work, "copy-out"), "--pick", "1", "--write"],
                   capture_output=True, text=True, env=env)
check(r.returncode == 0 and "pick:" in r.stdout, f"--write:\n{r.stdout}{r.stderr}")
with open(copy) as f:
    written = f.read()
check(written.startswith("# A box on a plane"), "the scene's comments were lost")
check("penumbra-tune" in written and "wrote" in r.stdout, f"nothing written:\n{r.stdout}")
# What was written is trial 1's settings, as penumbra-view reads the file back.
with open(os.path.join(work, "copy-out", "tune.json")) as f:
    picked = json.load(f)["pick"]["sets"]
table = {row["key"]: row["value"] for row in json.loads(subprocess.run(
    [os.path.join(build, "runtime", "penumbra-view"), "--scene", copy, "--list-params"],
    capture_output=True, text=True).stdout or "[]")}
for key, value in picked.items():
    same = (table.get(key) == value or
            (key in table and table[key] is not None and _num(table[key]) is not None and
             _num(value) is not None and math.isclose(_num(table[key]), _num(value),
                                                      rel_tol=1e-5)))
    check(same, f"{key}: the file reads back {table.get(key)!r}, trial 1 had {value!r}")
r = subprocess.run([sys.executable, tune, "--scene", copy, "--out", os.path.join(work,
                    "copy-out"), "--pick", "99", "--quick", "--size", "96x54", "--frames", "1",
                    "--path-frames", "2", "--trials", "3"], capture_output=True, text=True,
                   env=env)
check(r.returncode != 0 and "--pick 99: no measured trial" in r.stderr,
      f"--pick of a trial not measured:\n{r.stderr}")
check(not [n for n in os.listdir(work) if n.startswith(".penumbra")], "a temporary file was left")
view = os.path.join(build, "runtime", "penumbra-view")
check(subprocess.run([view, "--scene", copy, "--list-params"], capture_output=True).returncode
      == 0, "the written scene does not load")

# Bad input: each a message naming what is wrong, and a non-zero exit.
r = run(["--trials", "3", "--out", out, "--budget-ms", "0.000001"])
check(r.returncode != 0 and "no measured point meets ms <= 1e-06" in r.stderr,
      f"impossible budget:\n{r.stderr}")
r = run(["--out", out, "--max", "speed=1"])
check(r.returncode != 0 and "--max speed=1" in r.stderr, f"unknown objective:\n{r.stderr}")
dark = os.path.join(work, "dark.toml")
with open(dark, "w") as f:
    f.write('name = "dark"\n[[object]]\nmesh = "plane"\n')
r = subprocess.run([sys.executable, tune, "--scene", dark, "--out", os.path.join(work, "d")],
                   capture_output=True, text=True, env=env)
check(r.returncode != 0 and "has no lights" in r.stderr, f"no lights:\n{r.stderr}")
typo = os.path.join(work, "typo.toml")
with open(typo, "w") as f:
    f.write(SCENE.replace("pcf_radius = 1", "pcf_radius = 1\npcf_radus = 2"))
r = subprocess.run([sys.executable, tune, "--scene", typo, "--out", os.path.join(work, "t")],
                   capture_output=True, text=True, env=env)
check(r.returncode != 0 and "typo.toml:15" in r.stderr, f"typo:\n{r.stderr}")

# The scene's own [tune] budget: used without --budget-ms/--max; budget_ms only on the device
# it names; --check-defaults fails when the defaults miss it; a typo in it is an error at its
# line.
budgeted = os.path.join(work, "budgeted.toml")
with open(budgeted, "w") as f:
    f.write(SCENE + '\n[tune]\ndevice = "NVIDIA H200"\nbudget_ms = 1\nmax_path_error = 0\n')
r = subprocess.run([sys.executable, tune, "--scene", budgeted, "--out", os.path.join(work, "b"),
                    "--quick", "--size", "96x54", "--frames", "1", "--path-frames", "2",
                    "--trials", "2", "--check-defaults"], capture_output=True, text=True, env=env)
with open(os.path.join(work, "b", "tune.json")) as f:
    measured_on = json.load(f)["device"]
if "NVIDIA H200" not in measured_on:
    # On another device the defaults' own GPU time stands in for budget_ms.
    check("budget_ms = 1 is for NVIDIA H200" in r.stdout and "stands in for it" in r.stdout and
          "the defaults' GPU time for budget_ms): ms <= " in r.stdout,
          f"[tune] budget_ms for another device:\n{r.stdout}{r.stderr}")
check("budget (the scene's [tune]" in r.stdout and "path_error <= 0.0" in r.stdout,
      f"[tune] not used:\n{r.stdout}{r.stderr}")
check(r.returncode != 0 and "the defaults miss it: path_error" in r.stdout,
      f"--check-defaults with defaults that miss [tune]:\n{r.stdout}{r.stderr}")
check("no measured point meets " in r.stderr and "path_error <= 0.0" in r.stderr,
      f"[tune] impossible:\n{r.stderr}")
with open(budgeted, "w") as f:
    f.write(SCENE + "\n[tune]\nbudget_mss = 2\n")
r = subprocess.run([sys.executable, tune, "--scene", budgeted, "--out", os.path.join(work, "b2")],
                   capture_output=True, text=True, env=env)
check(r.returncode != 0 and "budgeted.toml:27" in r.stderr and "budget_mss" in r.stderr,
      f"[tune] typo:\n{r.stderr}")

# The one-knob sweep beside the search: measured, scored like it, covered or listed; two points
# at once, the timed frames behind the GPU lock the tuner hands its processes.
r = run(["--jobs", "0"])
check(r.returncode != 0 and "--jobs 0: must be 1 to 256" in r.stderr, f"--jobs 0:\n{r.stderr}")
r = run(["--trials", "4", "--out", out, "--one-knob", "--jobs", "2"])
check(r.returncode == 0 and "one-knob sweep: the search covers" in r.stdout,
      f"--one-knob:\n{r.stdout}{r.stderr}")
check(os.path.isfile(os.path.join(out, "gpu.lock")), "--jobs 2 made no gpu.lock")
if os.path.isfile(os.path.join(out, "oneknob.csv")):
    with open(os.path.join(out, "oneknob.csv")) as f:
        knobs = list(csv.DictReader(f))
    # --quick's sweep: hard, pcf r=1, pcss medium.
    check([k["label"] for k in knobs] == ["hard", "pcf r=1", "pcss medium"],
          f"one-knob labels {knobs}")
    with open(os.path.join(out, "tune.json")) as f:
        one = json.load(f).get("one_knob", {})
    check(one.get("points") == 3 and one.get("covered", -1) + len(one.get("uncovered", [])) == 3,
          f"tune.json one_knob: {one}")
else:
    check(False, "--one-knob wrote no oneknob.csv")
# The sweep's points seed the search (all three fit its space), marked apart from its own points
# and not counted in --trials: one more trial measures one new point, and seeds nothing again.
check("the search starts from 3 of the sweep's points" in r.stdout, f"seeding:\n{r.stdout}")
with open(os.path.join(out, "points.csv")) as f:
    seeds = [row["seed"] for row in csv.DictReader(f) if row["seed"]]
check(len(seeds) == 3, f"seeded rows in points.csv: {seeds}")
before = len(points(out))
r = run(["--trials", "5", "--out", out, "--one-knob"])
check(r.returncode == 0 and len(points(out)) == before + 1 and "starts from" not in r.stdout,
      f"a resumed seeded run measured {len(points(out)) - before} points:\n{r.stdout}{r.stderr}")

# A study started from an earlier run's points: they join it, the defaults are measured again.
r = run(["--trials", "5", "--out", os.path.join(work, "imported"), "--import",
         os.path.join(out, "points.csv")])
check(r.returncode == 0 and "imported 8 points" in r.stdout and
      "measured in the imported run at" in r.stdout, f"--import:\n{r.stdout}{r.stderr}")
check(len(points(os.path.join(work, "imported"))) == 1,
      "--import measured more than the defaults")

# --replay, CI's frontier check: checked-in points with the settings and a contender whose
# recorded cost is lower. The scene with a 0.2 m constant bias leaves a wide lit gap under the
# box; the same settings with the scene's bias close it.
with open(os.path.join(out, "points.csv")) as f:
    rows = list(csv.DictReader(f))
base_row = next(row for row in rows if row["defaults"] == "True")
biased = ";".join(kv if not kv.startswith("shadows.constant_bias=") else
                  "shadows.constant_bias=0.2" for kv in base_row["sets"].split(";"))
check(biased != base_row["sets"], f"no constant bias in {base_row['sets']}")


def replay_data(name, cheap_sets, dear_sets):
    """A points.csv of two points with equal recorded errors: `cheap_sets` at 1 ms, `dear_sets`
    at 2 ms (the replay ranks contenders by the recorded numbers, then measures them)."""
    path = os.path.join(work, name)
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(base_row))
        w.writeheader()
        w.writerow({**base_row, "trial": "0", "ms": "1", "sets": cheap_sets,
                    "path_error": "0.001"})
        w.writerow({**base_row, "trial": "1", "ms": "2", "sets": dear_sets,
                    "path_error": "0.002"})
    return path


def replay(scene_path, data):
    return subprocess.run([sys.executable, tune, "--scene", scene_path, "--quick", "--size",
                           "192x108", "--path-frames", "2", "--replay", data],
                          capture_output=True, text=True, env=env)


# The scene's settings (the dearer point) against a cheaper point with the huge bias: no beat.
r = replay(scene, replay_data("replay-ok.csv", biased, base_row["sets"]))
check(r.returncode == 0 and "no contender beats its settings" in r.stdout,
      f"--replay of settings on the frontier:\n{r.stdout}{r.stderr}")
# The scene with the huge bias (the dearer point) against the scene's bias at less cost: beaten.
stale = os.path.join(work, "stale.toml")
with open(stale, "w") as f:
    f.write(SCENE.replace("resolution = 512", "resolution = 512\nconstant_bias = 0.2"))
r = replay(stale, replay_data("replay-stale.csv", base_row["sets"], biased))
check(r.returncode == 1 and "now beats the settings" in r.stdout,
      f"--replay of stale settings:\n{r.stdout}{r.stderr}")
# Settings that are not among the points: the scene changed since it was tuned.
r = replay(stale, replay_data("replay-other.csv", base_row["sets"], base_row["sets"]))
check(r.returncode == 1 and "are not among the 2 points" in r.stdout,
      f"--replay of settings not in the data:\n{r.stdout}{r.stderr}")

# The patcher: a key replaced in place, one added to its table, a table added; nothing else.
text = '# top\n[shadows]\nfilter = "pcf"  # old\n\n[[material]]\nname = "m"\n'
got = scenefile.patched_text(text, {"shadows.filter": "hard", "shadows.pcf_radius": 2,
                                    "contact.steps": 0, "shadows.temporal": True}, "n")
want = ('# top\n[shadows]\nfilter = "hard"  # n\npcf_radius = 2  # n\ntemporal = true  # n\n\n'
        '[[material]]\nname = "m"\n\n[contact]\nsteps = 0  # n\n')
check(got == want, f"patched text:\n{got!r}\nwanted\n{want!r}")
# A new file gets the permissions open() would give it, not the temporary file's private ones.
fresh = os.path.join(work, "fresh.txt")
scenefile.write_atomic(fresh, "x")
umask = os.umask(0)
os.umask(umask)
check(os.stat(fresh).st_mode & 0o777 == 0o666 & ~umask,
      f"a new file written atomically has mode {oct(os.stat(fresh).st_mode & 0o777)}")
try:
    scenefile.write_atomic(os.path.join(work, "no-such-dir", "x.toml"), "x")
    check(False, "a write into a missing folder must fail")
except OSError:
    pass

if failures:
    print("\n".join(failures))
    sys.exit(1)
print("penumbra-tune: outputs, resume, interruption, --write and bad input as expected")
