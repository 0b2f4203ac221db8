"""Scene files: read with tomllib (what a scene models), and patched in place: keys of the
singleton tables ([shadows], [contact], ...) set to new values, every other line and comment kept,
written atomically (a temporary file renamed over the old one), so a failure leaves the old file
whole."""
import hashlib
import json
import os
import re
import tempfile
import tomllib

from . import build


class SceneError(ValueError):
    """A scene file that cannot be used; the message names the file (and line where known)."""


def find(name):
    """A shipped scene's name ("default") or a file's path -> an absolute path."""
    if os.path.isfile(name):
        return os.path.abspath(name)
    path = os.path.join(build.ROOT, "scenes", name + ".toml")
    if os.path.isfile(path):
        return path
    shipped = sorted(f[:-5] for f in os.listdir(os.path.join(build.ROOT, "scenes"))
                     if f.endswith(".toml"))
    raise SceneError(f"{name}: no such file, and not a shipped scene ({', '.join(shipped)})")


def load(path):
    try:
        with open(path, "rb") as f:
            return tomllib.load(f)
    except OSError as e:
        raise SceneError(f"{path}: {e.strerror}") from e
    except tomllib.TOMLDecodeError as e:
        raise SceneError(f"{path}: {e}") from e


class Features:
    """What a scene models: the sun, its spot and point lights (shadowed or not, own filters),
    contact shadows."""

    def __init__(self, data):
        self.sun = "sun" in data
        self.spots = list(data.get("spot", []))
        self.points = list(data.get("point", []))
        self.contact = "contact" in data
        self.shadowed_spots = [s for s in self.spots if s.get("shadows", True)]
        self.shadowed_points = [p for p in self.points if p.get("shadows", True)]

    @property
    def lights(self):
        return int(self.sun) + len(self.spots) + len(self.points)

    @property
    def scene_filter_used(self):
        """shadows.filter matters: the sun uses it, and so does every shadowed spot or point
        light without a filter of its own."""
        return self.sun or any("filter" not in l
                               for l in self.shadowed_spots + self.shadowed_points)


HEADER = re.compile(r"^\s*\[([A-Za-z_][A-Za-z0-9_]*)\]\s*(#.*)?$")
ANY_HEADER = re.compile(r"^\s*\[")


def content_hash(path):
    """A scene's identity for stored results: its values, not its comments or layout, and not
    its [tune] budget (which changes a pick, not a measurement)."""
    content = {k: v for k, v in load(path).items() if k != "tune"}
    return hashlib.sha256(json.dumps(content, sort_keys=True, default=str)
                          .encode()).hexdigest()[:12]


def tune_limits(data):
    """The max_* limits of a scene's [tune] table (objective -> value): a point that misses one
    is no choice for the scene, so it beats no settings."""
    return {k[len("max_"):]: float(v) for k, v in data.get("tune", {}).items()
            if k.startswith("max_")}


def toml_value(value):
    """A Python value as TOML writes it."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return repr(float(f"{value:.6g}"))
    return '"' + str(value).replace("\\", "\\\\").replace('"', '\\"') + '"'


def patched_text(text, values, note=""):
    """text with each "table.name" of `values` set (replacing its line, or added to its table,
    or the table added at the end); `note` as a comment on each line written."""
    lines = text.splitlines()
    suffix = f"  # {note}" if note else ""
    for key, value in values.items():
        table, name = key.split(".", 1)
        line = f"{name} = {toml_value(value)}{suffix}"
        start = next((i for i, l in enumerate(lines)
                      if (m := HEADER.match(l)) and m.group(1) == table), None)
        if start is None:
            lines += ["", f"[{table}]", line]
            continue
        end = next((i for i in range(start + 1, len(lines)) if ANY_HEADER.match(lines[i])),
                   len(lines))
        own = re.compile(rf"^\s*{re.escape(name)}\s*=")
        at = next((i for i in range(start + 1, end) if own.match(lines[i])), None)
        if at is not None:
            lines[at] = line
        else:
            last = max((i for i in range(start, end) if lines[i].strip() and
                        not lines[i].lstrip().startswith("#")), default=start)
            lines.insert(last + 1, line)
    return "\n".join(lines) + "\n"


def write_atomic(path, text):
    """Writes text to path through a temporary file in the same folder, renamed over it."""
    folder = os.path.dirname(os.path.abspath(path))
    fd, tmp = tempfile.mkstemp(prefix=".penumbra-", suffix=".tmp", dir=folder)
    try:
        with os.fdopen(fd, "w") as f:
            f.write(text)
            f.flush()
            os.fsync(f.fileno())
        if os.path.exists(path):
            os.chmod(tmp, os.stat(path).st_mode & 0o777)
        else:  # a new file as open() makes one (mkstemp's are private to their owner)
            umask = os.umask(0)
            os.umask(umask)
            os.chmod(tmp, 0o666 & ~umask)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
