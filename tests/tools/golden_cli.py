"""penumbra-golden from the command line: list names the cases and their device classes;
update never runs without naming its cases; --dry-run writes the review and leaves the goldens
as they were; update rewrites a golden that then passes check; a damaged golden is an error
naming the file; an unknown case names the cases file. Works on a copy of tests/golden
($PENUMBRA_GOLDEN_DIR): nothing here writes into the source tree.
Usage: golden_cli.py PENUMBRA_GOLDEN_BINARY SOURCE_GOLDEN_DIR WORK_DIR"""
import hashlib
import os
import shutil
import subprocess
import sys

tool, source, work = (os.path.abspath(p) for p in sys.argv[1:4])
shutil.rmtree(work, ignore_errors=True)
golden = os.path.join(work, "golden")
# Only the default case's goldens (every class), with the real cases file.
os.makedirs(golden)
shutil.copy(os.path.join(source, "cases.toml"), golden)
for cls in os.listdir(source):
    if os.path.isdir(os.path.join(source, cls, "default")):
        shutil.copytree(os.path.join(source, cls, "default"), os.path.join(golden, cls, "default"))
env = dict(os.environ, PENUMBRA_GOLDEN_DIR=golden)
failures = []


def check(ok, what):
    if not ok:
        failures.append(what)


def run(*args):
    return subprocess.run([tool, *args], capture_output=True, text=True, env=env, cwd=work)


def digest(path):
    h = hashlib.sha256()
    for root, _, files in sorted(os.walk(path)):
        for f in sorted(files):
            with open(os.path.join(root, f), "rb") as fh:
                h.update(f.encode() + fh.read())
    return h.hexdigest()


r = run("list")
check(r.returncode == 0 and "default" in r.stdout and "lavapipe" in r.stdout,
      f"list: {r.returncode} {r.stdout}{r.stderr}")
r = run("update")
check(r.returncode == 1 and "never runs implicitly" in r.stderr, f"update alone: {r.stderr}")
r = run("check", "--case", "nope")
check(r.returncode == 1 and "no case 'nope'" in r.stderr and "cases.toml" in r.stderr,
      f"check --case nope: {r.stderr}")

device_dirs = [d for d in os.listdir(golden) if os.path.isdir(os.path.join(golden, d))]
before = digest(golden)
r = run("update", "--case", "default", "--dry-run", "--no-cache", "--samples", "16",
        "--review", os.path.join(work, "review"))
check(r.returncode == 0 and "--dry-run" in r.stdout, f"update --dry-run: {r.stdout}{r.stderr}")
check(digest(golden) == before, "update --dry-run changed the goldens")
check(os.path.isfile(os.path.join(work, "review", "default", "index.html")),
      "update --dry-run wrote no review page")

# Which class is this device? The line "device class X" of any GPU command.
cls = next((line.rsplit(" ", 1)[1] for line in r.stdout.splitlines()
            if "device class" in line), None)
check(cls is not None, f"no device class in: {r.stdout}")
if cls:
    target = os.path.join(golden, cls, "default")
    shutil.rmtree(target, ignore_errors=True)
    r = run("update", "--case", "default", "--no-cache", "--samples", "16", "--review",
            os.path.join(work, "review"))
    check(r.returncode == 0 and os.path.isfile(os.path.join(target, "golden.toml")),
          f"update: {r.stdout}{r.stderr}")
    r = run("check", "--case", "default", "--report", os.path.join(work, "report"))
    check(r.returncode == 0 and "default: passed" in r.stdout, f"check after update: {r.stdout}")
    # A damaged golden: an error naming the file, not a pass or a crash.
    with open(os.path.join(target, "visibility-sun.png"), "wb") as f:
        f.write(b"not a png")
    r = run("check", "--case", "default", "--report", os.path.join(work, "report"))
    check(r.returncode == 1 and "visibility-sun.png" in r.stderr, f"damaged: {r.stderr}")

for f in failures:
    print("FAIL", f)
sys.exit(1 if failures else 0)
