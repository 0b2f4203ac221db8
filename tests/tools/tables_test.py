"""The frontier rule (penumbra.pareto.beaten_by) on cases that tell its margins apart, and the
docs' generated tables: tools/penumbra-tables --check passes on the docs as checked in and
fails, naming the table, on a copy with one number changed, and (the accuracy and frame tables)
on a copy of the data with one value changed."""
import json
import os
import shutil
import subprocess
import sys
import tempfile

root = sys.argv[1]
sys.path.insert(0, os.path.join(root, "tools"))
from penumbra import pareto  # noqa: E402

failures = []


def check(ok, what):
    if not ok:
        failures.append(what)
        print("FAILED:", what)


errors = ["e", "f"]
floors = {"e": 2e-4, "f": 1e-3}
d = {"ms": 6.47, "e": 0.00316, "f": 0.00128}
# grazing's case: better on e by 13%, worse on f by less than the floor -> beats.
p = {"ms": 6.43, "e": 0.00275, "f": 0.00162}
check(pareto.beaten_by(d, [d, p], "ms", errors, 0.05, floors) == [p], "within-floor worse beats")
# the same point over a [tune] limit on f -> no choice for the scene, beats nothing.
check(pareto.beaten_by(d, [d, p], "ms", errors, 0.05, floors, {"f": 0.0015}) == [],
      "a point over a limit beats")
check(pareto.beaten_by(d, [d, p], "ms", errors, 0.05, floors, {"f": 0.002}) == [p],
      "a point within the limits does not beat")
# worse on f beyond 5% and the floor -> does not beat.
q = {"ms": 6.43, "e": 0.00275, "f": 0.0030}
check(pareto.beaten_by(d, [d, q], "ms", errors, 0.05, floors) == [], "worse beyond the margin")
# better only by less than the margin -> does not beat.
r = {"ms": 6.0, "e": 0.00310, "f": 0.00128}
check(pareto.beaten_by(d, [d, r], "ms", errors, 0.05, floors) == [], "better within the margin")
# costlier -> does not beat, however much better.
c = {"ms": 7.0, "e": 0.0001, "f": 0.0001}
check(pareto.beaten_by(d, [d, c], "ms", errors, 0.05, floors) == [], "costlier")
check(pareto.frontier([d, p, q, c], ["ms"] + errors) == [d, p, c], "frontier (q: p is no worse)")

tables = os.path.join(root, "tools", "penumbra-tables")
doc = os.path.join(root, "docs", "tuning.md")
run = subprocess.run([sys.executable, tables, "--check", doc], capture_output=True, text=True)
check(run.returncode == 0, f"the checked-in tables are stale:\n{run.stdout}{run.stderr}")
with tempfile.TemporaryDirectory() as tmp:
    copy = os.path.join(tmp, "tuning.md")
    shutil.copy(doc, copy)
    text = open(copy).read()
    at = text.index("| grazing | ", text.index("<!-- table tune-h200"))
    line_end = text.index("\n", at)
    changed = text[:at] + text[at:line_end].replace("| 6.43 |", "| 6.34 |") + text[line_end:]
    check(changed != text, "the mutation changed the copy")
    open(copy, "w").write(changed)
    run = subprocess.run([sys.executable, tables, "--check", copy], capture_output=True,
                         text=True)
    check(run.returncode == 1 and "table tune-h200" in run.stdout,
          f"a changed number was not caught:\n{run.stdout}{run.stderr}")
    run = subprocess.run([sys.executable, tables, copy], capture_output=True, text=True)
    check(open(copy).read() == text, "regenerating did not restore the table")


# The accuracy tables (docs/accuracy.md) and the frame timings (docs/performance.md), both ways:
# a changed number in a table, and a changed value in the data it comes from, fail --check
# naming the table; --data points the tool at a copy of docs/data.
for name in ["accuracy.md", "performance.md"]:
    doc = os.path.join(root, "docs", name)
    run = subprocess.run([sys.executable, tables, "--check", doc], capture_output=True, text=True)
    check(run.returncode == 0, f"{name}'s tables are stale:\n{run.stdout}{run.stderr}")
