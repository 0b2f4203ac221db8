#!/usr/bin/python3
"""penumbra-view --headless --watch --truth-flicker translate-1cm (issue 36): an edit of a copy of the shader tree that
widens the PCF kernel by one texel prints the sun's GPU-time and error deltas against the
ray-traced truth (the error grows, the image changes), and undoing the edit prints zero error
change since the start and an image bit-identical to it; a scene with no shadowed light says so.

usage: truth_deltas_test.py VIEW ROOT WORK_DIR"""
import os
import re
import shutil
import signal
import subprocess
import sys
import time

view, root, work = sys.argv[1:4]
shutil.rmtree(work, ignore_errors=True)
os.makedirs(work)
shaders = os.path.join(work, "shaders")
shutil.copytree(os.path.join(root, "shaders"), shaders)
pcf = os.path.join(shaders, "penumbra", "pcf.glsl")
NARROW = "  return clamp(radius, 0, kPcfMaxRadius);"
WIDE = "  return clamp(radius + 1, 0, kPcfMaxRadius);"
with open(pcf) as f:
    original = f.read()
if NARROW not in original:
    sys.exit(f"{pcf}: the line to edit ('{NARROW.strip()}') is gone; update this test")
env = dict(os.environ, PENUMBRA_REFERENCE_CACHE=os.path.join(work, "cache"))
log_path = os.path.join(work, "view.log")
log = open(log_path, "w")
p = subprocess.Popen([view, "--headless", "--watch", "--truth-flicker", "translate-1cm", "--scene",
                      "default", "--set",
                      "shadows.filter=pcf", "--size", "160x90", "--view", "lit", "--shader-dir",
                      shaders, "--out", os.path.join(work, "out")],
                     stdout=log, stderr=subprocess.STDOUT, env=env, cwd=work)


def text():
    with open(log_path) as f:
        return f.read()


def wait_for(pattern, count=1, timeout=600):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if len(re.findall(pattern, text(), re.M)) >= count:
            return True
        if p.poll() is not None:
            return False
        time.sleep(0.1)
    return False


def fail(what):
    if p.poll() is None:
        p.kill()
    sys.exit(f"{what}\n--- penumbra-view's output:\n{text()[-6000:]}")


def edit(content):
    with open(pcf + ".new", "w") as f:
        f.write(content)
    os.replace(pcf + ".new", pcf)


if not wait_for(r"^\[truth\] sun: mean \|dV\| [0-9.]+, .*, flicker [0-9.]+%, path error "):
    fail("no --truth baseline for the sun, with its flicker along translate-1cm")
edit(original.replace(NARROW, WIDE))
if not wait_for(r"^\[truth\] since the start", 1):
    fail("no deltas after the edit that widens the kernel")
out = text()
m = re.search(r"^\[truth\] sun: mean \|dV\| ([0-9.]+) -> ([0-9.]+)", out, re.M)
if not m or not float(m.group(2)) > float(m.group(1)):
    fail("the wider kernel did not raise the sun's mean |dV| against the truth")
if not re.search(r"^\[truth\] GPU [0-9.]+ -> [0-9.]+ ms per frame", out, re.M):
    fail("no GPU-time delta")
if not re.search(r"^\[truth\] sun: .*, flicker [0-9.]+ -> [0-9.]+%, path error ", out, re.M):
    fail("no flicker delta along the path")
if "image changed since the start" not in out:
    fail("the wider kernel left the image as it was")
# Each snapshot writes the light's error heat map (the baseline's, then this save's).
heat = os.path.join(work, "out", "truth-error.png")
if not wait_for(r"^\[truth\] error heat map: " + re.escape(heat), 2):
    fail("no error heat map written after the save")
with open(heat, "rb") as f:
    head = f.read(24)
if head[:8] != b"\x89PNG\r\n\x1a\n" or head[16:24] != (160).to_bytes(4, "big") + (90).to_bytes(4, "big"):
    fail(f"{heat} is not a 160x90 PNG")
edit(original)
if not wait_for(r"^\[truth\] since the start", 2):
    fail("no deltas after the edit was undone")
last = [l for l in text().splitlines() if l.startswith("[truth] since the start")][-1]
if not re.search(r"sun mean \|dV\| [+-]0\.00000; image bit-identical to the start", last):
    fail(f"undoing the edit did not give back the start: {last}")
p.send_signal(signal.SIGINT)
try:
    rc = p.wait(timeout=120)
except subprocess.TimeoutExpired:
    fail("penumbra-view did not stop on SIGINT")
if rc != 0:
    fail(f"penumbra-view exited {rc}")

# --truth needs --watch; a scene without a shadowed light has nothing to measure.
r = subprocess.run([view, "--headless", "--truth", "--scene", "default"], capture_output=True,
                   text=True, env=env, cwd=work)
if r.returncode == 0 or "--truth" not in r.stderr or "--watch" not in r.stderr:
    sys.exit(f"--truth without --watch was not refused:\n{r.stdout}{r.stderr}")
r = subprocess.run([view, "--headless", "--watch", "--truth-flicker", "sideways"],
                   capture_output=True, text=True, env=env, cwd=work)
if r.returncode == 0 or "no camera path 'sideways'" not in r.stderr:
    sys.exit(f"an unknown --truth-flicker path was not refused by name:\n{r.stderr}")
print("penumbra-view --truth: deltas after an edit, zero after undoing it")
