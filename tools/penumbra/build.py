"""Where the build's executables are: --build DIR, else $PENUMBRA_BUILD, else ROOT/build; in an
installed Penumbra (this package under <prefix>/share/penumbra/python), the prefix's bin/."""
import json
import os
import subprocess

_HERE = os.path.dirname(os.path.abspath(__file__))
_SHARE = os.path.dirname(os.path.dirname(_HERE))
# Installed: the package sits in <prefix>/share/penumbra/python with the shaders and scenes beside
# it (the scripts import it by their real path), so a moved prefix works.
INSTALLED = (os.path.basename(os.path.dirname(_HERE)) == "python" and
             os.path.isdir(os.path.join(_SHARE, "shaders", "render")))
# The folder whose scenes/ holds the shipped scenes: the source tree, or share/penumbra.
ROOT = _SHARE if INSTALLED else os.path.abspath(os.path.join(_HERE, "..", ".."))
BIN = os.path.abspath(os.path.join(_SHARE, "..", "..", "bin")) if INSTALLED else None


def default_build():
    """--build's default: $PENUMBRA_BUILD, else the prefix's bin/ (installed), else ROOT/build."""
    return os.environ.get("PENUMBRA_BUILD") or BIN or os.path.join(ROOT, "build")


def tool(build, name):
    """The executable `name` of `build`: a build tree (runtime/penumbra-view, tools/<name>) or a
    folder holding it (an installed prefix's bin/)."""
    flat = os.path.join(build, name)
    if os.path.isfile(flat):
        return flat
    return os.path.join(build, "runtime" if name == "penumbra-view" else "tools", name)


class ToolError(RuntimeError):
    """A tool of the build failed; the message has its command line and its output's tail."""


class Tools:
    def __init__(self, build=None):
        self.build = os.path.abspath(build or default_build())
        self.view = tool(self.build, "penumbra-view")
        self.reference = tool(self.build, "penumbra-reference")

    def check(self):
        missing = [t for t in (self.view, self.reference) if not os.access(t, os.X_OK)]
        if missing:
            raise ToolError(f"{', '.join(missing)} not built (PENUMBRA_TARGETS=\"penumbra-view "
                            "penumbra-reference\" .ci/build.sh, or --build DIR)")


def run(cmd, env=None):
    """Runs a tool; its stdout, or ToolError with the command and the last lines it printed."""
    r = subprocess.run(cmd, capture_output=True, text=True, env=env)
    if r.returncode != 0:
        tail = "\n".join((r.stdout + r.stderr).strip().splitlines()[-15:])
        raise ToolError(f"{' '.join(cmd)} exited {r.returncode}:\n{tail}")
    return r.stdout


def filter_names(view):
    """The filter table's names, in its order (penumbra-view --list-params: shadows.filter's
    choices)."""
    rows = json.loads(run([view, "--list-params"]))
    return next(r["choices"] for r in rows if r["key"] == "shadows.filter")


def filter_readers(rows):
    """{key: the filters that read it} from penumbra-view --list-params's rows."""
    return {r["key"]: set(r.get("filters", ())) for r in rows}


def git_commit(short="--short"):
    """$PENUMBRA_COMMIT (a copy of the tree without .git, on another machine), else git's; an
    installed Penumbra's is the one `cmake --install` recorded in share/penumbra/commit."""
    if os.environ.get("PENUMBRA_COMMIT"):
        return os.environ["PENUMBRA_COMMIT"]
    if INSTALLED:
        try:
            with open(os.path.join(ROOT, "commit")) as f:
                return f.read().strip() or "unknown"
        except OSError:
            return "unknown"
    try:
        return subprocess.run(["git", "-C", ROOT, "rev-parse", short, "HEAD"],
                              capture_output=True, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"
