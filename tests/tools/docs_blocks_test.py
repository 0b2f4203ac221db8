"""The docs' runnable blocks run as shown (tools/penumbra/docblocks.py): every marked block of
README.md and docs/*.md runs in a scratch copy of the tree against this build and its claimed
output is checked; docs/hot-reload.md's script is among them. First the runner is checked on a
small synthetic Markdown file: a wrong claimed output, a failing command, an unexpected exit
status, a block that never ends and a bad marker must each fail naming the file and line, and
a block's writes must land in the scratch copy, not in the tree.
Usage: docs_blocks_test.py ROOT BUILD WORK_DIR"""
import os
import shutil
import sys

root, build, work = (os.path.abspath(a) for a in sys.argv[1:4])
sys.path.insert(0, os.path.join(root, "tools"))
from penumbra import docblocks  # noqa: E402

shutil.rmtree(work, ignore_errors=True)
os.makedirs(work)
errors = []

SYNTHETIC = """# synthetic

<!-- run: file=notes/greeting.txt -->
```
hello from a file block
```

<!-- run -->
```sh
cat notes/greeting.txt
echo "took 12 ms"
touch shaders/written-by-a-doc-block
```
<!-- run: output -->
```text
hello from a file block
...
took ... ms
```

<!-- run -->
```sh
echo one
```
<!-- run: output -->
```text
two
```

<!-- run -->
```sh
echo before
false
echo after
```

<!-- run: exit=3 -->
```sh
exit 0
```

<!-- run: timeout=1 -->
```sh
sleep infinity
```

<!-- run -->
```sh
echo 'ordered'; echo 'claims'
```
<!-- run: output -->
```text
claims
ordered
```
"""
# The line of each block's opening fence above, and what its failure must say.
EXPECTED = {
    9: None,
    22: "claimed line 1 is not in the output:\n  two",
    31: "exited 1, the doc expects 0",
    38: "exited 0, the doc expects 3",
    43: "did not finish within 1 s",
    48: "claimed line 2 is not in the output after the lines matched before it",
}
synthetic = os.path.join(work, "synthetic.md")
with open(synthetic, "w") as f:
    f.write(SYNTHETIC)
lines = SYNTHETIC.splitlines()
for line in EXPECTED:
    if not lines[line - 1].startswith("```sh"):
        sys.exit(f"the test's own table is off: line {line} is {lines[line - 1]!r}")
log = []
ran, failures = docblocks.run_file(synthetic, root=root, build=build, parent=work,
                                   log=log.append)
got = {b.line: why for b, why in failures}
for line, want in EXPECTED.items():
    if want is None and line in got:
        errors.append(f"synthetic.md:{line} should pass: {got[line]}")
    elif want is not None and (line not in got or want not in got[line]):
        errors.append(f"synthetic.md:{line} should fail with '{want}', got: {got.get(line)}")
if ran != len(EXPECTED):
    errors.append(f"{ran} synthetic blocks ran, {len(EXPECTED)} expected")
where = docblocks.shown(synthetic, root)
for entry in log:
    if entry.startswith("FAIL") and not entry.startswith(f"FAIL {where}:"):
        errors.append(f"a failure that does not name the file:line: {entry[:200]}")
if "  | before" not in got.get(31, "") or "  | after" in got.get(31, ""):
    errors.append(f"the failing block did not stop at the failure (set -e): {got.get(31)}")
if f"[docs] {where}:33: exit status 1" not in got.get(31, ""):
    errors.append(f"the failing command is not named at synthetic.md:33: {got.get(31)}")
if os.path.exists(os.path.join(root, "shaders", "written-by-a-doc-block")):
    os.remove(os.path.join(root, "shaders", "written-by-a-doc-block"))
    errors.append("a doc block wrote into the source tree's shaders/")
for text, why in [
    ("<!-- run: timeout=5s -->\n```sh\ntrue\n```\n", "x.md:1: run marker: timeout=5s is not"),
    ("<!-- run: retries=2 -->\n```sh\ntrue\n```\n", "x.md:1: run marker: unknown option"),
    ("<!-- run -->\nsome text\n```sh\ntrue\n```\n", "x.md:1: run marker not followed"),
    ("```sh\ntrue\n```\n<!-- run: output -->\n```\nx\n```\n", "x.md:5: an output block must"),
    ("<!-- run: file=../x -->\n```\nx\n```\n", "x.md:1: run marker: file=../x must be"),
]:
    try:
        docblocks.parse(text, "x.md")
        errors.append(f"a bad marker was accepted, expected '{why}'")
    except docblocks.DocError as e:
        if not str(e).startswith(why):
            errors.append(f"bad marker: expected '{why}', got '{e}'")
if errors:
    sys.exit("the runner of the docs' blocks is broken:\n" + "\n".join(errors))
print(f"the runner: {len(EXPECTED)} synthetic blocks, each failure named as expected")

# The docs themselves.
total, failed, per_doc = 0, [], {}
for path in docblocks.doc_files(root):
    n, failures = docblocks.run_file(path, root=root, build=build, parent=work)
    total += n
    failed += failures
    if n:
        per_doc[os.path.relpath(path, root)] = n
with open(os.path.join(root, "docs", "hot-reload.md"), encoding="utf-8") as f:
    hot = docblocks.parse(f.read(), "docs/hot-reload.md")
if not any(b.kind == "file" and b.options["file"] == "check.txt" and "expect_rebuilt" in b.text
           for b in hot):
    failed.append(("docs/hot-reload.md", "its example script (check.txt) is no longer marked"))
print("blocks run per doc: " + ", ".join(f"{d} {n}" for d, n in per_doc.items()))
if failed:
    sys.exit(f"{len(failed)} of {total} doc blocks failed:\n" +
             "\n".join(f"{b}: {why}" for b, why in failed))
print(f"all {total} doc blocks ran as their docs say")
