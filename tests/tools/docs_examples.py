"""The docs' runnable examples, run: the hot-reload script of docs/hot-reload.md (a broken edit
of pcf.glsl refused at its file:line, the fix rebuilding exactly the pipelines it names), on a
copy of the shader tree, so a doc that goes stale fails here. Usage: docs_examples.py VIEW ROOT
WORK_DIR"""
import os
import re
import shutil
import subprocess
import sys

view, root, work = sys.argv[1:4]
shutil.rmtree(work, ignore_errors=True)
os.makedirs(work)
with open(os.path.join(root, "docs", "hot-reload.md")) as f:
    doc = f.read()
m = re.search(r"An example that checks a broken edit[^\n]*\n+```\n(.*?)```", doc, re.S)
if not m:
    sys.exit("docs/hot-reload.md: the example script after 'An example that checks a broken "
             "edit' is gone")
script = os.path.join(work, "check.txt")
with open(script, "w") as f:
    f.write(m.group(1))
shaders = os.path.join(work, "sh")
shutil.copytree(os.path.join(root, "shaders"), shaders)
r = subprocess.run([view, "--headless", "--shader-dir", shaders, "--script", script], cwd=work,
                   capture_output=True, text=True, timeout=600)
if r.returncode != 0:
    sys.exit(f"docs/hot-reload.md's example script failed (exit {r.returncode}):\n{m.group(1)}\n"
             f"{r.stdout[-3000:]}{r.stderr[-3000:]}")
for png in ("before.png", "after.png"):
    if not os.path.isfile(os.path.join(work, png)):
        sys.exit(f"the example wrote no {png}")
print("docs/hot-reload.md: the example script runs as shown")
