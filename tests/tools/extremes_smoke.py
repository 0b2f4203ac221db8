"""The extremes matrix (tools/penumbra-extremes): the covering design covers every pair of levels
(and stops covering them without one of its cells); --quick runs CI's cells against the reference
with no NaN, no black pixels and finite metrics; a bad --cells is an error naming the cell.
Usage: extremes_smoke.py EXTREMES BUILD_DIR WORK_DIR"""
import csv
import importlib.machinery
import importlib.util
import itertools
import math
import os
import shutil
import subprocess
import sys

tool, build, work = sys.argv[1:4]
shutil.rmtree(work, ignore_errors=True)
os.makedirs(work)
failures = []


def check(ok, what):
    if not ok:
        failures.append(what)


loader = importlib.machinery.SourceFileLoader("penumbra_extremes", tool)
spec = importlib.util.spec_from_loader("penumbra_extremes", loader)
x = importlib.util.module_from_spec(spec)
loader.exec_module(x)


def missing_pairs(cells):
    names = [n for n, _ in x.FACTORS]
    levels = dict(x.FACTORS)
    missing = 0
    for p, q in itertools.combinations(names, 2):
        seen = {(c[p], c[q]) for c in cells}
        missing += sum(1 for a in levels[p] for b in levels[q] if (a, b) not in seen)
    return missing


cells = x.covering_array(x.FACTORS)
check(missing_pairs(cells) == 0, f"{missing_pairs(cells)} pairs of levels not covered")
full = math.prod(len(v) for _, v in x.FACTORS)
check(len(cells) < full / 100, f"{len(cells)} cells: not a covering design")
# Every cell is needed: without any one of them some pair goes uncovered... or at least one
# cell is; the greedy design has no redundant first cell.
check(missing_pairs(cells[1:]) > 0, "the first cell covers nothing new")
# The degenerate suns are levels, exactly.
check(any(x.sun_direction(c["elevation"]) == [0.0, -1.0, 0.0] for c in cells), "no sun overhead")
check(any(x.sun_direction(c["elevation"]) == [0.0, 1.0, 0.0] for c in cells), "no sun underneath")

out = os.path.join(work, "quick")
# Without the baseline row (the shipped scene, measured in full runs for comparison): CI's time.
r = subprocess.run([sys.executable, tool, "--quick", "--no-baseline", "--out", out, "--build",
                    build], capture_output=True, text=True)
check(r.returncode == 0, f"--quick exited {r.returncode}:\n{r.stdout}{r.stderr}")
csv_path = os.path.join(out, "extremes.csv")
if os.path.isfile(csv_path):
    with open(csv_path) as f:
        rows = list(csv.DictReader(f))
    quick = x.quick_cells(cells)
    check(len(rows) == len(quick), f"{len(rows)} rows, expected {len(quick)}")
    check({float(rw["elevation"]) for rw in rows} >= {90.0, -90.0}, "quick misses a degenerate sun")
    for rw in rows:
        check(rw["errors"] == "", f"cell {rw['cell']}: {rw['errors']}")
        check(rw["black_pixels"] == "0" and rw["rejected_pixels"] == "0",
              f"cell {rw['cell']}: black or rejected pixels")
        for key in ("mean_abs", "false_light", "false_shadow", "umbra_kept_lit", "flicker"):
            v = float(rw[key])
            check(math.isfinite(v) and 0.0 <= v <= 1.0, f"cell {rw['cell']}: {key} = {rw[key]}")
else:
    check(False, "extremes.csv missing")
for name in ("extremes.md", "extremes.json"):
    check(os.path.isfile(os.path.join(out, name)), f"{name} missing")

r = subprocess.run([sys.executable, tool, "--cells", "3,99", "--out", out, "--build", build],
                   capture_output=True, text=True)
check(r.returncode != 0 and "no cell 99" in r.stderr, f"--cells 3,99: {r.stderr}")

for f in failures:
    print("FAIL", f)
sys.exit(1 if failures else 0)
