#!/usr/bin/python3
"""penumbra-compile-bench (issue 36): it times new versions of a compute program (with
--dispatch their first dispatch too, on stand-in resources), and the sun resolve compiled with PENUMBRA_FILTERS_2D naming one filter is smaller SPIR-V than with every
filter (shadow_filter.glsl compiles no other case); --write-spirv writes the SPIR-V, and a .spv file is taken as it is; bad input is
refused by name.

  compile_bench_smoke.py BENCH
"""
import os
import re
import subprocess
import sys
import tempfile

bench = sys.argv[1]
failures = []


def check(ok, what):
    if not ok:
        failures.append(what)


def run(*args):
    return subprocess.run([bench, *args], capture_output=True, text=True, timeout=600)


ROW = re.compile(r"^(\S+)\s+([0-9.]+) KB\s+(-|[0-9.]+ \(\s*[0-9.]+-\s*[0-9.]+\))\s+"
                 r"([0-9.]+) \(\s*[0-9.]+-\s*[0-9.]+\)$")


def rows(out):
    return {m.group(1): m for m in (ROW.match(l) for l in out.splitlines()) if m}


out_all = ""
r = run("--program", "render/shadow_resolve.comp", "--program", "render/tonemap.comp",
        "--versions", "2")
out_all += r.stdout + r.stderr
check(r.returncode == 0, f"exit status {r.returncode}: {r.stderr}")
every = rows(r.stdout)
check(set(every) == {"render/shadow_resolve.comp", "render/tonemap.comp"},
      f"not one row per program: {r.stdout}")
check("2 new versions per program" in r.stdout, "the versions are not stated")

r = run("--program", "render/shadow_resolve.comp", "--versions", "2",
        "--define", "PENUMBRA_FILTERS_2D=1", "--spec", "0=0")
out_all += r.stdout + r.stderr
check(r.returncode == 0, f"exit status {r.returncode}: {r.stderr}")
hard = rows(r.stdout)
if "render/shadow_resolve.comp" in every and "render/shadow_resolve.comp" in hard:
    a = float(every["render/shadow_resolve.comp"].group(2))
    b = float(hard["render/shadow_resolve.comp"].group(2))
    check(b < 0.8 * a, f"PENUMBRA_FILTERS_2D=1 left the resolve at {b} KB of {a}")

# --dispatch: every binding of the sun resolve (uniform blocks, a depth-compare array, a storage
# image) gets a stand-in, the first dispatch of each version is timed, and the validation layer
# (on in the tests' environment, where any message fails the run) is content.
r = run("--program", "render/shadow_resolve.comp", "--versions", "2", "--dispatch",
        "--define", "PENUMBRA_FILTERS_2D=1", "--spec", "0=0")
out_all += r.stdout + r.stderr
DISPATCH = re.compile(r"^render/shadow_resolve\.comp\s+.*\)\s+([0-9.]+) \(\s*[0-9.]+-\s*[0-9.]+\)$",
                      re.M)
check(r.returncode == 0 and "first dispatch ms" in r.stdout and DISPATCH.search(r.stdout),
      f"--dispatch did not time the first dispatch: {r.stdout}{r.stderr}")
check("validation: 0 messages" in r.stdout, "the validation layer was off or reported messages")
# The EVSM2 moments' pass: push constants and an arrayed storage image get stand-ins too.
r = run("--program", "render/evsm_moments.comp", "--versions", "1", "--dispatch")
out_all += r.stdout + r.stderr
check(r.returncode == 0 and "validation: 0 messages" in r.stdout,
      f"--dispatch of evsm_moments.comp: {r.stdout}{r.stderr}")

# A .spv file: no glslang column. --write-spirv makes its directory.
with tempfile.TemporaryDirectory() as tmp:
    spv = os.path.join(tmp, "made", "tonemap.spv")
    r = run("--program", "render/tonemap.comp", "--versions", "1", "--write-spirv",
            os.path.join(tmp, "made"))
    check(r.returncode == 0 and os.path.getsize(spv) > 1000,
          f"--write-spirv wrote no SPIR-V: {r.stdout}{r.stderr}")
    r = run("--program", spv, "--versions", "2")
    out_all += r.stdout + r.stderr
    got = rows(r.stdout)
    check(r.returncode == 0 and spv in got and got[spv].group(3) == "-",
          f"a .spv file is not timed without glslang: {r.stdout}{r.stderr}")
    bad = os.path.join(tmp, "bad.spv")
    with open(bad, "wb") as f:
        f.write(b"\x03\x02\x23\x07" + b"\x00" * 7)
    r = run("--program", bad)
    check(r.returncode != 0 and "bad.spv: not SPIR-V" in r.stderr,
          f"a truncated .spv is not refused by name: {r.stderr}")

r = run("--program", "render/tonemap.comp", "--spec", "9=1", "--versions", "1")
check(r.returncode != 0 and "--spec 9=1: render/tonemap.comp has no specialization constant 9"
      in r.stderr, f"an unknown constant_id is not refused by name: {r.stderr}")
r = run("--program", "render/forward.frag")
check(r.returncode != 0 and "render/forward.frag: penumbra-compile-bench times compute programs"
      in r.stderr, f"a fragment stage is not refused by name: {r.stderr}")
r = run("--program", "render/nowhere.comp")
check(r.returncode != 0 and "nowhere.comp" in r.stderr,
      f"a missing program is not named: {r.stderr}")
r = run("--program", "render/tonemap.comp", "--spec", "x")
check(r.returncode == 2 and "--spec x: expected ID=VALUE" in r.stderr,
      f"a bad --spec is not refused by name: {r.stderr}")
r = run()
check(r.returncode == 2 and "no --program given" in r.stderr, "no --program is not refused")

if failures:
    print(out_all)
    for f in failures:
        print("FAILED:", f)
    sys.exit(1)
print("penumbra-compile-bench: versions timed, the filter set shrinks the resolve, bad input named")
