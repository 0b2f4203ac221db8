"""penumbra-bench's runs: the points log a run appends to as it goes (a stopped run resumes
from it), shards of one run and their merge."""
import hashlib
import json
import os
import sys

from .bench_report import plot_and_report, write_csv
from .scenefile import write_atomic

POINTS_LOG = "points.jsonl"


def point_key(index, point):
    """A point by its place in the run and what it measures (scene, configuration, settings)."""
    label, path, base, name, sets = point
    with open(path, "rb") as f:  # an edited scene file is another point
        scene_hash = hashlib.sha256(f.read()).hexdigest()[:16]
    return f"{index}|{label}|{scene_hash}|{name}|" + ";".join(f"{k}={v}" for k, v in base + sets)


def read_points(path):
    """POINTS_LOG: its run header and the finished points by key (a torn last line, from a run
    killed while writing it, is left out)."""
    header, done = None, {}
    with open(path) as f:
        for n, line in enumerate(f):
            try:
                entry = json.loads(line)
            except json.JSONDecodeError:
                continue
            if n == 0:
                header = entry.get("run")
            elif "key" in entry:
                done[entry["key"]] = entry
    return header, done


def parse_shard(text):
    """"I/N" -> (I - 1, N), or None."""
    if not text:
        return None
    try:
        i, n = (int(x) for x in text.split("/"))
    except ValueError:
        sys.exit(f"penumbra-bench: --shard {text}: expected I/N, e.g. 1/4")
    if not 1 <= i <= n:
        sys.exit(f"penumbra-bench: --shard {text}: I must be in [1, N]")
    return i - 1, n


def merge_runs(dirs, out):
    """The shards' points into one run's tables, plots and report. Runs measured with other
    settings or at another commit are refused, and so is a point that two shards both hold."""
    header, merged, rate = None, {}, None
    for d in dirs:
        h, done = read_points(os.path.join(d, POINTS_LOG))
        if header is None:
            header = h
        elif h != header:
            sys.exit(f"penumbra-bench: --merge: {d} was measured with {h}, {dirs[0]} with "
                     f"{header}; only runs of the same settings and commit merge")
        for key, entry in done.items():
            if key in merged:
                sys.exit(f"penumbra-bench: --merge: point {key} is in two of the runs")
            merged[key] = entry
        if rate is None and os.path.isfile(os.path.join(d, "texel_rate.json")):
            with open(os.path.join(d, "texel_rate.json")) as f:
                rate = json.load(f)
    if not merged:
        sys.exit("penumbra-bench: --merge: no finished point in " + ", ".join(dirs))
    rows = sorted((r for e in merged.values() for r in e["rows"]), key=lambda r: r["point"])
    os.makedirs(out, exist_ok=True)
    write_csv(rows, out)
    first = next(iter(merged.values()))
    meta = {"device": first["device"], "driver": first["driver"], "commit": header["commit"],
            "frames": header["frames"], "size": header["size"],
            "complete": len(merged) == header["points"], "shard": None,
            "gfetch_per_s": (rate or {}).get("kinds", {}).get("compare", {}).get("gfetch_per_s"),
            "flicker_frames": header["flicker_frames"] if header["flicker"] != "none" else 0,
            "texel_rate": rate or {}, "merged_from": dirs}
    write_atomic(os.path.join(out, "bench.json"), json.dumps({"meta": meta, "rows": rows},
                                                             indent=1))
    plot_and_report(rows, out, meta)
    print(f"penumbra-bench: merged {len(merged)} of {header['points']} points from "
          f"{len(dirs)} run(s) into {out}")
