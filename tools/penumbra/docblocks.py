"""The docs' runnable examples: marked fenced blocks of README.md and docs/*.md, run in a scratch
copy of the tree, their claimed output checked (tools/penumbra-docs-check; docs/architecture.md,
"How the docs' examples are checked").

A marker is an HTML comment on its own line before a fenced block (GitHub shows neither the
comment nor anything of the marking); blank lines may come between:

    <!-- run -->                      the block is bash, run with `set -euo pipefail`
    <!-- run: timeout=120 exit=1 -->  its limit in seconds (default 60) and exit status (default 0)
    <!-- run: file=check.txt -->      the block is written to check.txt in the scratch directory
    <!-- run: output -->              the output (stdout and stderr) the run block above claims

A claimed output's lines must each be a whole line of the output, in that order; other lines may
come between them. `...` inside a line matches any text (a time, a path); a line that is only
`...` stands for lines left out and matches nothing by itself.

Each Markdown file gets one scratch directory, and its marked blocks run there in the file's
order, so a file block feeds the run blocks after it. The directory holds copies of shaders/,
scenes/, docs/ and tools/, and `build`, a link to the build (--build, else $PENUMBRA_BUILD, else
the tree's build/). HOME and TMPDIR point into it, so nothing a block writes lands in the tree."""
import difflib
import glob
import os
import re
import shlex
import shutil
import signal
import subprocess
import tempfile
import time

ROOT = os.path.abspath(os.path.join(os.path.dirname(os.path.realpath(__file__)), "..", ".."))
COPIED = ("shaders", "scenes", "docs", "tools")
DEFAULT_TIMEOUT = 60

_MARK = re.compile(r"^\s*<!--\s*run(?::(.*?))?\s*-->\s*$")
_FENCE = re.compile(r"^(\s*)(`{3,}|~{3,})")
_OPTIONS = {"run": {"timeout", "exit"}, "file": set(), "output": set()}


class DocError(Exception):
    """A marker that cannot be used as written; the message starts with file:line."""


class Block:
    def __init__(self, where, line, kind, options, text):
        self.where = where      # the Markdown file as shown in messages
        self.line = line        # the line of the opening fence
        self.kind = kind        # "run", "file" or "output"
        self.options = options  # run: timeout, exit; file: file
        self.text = text
        self.output = None      # run: its claimed output block

    def __str__(self):
        return f"{self.where}:{self.line}"


def _parse_marker(body, where, line):
    words = shlex.split(body or "")
    if words == ["output"]:
        return "output", {}
    options = {}
    for word in words:
        key, eq, value = word.partition("=")
        if not eq or not value:
            raise DocError(f"{where}:{line}: run marker: '{word}' is not KEY=VALUE (run: timeout=S "
                           "exit=N, run: file=NAME, run: output)")
        options[key] = value
    kind = "file" if "file" in options else "run"
    unknown = set(options) - _OPTIONS[kind] - ({"file"} if kind == "file" else set())
    if unknown:
        raise DocError(f"{where}:{line}: run marker: unknown option {', '.join(sorted(unknown))} "
                       f"for a {kind} block")
    if kind == "file":
        name = options["file"]
        if os.path.isabs(name) or ".." in name.split("/"):
            raise DocError(f"{where}:{line}: run marker: file={name} must be a relative path "
                           "inside the scratch directory")
    for key in ("timeout", "exit"):
        if key in options:
            try:
                options[key] = int(options[key])
            except ValueError:
                raise DocError(f"{where}:{line}: run marker: {key}={options[key]} is not an "
                               "integer") from None
    return kind, options


def parse(text, where):
    """The marked blocks of one Markdown file's text, each run block with its claimed output."""
    lines = text.splitlines()
    blocks, pending, fence = [], None, None
    i = 0
    while i < len(lines):
        line = lines[i]
        if fence is None:
            m = _MARK.match(line)
            if m:
                if pending:
                    raise DocError(f"{where}:{pending[0]}: run marker not followed by a fenced "
                                   "block")
                pending = (i + 1, *_parse_marker(m.group(1), where, i + 1))
            elif _FENCE.match(line):
                fence = _FENCE.match(line).group(2)
                start, body = i + 1, []
                i += 1
                while i < len(lines) and not lines[i].strip().startswith(fence):
                    body.append(lines[i])
                    i += 1
                if i == len(lines):
                    raise DocError(f"{where}:{start}: fenced block never closed")
                fence = None
                if pending:
                    indent = len(_FENCE.match(lines[start - 1]).group(1))
                    text_ = "\n".join(l[indent:] if l[:indent].isspace() else l for l in body)
                    block = Block(where, start, pending[1], pending[2], text_ + "\n")
                    if block.kind == "output":
                        if not blocks or blocks[-1].kind != "run" or blocks[-1].output:
                            raise DocError(f"{where}:{start}: an output block must follow a run "
                                           "block")
                        blocks[-1].output = block
                    else:
                        blocks.append(block)
                    pending = None
            elif line.strip() and pending:
                raise DocError(f"{where}:{pending[0]}: run marker not followed by a fenced block")
        i += 1
    if pending:
        raise DocError(f"{where}:{pending[0]}: run marker not followed by a fenced block")
    return blocks