with tempfile.TemporaryDirectory() as tmp:
    doc = os.path.join(tmp, "accuracy.md")
    shutil.copy(os.path.join(root, "docs", "accuracy.md"), doc)
    text = open(doc).read()
    at = text.index("| sun | lavapipe, ", text.index("<!-- table accuracy-default"))
    line_end = text.index("\n", at)
    mean = text[at:line_end].split(" | ")[2]  # "0.0006 (0.0005)"
    changed = text[:at] + text[at:line_end].replace(mean, "0.0001" + mean[6:], 1) + \
        text[line_end:]
    check(changed != text, "the accuracy mutation changed the copy")
    open(doc, "w").write(changed)
    run = subprocess.run([sys.executable, tables, "--check", doc], capture_output=True, text=True)
    check(run.returncode == 1 and "table accuracy-default" in run.stdout,
          f"a changed number in accuracy-default was not caught:\n{run.stdout}{run.stderr}")
    subprocess.run([sys.executable, tables, doc], capture_output=True, text=True)
    check(open(doc).read() == text, "regenerating did not restore accuracy-default")

    # The data side: a copy of docs/data with one value changed at a time.
    data = os.path.join(tmp, "data")
    shutil.copytree(os.path.join(root, "docs", "data"), data)
    perf = os.path.join(tmp, "performance.md")
    shutil.copy(os.path.join(root, "docs", "performance.md"), perf)
    run = subprocess.run([sys.executable, tables, "--check", "--data", data, doc, perf],
                         capture_output=True, text=True)
    check(run.returncode == 0, f"the copied data gives other tables:\n{run.stdout}{run.stderr}")
    metrics_path = os.path.join(data, "accuracy", "default-lavapipe.json")
    original = open(metrics_path).read()

    def data_change(path, edit, tables_expected, what):
        before = open(path).read()
        open(path, "w").write(edit(before))
        r = subprocess.run([sys.executable, tables, "--check", "--data", data, doc, perf],
                           capture_output=True, text=True)
        named = [t for t in tables_expected if f"table {t}\n" in r.stdout + "\n"]
        check(r.returncode == 1 and named == tables_expected,
              f"{what}: expected stale {tables_expected}:\n{r.stdout}{r.stderr}")
        open(path, "w").write(before)

    def mean_abs(text):
        m = json.loads(text)
        m["lights"][0]["mean_abs"] *= 3
        return json.dumps(m)

    def excess(text):
        m = json.loads(text)
        m["flicker"]["translate-1cm"]["sun"]["excess_fraction"] += 0.01
        return json.dumps(m)

    def timing(text):
        m = json.loads(text)
        m["timings"]["passes"]["sun-shadow"] += 10
        return json.dumps(m)

    def commit(text):
        c = json.loads(text)
        c["default-lavapipe.json"]["commit"] = "0000000"
        return json.dumps(c)

    data_change(metrics_path, mean_abs, ["accuracy-default"], "a light's mean |dV|")
    data_change(metrics_path, excess, ["accuracy-default"], "an excess flicker")
    data_change(metrics_path, timing, ["accuracy-default", "frames"], "a pass's GPU ms")
    data_change(os.path.join(data, "accuracy", "commits.json"), commit,
                ["accuracy-runs", "accuracy-default", "frames"], "the commit measured at")
    tune = os.path.join(data, "tune", "space-h200-tune.json")
    data_change(tune, lambda t: t.replace('"point-shadow": 2.74432', '"point-shadow": 2.8'),
                ["frames"], "a tune run's defaults' pass time")
    check(open(metrics_path).read() == original, "the data copy was restored")

    # A data file the commits do not name is an error, not a row without a commit.
    shutil.copy(metrics_path, os.path.join(data, "accuracy", "default-h100.json"))
    r = subprocess.run([sys.executable, tables, "--check", "--data", data, doc],
                       capture_output=True, text=True)
    check(r.returncode != 0 and "commits.json" in r.stderr,
          f"a data file without its commit was accepted:\n{r.stdout}{r.stderr}")

sys.exit(1 if failures else 0)
