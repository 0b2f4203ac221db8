"""Where a tuning point is measured: on this machine (threads, each running penumbra-reference;
--jobs), or as tasks of a Dask cluster (--cluster), each asking for one slot of its device class.

Dask (Debian's python3-distributed) rather than Ray: Ray is not packaged for Debian, and Dask's
scheduler does what a sweep needs: worker resources (a custom resource per device class, so a
lavapipe point never lands on a GPU worker and a GPU point never on a lavapipe one), a task of a
worker that dies re-run on another, and results that come back to the one process that records
them as they finish.

A point is a spec (a dict): the scene, its settings, the size, path and frame counts, and the
configuration hash the client expects: the scene file's content hash, the settings and the
commit. The worker computes that hash again from its own scene file and commit and returns it
with the result; a point whose hash differs (a worker at another commit, or with another scene
file) is refused, not mixed in.

The truth of a scene and path does not depend on the shadow settings: in a cluster run it is
traced once per device class by a task of its own, and its files (the reference cache's, keyed by
the receivers they were traced for) travel with every point of that class, so a worker never
traces it again. Nothing here listens on a port: the scheduler and workers do
(tools/penumbra-cluster starts them on loopback or a private address only), and `local[:N]` starts
a cluster of N workers on 127.0.0.1 whose every port is bound to loopback."""
import hashlib
import json
import os
import socket
import tempfile
import threading

from . import build, scenefile
from .measure import measure, measure_bench

RESOURCE = "penumbra-{}"  # a worker's slots of a device class: penumbra-gpu, penumbra-lavapipe


def device_class():
    """This machine's device class, as PENUMBRA_DEVICE picks the device."""
    return os.environ.get("PENUMBRA_DEVICE") or "lavapipe"


def scene_ref(scene):
    """The scene as a worker finds it: relative to the checkout when inside it, else as is."""
    scene = os.path.abspath(scene)
    rel = os.path.relpath(scene, build.ROOT)
    return rel if not rel.startswith("..") else scene


def scene_path(ref):
    return ref if os.path.isabs(ref) else os.path.join(build.ROOT, ref)


# What a point's identity leaves out: where the scene is and its text (its hash stands for them),
# the commit (passed apart) and the hash itself.
_NOT_INPUTS = ("config_hash", "scene", "scene_hash", "commit")
# What the truth leaves out besides: the shadow settings and the timed frames.
_NOT_TRUTH = _NOT_INPUTS + ("sets", "frames")


def config_hash(spec, scene_hash, commit):
    """The configuration a point is measured for: the scene's content, the commit and the
    point's inputs (settings, size, frames, path or flicker arguments, kind)."""
    inputs = {k: v for k, v in spec.items() if k not in _NOT_INPUTS}
    key = json.dumps([scene_hash, commit, inputs], sort_keys=True)
    return hashlib.sha256(key.encode()).hexdigest()[:16]


def truth_key(spec):
    """The truth's identity: the scene and what the reference traces for it (size, path or
    flicker arguments), not the shadow settings."""
    truth = {k: v for k, v in spec.items() if k not in _NOT_TRUTH}
    key = json.dumps([spec["scene_hash"], truth], sort_keys=True)
    return hashlib.sha256(key.encode()).hexdigest()[:16]


def base_spec(scene, size, frames, path, path_frames):
    """What every penumbra-tune point of a run shares; point_spec adds a point's settings."""
    return {"scene": scene_ref(scene), "scene_hash": scenefile.content_hash(scene), "size": size,
            "frames": frames, "path": path, "path_frames": path_frames,
            "commit": build.git_commit()}


def bench_spec(scene, size, frames, flicker, move=None):
    """What a penumbra-bench point shares with the others of its scene. The scene file is found
    as penumbra-tune's are (in the worker's checkout, or at the same absolute path); `move`
    (x, y, z) moves the whole scene when the tools load it (--move)."""
    spec = {"kind": "bench", "size": size, "frames": frames, "flicker": list(flicker),
            "commit": build.git_commit(), "scene": scene_ref(scene),
            "scene_hash": scenefile.content_hash(scene)}
    if move is not None:
        spec["move"] = [float(x) for x in move]
    return spec


def point_spec(base, sets):
    """A point as the client asks for it, with the configuration hash it expects back."""
    spec = dict(base, sets=sets if isinstance(sets, list) else dict(sets))
    spec["config_hash"] = config_hash(spec, base["scene_hash"], base["commit"])
    return spec


def _truth_dir(spec):
    """A truth's own reference-cache folder on this machine: under PENUMBRA_REFERENCE_CACHE when
    set, else in the temporary directory (it outlives a run, so the next one traces nothing)."""
    root = os.environ.get("PENUMBRA_REFERENCE_CACHE") or os.path.join(
        tempfile.gettempdir(), f"penumbra-truth-{os.getuid()}")
    return os.path.join(root, "shared", truth_key(spec))


def _scene(spec, work):
    """The scene file on this machine, and its hash as the client computes it."""
    scene = scene_path(spec["scene"])
    return scene, scenefile.content_hash(scene)


def _measure(spec, scene, work, env, truth_only=False):
    tools = build.Tools()
    if spec.get("kind") == "bench":
        passes, device, metrics = measure_bench(tools, scene, [] if truth_only else spec["sets"],
                                                work, spec["size"], spec["frames"],
                                                spec["flicker"], env=env, timed=not truth_only,
                                                move=spec.get("move"))
        return {"passes": passes, "device": device, "metrics": metrics}
    return measure(tools, scene, {} if truth_only else spec["sets"], work,
                   size=spec["size"] or None, frames=0 if truth_only else spec["frames"],
                   path=spec["path"], path_frames=spec["path_frames"], env=env)


