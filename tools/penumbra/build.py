"""Where the build's executables are: --build DIR, else $PENUMBRA_BUILD, else ROOT/build."""
import os
import subprocess

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))


class ToolError(RuntimeError):
    """A tool of the build failed; the message has its command line and its output's tail."""


class Tools:
    def __init__(self, build=None):
        self.build = os.path.abspath(build or os.environ.get("PENUMBRA_BUILD") or
                                     os.path.join(ROOT, "build"))
        self.view = os.path.join(self.build, "runtime", "penumbra-view")
        self.reference = os.path.join(self.build, "tools", "penumbra-reference")

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


def git_commit():
    """$PENUMBRA_COMMIT (a copy of the tree without .git, on another machine), else git's."""
    if os.environ.get("PENUMBRA_COMMIT"):
        return os.environ["PENUMBRA_COMMIT"]
    try:
        return subprocess.run(["git", "-C", ROOT, "rev-parse", "--short", "HEAD"],
                              capture_output=True, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"