def _pattern(claimed):
    return re.compile(".*?".join(re.escape(part) for part in claimed.split("...")))


def check_output(claimed, output):
    """None when every claimed line is a line of the output in order, else why not."""
    actual = [l.rstrip() for l in output.splitlines()]
    at = 0
    for number, want in enumerate(claimed.splitlines(), 1):
        want = want.rstrip()
        if not want or want == "...":
            continue
        pattern = _pattern(want)
        for j in range(at, len(actual)):
            if pattern.fullmatch(actual[j]):
                at = j + 1
                break
        else:
            close = difflib.get_close_matches(want, actual[at:], n=1, cutoff=0.5)
            hint = f"\n  closest line: {close[0]}" if close else ""
            earlier = "" if at == 0 else " after the lines matched before it"
            return f"claimed line {number} is not in the output{earlier}:\n  {want}{hint}"
    return None


def scratch_dir(parent, root, build):
    """A scratch copy of what the docs' commands use; returns its path."""
    work = tempfile.mkdtemp(prefix="docs-", dir=parent)
    for name in COPIED:
        src = os.path.join(root, name)
        if os.path.isdir(src):
            shutil.copytree(src, os.path.join(work, name), symlinks=True,
                            ignore=shutil.ignore_patterns("__pycache__"))
    os.symlink(os.path.abspath(build), os.path.join(work, "build"))
    for name in ("home", "tmp"):
        os.mkdir(os.path.join(work, name))
    return work


def _kill_group(pgid):
    try:
        os.killpg(pgid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        pass


def run_block(block, work, env):
    """Runs one run block in WORK; None when it does what it claims, else why not."""
    script = os.path.join(work, f".block-{block.line}.sh")
    # The block's text starts at the script's line 3, the doc's line block.line + 1; a command
    # that fails is named at its line of the doc.
    where = re.sub(r"[^\w./+-]", "_", block.where)
    trap = f"echo \"[docs] {where}:$((LINENO + {block.line - 2})): exit status $?\" >&2"
    with open(script, "w") as f:
        f.write(f"set -euo pipefail\ntrap '{trap}' ERR\n{block.text}")
    timeout = block.options.get("timeout", DEFAULT_TIMEOUT)
    proc = subprocess.Popen(["bash", "--noprofile", "--norc", script], cwd=work, env=env,
                            stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, start_new_session=True)
    try:
        out, _ = proc.communicate(timeout=timeout)
        timed_out = False
    except subprocess.TimeoutExpired:
        _kill_group(proc.pid)
        out, _ = proc.communicate()
        timed_out = True
    _kill_group(proc.pid)  # what the block left running in the background
    out = out.decode("utf-8", "replace")
    tail = "\n".join("  | " + l for l in out.rstrip().splitlines()[-25:])
    if timed_out:
        return f"did not finish within {timeout} s (timeout=); its output:\n{tail}"
    want = block.options.get("exit", 0)
    if proc.returncode != want:
        return f"exited {proc.returncode}, the doc expects {want}; its output:\n{tail}"
    if block.output:
        why = check_output(block.output.text, out)
        if why:
            return f"{why}\n(output claimed at {block.output}); the output:\n{tail}"
    return None


def block_env(work, build):
    env = dict(os.environ)
    env.update(HOME=os.path.join(work, "home"), TMPDIR=os.path.join(work, "tmp"),
               PENUMBRA_BUILD=os.path.abspath(build))
    return env


def shown(path, root=ROOT):
    """A Markdown file's name in messages: relative to the tree when it is inside it."""
    rel = os.path.relpath(path, root)
    return path if rel.startswith("..") else rel


def run_file(path, root=ROOT, build=None, parent=None, keep=False, log=print):
    """Runs the marked blocks of one Markdown file; returns (blocks run, failures), a failure
    being (block, why)."""
    build = build or os.environ.get("PENUMBRA_BUILD") or os.path.join(root, "build")
    where = shown(path, root)
    with open(path, encoding="utf-8") as f:
        blocks = parse(f.read(), where)
    if not blocks:
        return 0, []
    work = scratch_dir(parent, root, build)
    env = block_env(work, build)
    failures, ran = [], 0
    try:
        for block in blocks:
            if block.kind == "file":
                dest = os.path.join(work, block.options["file"])
                os.makedirs(os.path.dirname(dest), exist_ok=True)
                with open(dest, "w") as f:
                    f.write(block.text)
                continue
            ran += 1
            start = time.monotonic()
            why = run_block(block, work, env)
            took = time.monotonic() - start
            if why:
                failures.append((block, why))
                log(f"FAIL {block} ({took:.1f} s): {why}")
            else:
                log(f"ok   {block} ({took:.1f} s)")
    finally:
        if keep:
            log(f"scratch directory of {where}: {work}")
        else:
            shutil.rmtree(work, ignore_errors=True)
    return ran, failures


def doc_files(root=ROOT):
    """README.md and docs/*.md (docs/history is the record of past runs, not instructions)."""
    return [os.path.join(root, "README.md")] + sorted(glob.glob(os.path.join(root, "docs", "*.md")))
