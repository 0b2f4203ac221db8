#!/usr/bin/python3
"""penumbra-reload-bench --all on two files (issue 36): each file's new-code edit is chosen so it
changes a pipeline's SPIR-V when the file has a float literal (tonemap.comp), and a file without
one gets a comment whose row says the SPIR-V did not change (finite.glsl); both are measured in
the default scene; a file outside penumbra/ and render/ is refused naming it.

  reload_bench_smoke.py BENCH
"""
import subprocess
import sys

bench = sys.argv[1]
failures = []


def check(ok, what):
    if not ok:
        failures.append(what)


def run(*args):
    return subprocess.run([bench, *args], capture_output=True, text=True, timeout=600)


r = run("--all", "--file", "render/tonemap.comp", "--file", "penumbra/finite.glsl",
        "--modes", "new-change", "--edits", "2", "--size", "64x36")
out = r.stdout + r.stderr
check(r.returncode == 0, f"exit status {r.returncode}")
lines = out.splitlines()
row = {name: next((l for l in lines if l.strip().startswith(name) and "new code, on change" in l), "")
       for name in ("render/tonemap.comp", "penumbra/finite.glsl")}
check("scene default at 64x36" in out, "the files are not measured in the default scene")
check(any("render/tonemap.comp" in l and "edit: the literal" in l for l in lines),
      "tonemap.comp's edit is not one of its float literals")
check(row["render/tonemap.comp"] and "rebuilt: tonemap" in row["render/tonemap.comp"]
      and "SPIR-V unchanged" not in row["render/tonemap.comp"],
      "tonemap.comp's edit did not reach the tonemap pipeline's SPIR-V")
check(any("penumbra/finite.glsl" in l and "edit: a comment" in l for l in lines),
      "finite.glsl (no float literal) does not get a comment")
check(row["penumbra/finite.glsl"].endswith("(SPIR-V unchanged)"),
      "finite.glsl's comment edit does not say the SPIR-V did not change")
check("validation: 0 messages" in out, "the validation layer was off or reported messages")

r = run("--all", "--file", "nowhere.glsl", "--edits", "2")
check(r.returncode != 0 and "--file nowhere.glsl: not a file of the tree's penumbra/ or render/"
      in r.stderr, f"a foreign --file is not refused by name: {r.stderr}")
r = run("--modes", "new-loop,sideways")
check(r.returncode != 0 and "--modes sideways: expected one of" in r.stderr,
      f"a bad mode is not refused by name: {r.stderr}")

if failures:
    print(out)
    for f in failures:
        print("FAILED:", f)
    sys.exit(1)
print("penumbra-reload-bench --all: edits chosen and measured as expected")
