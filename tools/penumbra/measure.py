"""One configuration of a scene, measured by penumbra-reference: the GPU time per pass (Vulkan
timestamp queries, the median over frames, as penumbra-view renders them) and the metrics against
the ray-traced truth:
the still frame, and along a camera path with the temporal history running (the error along the
path, the flicker the truth does not have), acne, leaks and the contact gap per light."""
import csv
import json
import math
import os

from .build import run

# The objectives a point is scored on, all to minimise.
OBJECTIVES = {
    "ms": "GPU ms per frame (every pass: shadow maps, resolves, contact, temporal, lighting)",
    "path_error": "mean |V - truth| along the camera path, temporal history running",
    "flicker": "excess flicker: shadow-edge pixels that change where the truth holds still, "
               "over the truth's edge pixels",
    "acne": "false shadow with no caster in the filter's reach, of the clearly lit receivers "
            "(the worst light)",
    "gap": "contact gap in texels of the light's map (the worst light; 0 without a contact)",
}
# Differences below these are not differences (the frontier check's absolute floors).
FLOORS = {"path_error": 2e-4, "still_error": 2e-4, "flicker": 1e-3, "acne": 2e-4, "gap": 0.25,
          "ms": 0.0}


def setargs(sets):
    return [x for k, v in sorted(sets.items()) for x in ("--set", f"{k}={v}")]


# Timed frames draw every shadow map every frame (shadows.cache = false): what a cut, a light
# that moved or the first frame costs, the time a budget must hold; a still camera with the
# cache would time the maps at nothing. A point that sets shadows.cache = true is timed along
# WALK instead (2.3 cm a frame, 1.4 m/s at 60 frames/s), what the cache costs as the camera
# walks. The images, and so every metric, are the same either way (tests/frame/
# shadow_cache_tests.cpp); docs/performance.md has the cache's own measurements.
WALK = [("camera.move", "1.63,0,-1.63"), ("camera.move_frames", "100")]


def timing_sets(sets):
    """The (key, value) list a point's timed frames run with."""
    cache = dict(sets).get("shadows.cache")
    if cache is None:
        return list(sets) + [("shadows.cache", "false")]
    return list(sets) + (WALK if cache == "true" else [])


def measure(tools, scene, sets, work, size=None, frames=5, path="translate-1cm",
            path_frames=8, env=None):
    """Returns a dict: the objectives (OBJECTIVES), still_error, per-light details, the
    device and the passes' ms. One penumbra-reference run: the still frame, the path, then
    `frames` frames timed with a renderer as penumbra-view builds it (0: none, and ms is
    None). `env`: the tool's environment (default this process's)."""
    os.makedirs(work, exist_ok=True)
    size_arg = ["--size", size] if size else []
    rout = os.path.join(work, "reference")
    if frames and "shadows.cache" not in sets:
        sets = dict(sets, **{"shadows.cache": "false"})  # timing_sets: every map every frame
    run([tools.reference, "--scene", scene, "--out", rout, "--flicker", path, "--flicker-frames",
         str(path_frames), "--flicker-truth", "--no-images"] +
        (["--timing-frames", str(frames)] if frames else []) +
        size_arg +
        setargs(sets), env=env)
    with open(os.path.join(rout, "metrics.json")) as f:
        m = json.load(f)
    return score(m, m["timings"]["passes"] if frames else None, m["device"], path)


def score(m, passes, device, path):
    """The objectives from penumbra-reference's metrics.json and penumbra-view's pass times."""
    lights = m["lights"]
    weight = sum(l["receivers"] for l in lights)
    flick = m.get("flicker", {}).get(path, {})

    def weighted(rows):
        """The mean of (value, weight) pairs weighted by their weights; 0 with none."""
        w = sum(r[1] for r in rows)
        return sum(r[0] * r[1] for r in rows) / w if w else 0.0

    still = weighted([(l["mean_abs"], l["receivers"]) for l in lights])
    path_err = weighted([(flick[l["light"]]["path_mean_abs_error"], l["receivers"])
                                 for l in lights if l["light"] in flick])
    truth_edges = sum(v.get("truth_edge_pixels", 0) for v in flick.values())
    excess = sum(v.get("excess_changed", 0) for v in flick.values())

    def worst(key):
        vals = [l.get(key) for l in lights]
        vals = [v for v in vals if v is not None and math.isfinite(v)]
        return max(vals) if vals else 0.0

    return {
        "ms": sum(passes.values()) if passes is not None else None,
        "path_error": path_err,
        "flicker": excess / truth_edges if truth_edges else 0.0,
        "acne": worst("acne"),
        "gap": worst("contact_gap_texels"),
        "still_error": still,
        "leak": worst("leak"),
        "gap_map": worst("contact_gap_map_texels"),
        "receivers": weight,
        "seconds": m.get("seconds", {}),
        "device": device,
        "passes": passes,
        "lights": {l["light"]: {k: l.get(k) for k in
                                ("mean_abs", "acne", "leak", "contact_gap_texels",
                                 "contact_gap_map_texels",
                                 "contact_gap_world", "false_light", "false_shadow")}
                   for l in lights},
    }


def measure_bench(tools, scene, sets, work, size="", frames=10, flicker=(), env=None,
                  timed=True, move=None):
    """penumbra-bench's point: the GPU time per pass from penumbra-view --headless (the median of
    `frames` frames after one more; timed=False: none, passes {}), then penumbra-reference's
    metrics.json (with `flicker`, its --flicker arguments). `sets` is a list of (key, value);
    `move` (x, y, z) moves the whole scene (--move). Returns (passes, device, metrics)."""
    setargs = [x for k, v in sets for x in ("--set", f"{k}={v}")]
    timed_args = [x for k, v in timing_sets(sets) for x in ("--set", f"{k}={v}")]
    if move is not None:
        moved = ["--move", ",".join(repr(float(x)) for x in move)]
        setargs, timed_args = moved + setargs, moved + timed_args
    size_arg = ["--size", size] if size else []
    passes, device = {}, ""
    if timed:
        vout = os.path.join(work, "view")
        run([tools.view, "--headless", "--scene", scene, "--frames", str(frames + 1), "--view",
             "lit", "--out", vout] + size_arg + timed_args, env=env)
        with open(os.path.join(vout, "timings.csv")) as f:
            for row in csv.DictReader(f):
                passes[row["pass"]] = float(row["median_ms"])
                device = row["device"]
    rout = os.path.join(work, "reference")
    run([tools.reference, "--scene", scene, "--out", rout] + size_arg + setargs + list(flicker),
        env=env)
    with open(os.path.join(rout, "metrics.json")) as f:
        return passes, device, json.load(f)