def run_point(spec, truth=None):
    """Measures one point (on a worker, or here): the result with the configuration hash this
    machine computes for it and the worker's host name; when `truth` (file name -> bytes) is
    given, those reference-cache files are installed first."""
    env = None
    if truth is not None:
        d = _truth_dir(spec)
        os.makedirs(d, exist_ok=True)
        for name, data in truth.items():
            target = os.path.join(d, os.path.basename(name))
            if not os.path.exists(target):
                with tempfile.NamedTemporaryFile(dir=d, delete=False) as f:
                    f.write(data)
                os.replace(f.name, target)
        env = dict(os.environ, PENUMBRA_REFERENCE_CACHE=d)
    with tempfile.TemporaryDirectory() as work:
        scene, scene_hash = _scene(spec, work)
        r = _measure(spec, scene, work, env)
    r["config_hash"] = config_hash(spec, scene_hash, build.git_commit())
    r["worker"] = socket.gethostname()
    return r


def trace_truth(spec):
    """The truth task: the scene at its own settings, untimed, into the truth's own cache folder;
    returns that folder's files (file name -> bytes) for the points of this device class."""
    d = _truth_dir(spec)
    os.makedirs(d, exist_ok=True)
    with tempfile.TemporaryDirectory() as work:
        scene, _ = _scene(spec, work)
        _measure(spec, scene, work, dict(os.environ, PENUMBRA_REFERENCE_CACHE=d), truth_only=True)
    files = {}
    for name in sorted(os.listdir(d)):
        if name.endswith(".pnref"):
            with open(os.path.join(d, name), "rb") as f:
                files[name] = f.read()
    return files


class ForeignResult(build.ToolError):
    """A worker measured another configuration than the one asked for."""


def check_result(spec, r):
    if r.get("config_hash") != spec["config_hash"]:
        raise ForeignResult(
            f"refused a point from worker {r.get('worker', '?')}: computed for configuration "
            f"{r.get('config_hash')}, asked for {spec['config_hash']} (commit {spec['commit']}, "
            f"scene {spec['scene']} hash {spec['scene_hash']}): the worker's checkout or scene "
            "file differs from this one")
    return r


class Here:
    """Points measured on this machine, `jobs` at once (the caller's threads)."""

    def __init__(self, jobs):
        self.slots = jobs
        self.where = f"this machine, {jobs} at once"

    def measure(self, spec):
        return check_result(spec, run_point(spec))

    def close(self):
        pass


class Cluster:
    """Points measured as tasks of a Dask cluster: `address` is a scheduler's (tcp://HOST:PORT),
    a scheduler file (JSON, as `dask scheduler --scheduler-file` writes), or local[:N] (N workers
    on 127.0.0.1, started and stopped here)."""

    def __init__(self, address, device):
        try:
            from dask.distributed import Client, LocalCluster
        except ImportError:
            raise build.ToolError("--cluster needs Dask (Debian: apt-get install "
                                  "python3-distributed; .ci/install-deps.sh installs it)")
        self.resource = RESOURCE.format(device)
        self.local = None
        if address == "local" or address.startswith("local:"):
            n = address.partition(":")[2] or "2"
            if not n.isdigit() or not 1 <= int(n) <= 256:
                raise build.ToolError(f"--cluster {address}: N must be 1 to 256")
            # Workers import this package: they find it as this process does.
            tools_dir = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
            os.environ["PYTHONPATH"] = os.pathsep.join(
                [tools_dir] + [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p])
            # Every port on loopback, the dashboards' too (Dask's default binds them to all
            # interfaces).
            self.local = LocalCluster(n_workers=int(n), threads_per_worker=1, processes=True,
                                      host="127.0.0.1", dashboard_address="127.0.0.1:0",
                                      worker_dashboard_address="127.0.0.1:0",
                                      resources={self.resource: 1})
            self.client = Client(self.local)
        elif address.endswith(".json"):
            self.client = Client(scheduler_file=address, timeout=30)
        else:
            self.client = Client(address, timeout=30)
        workers = self.client.scheduler_info()["workers"].values()
        self.slots = int(sum(w.get("resources", {}).get(self.resource, 0) for w in workers))
        if self.slots < 1:
            self.close()
            raise build.ToolError(
                f"--cluster {address}: no worker offers {self.resource} (start one with "
                f"tools/penumbra-cluster worker ADDRESS --device-class {device})")
        self.where = f"{self.client.scheduler.address}, {self.slots} {self.resource} slot(s)"
        self.truth = {}
        self.lock = threading.Lock()

    def measure(self, spec):
        key = truth_key(spec)
        with self.lock:
            if key not in self.truth:
                self.truth[key] = self.client.submit(trace_truth, spec, pure=False,
                                                     resources={self.resource: 1})
        future = self.client.submit(run_point, spec, self.truth[key], pure=False,
                                    resources={self.resource: 1})
        return check_result(spec, future.result())

    def close(self):
        self.client.close()
        if self.local is not None:
            self.local.close()


def executor(cluster, jobs, device):
    return Cluster(cluster, device) if cluster else Here(jobs)
