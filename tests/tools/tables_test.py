"""The frontier rule (penumbra.pareto.beaten_by) on cases that tell its margins apart, and the
docs' generated tables: tools/penumbra-tables --check passes on the docs as checked in and
fails, naming the table, on a copy with one number changed."""
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

sys.exit(1 if failures else 0)
