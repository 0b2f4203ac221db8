"""tools/penumbra-coverage on hand-written tracefiles: the merge adds counts across files, the
table and --uncovered say what was not run, --summary-csv writes the per-file numbers, a floor
fails with status 1, and bad input (no tracefiles, a bad floor) with status 2."""
import os
import subprocess
import sys
import tempfile

root = sys.argv[1]
tool = os.path.join(root, "tools", "penumbra-coverage")
failures = []


def check(ok, what):
    if not ok:
        failures.append(what)
        print("FAILED:", what)


with tempfile.TemporaryDirectory() as tmp:
    glsl = os.path.join(tmp, "lib", "f.glsl")
    os.makedirs(os.path.dirname(glsl))
    with open(glsl, "w") as f:
        f.write("int f(int x) {\n  if (x > 0) {\n    return 1;\n  }\n  return 0;\n}\n")
    traces = os.path.join(tmp, "traces")
    os.makedirs(traces)

    def trace(name, hits_positive, hits_other):
        calls = hits_positive + hits_other
        with open(os.path.join(traces, name), "w") as f:
            f.write(f"TN:\nSF:{glsl}\nFN:1,f(int)\nFNDA:{calls},f(int)\nFNF:1\nFNH:{int(calls > 0)}\n"
                    f"BRDA:2,0,0,{hits_positive if calls else '-'}\n"
                    f"BRDA:2,0,1,{hits_other if calls else '-'}\nBRF:2\nBRH:0\n"
                    f"DA:1,{calls}\nDA:2,{calls}\nDA:3,{hits_positive}\nDA:5,{hits_other}\n"
                    "LF:4\nLH:0\nend_of_record\n")

    # Process one ran only positive inputs, process two only others: together, everything.
    trace("a.1.info", 5, 0)
    trace("b.2.info", 0, 0)

    def run(*args):
        return subprocess.run([sys.executable, tool, *args], capture_output=True, text=True,
                              cwd=tmp)

    r = run(traces, "--uncovered", "--min-lines", "80")
    check(r.returncode == 1, f"a floor above 75% fails (status {r.returncode}): {r.stderr}")
    check("lib/f.glsl" in r.stdout and "75.0%" in r.stdout, "3 of 4 lines: 75.0%\n" + r.stdout)
    check("lib/f.glsl:5: line: return 0;" in r.stdout, "the line not run is listed\n" + r.stdout)
    check("lib/f.glsl:2: branch 0 never false" in r.stdout, "the side not taken is listed")
    check("below the floor 80%" in r.stderr, "the floor message\n" + r.stderr)

    trace("c.3.info", 0, 2)
    csv_path = os.path.join(tmp, "summary.csv")
    r = run(traces, "--min-lines", "100", "--min-branches", "100", "--summary-csv", csv_path,
            "--html", os.path.join(tmp, "html"), "--include", "/lib/")
    check(r.returncode == 0, f"merged, everything ran (status {r.returncode}): {r.stdout}{r.stderr}")
    with open(csv_path) as f:
        check(f.read() == "file,lines_hit,lines,branches_hit,branches,functions_hit,functions\n"
              "lib/f.glsl,4,4,2,2,1,1\n", "the summary CSV")
    check(os.path.exists(os.path.join(tmp, "html", "index.html")), "genhtml wrote index.html")

    r = run(os.path.join(tmp, "empty-dir-that-is-not-there"))
    check(r.returncode == 2 and "no such file" in r.stderr, "a missing input: status 2")
    os.makedirs(os.path.join(tmp, "empty"))
    r = run(os.path.join(tmp, "empty"))
    check(r.returncode == 2 and "no tracefiles" in r.stderr, "no tracefiles: status 2")
    r = run(traces, "--min-lines", "120")
    check(r.returncode == 2 and "--min-lines 120" in r.stderr, "a floor over 100: status 2")
    r = run(traces, "--include", "/nothing-matches/")
    check(r.returncode == 2, f"--include matching nothing: status 2 ({r.returncode}) {r.stderr}")

sys.exit(1 if failures else 0)
