"""penumbra-bench's results: bench.csv, the Pareto frontier of GPU time against error per scene,
the roofline and flicker tables, the plots (matplotlib when present) and report.md."""
import csv
import math
import os
import sys

from .scenefile import write_atomic

# The filters before the table's names were recorded in bench.json's meta ("filters").
FILTER_CONFIGS = ("defaults", "hard", "pcf", "poisson", "pcss", "evsm2")


def write_csv(rows, out):
    with open(os.path.join(out, "bench.csv.tmp"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        w.writeheader()
        w.writerows(rows)
    os.replace(os.path.join(out, "bench.csv.tmp"), os.path.join(out, "bench.csv"))


def frontier(points):
    """Indices of the Pareto frontier of (cost, error) points, both lower-is-better."""
    order = sorted(range(len(points)), key=lambda i: (points[i][0], points[i][1]))
    best, out = math.inf, []
    for i in order:
        if points[i][1] < best:
            out.append(i)
            best = points[i][1]
    return out


def summarize(rows):
    """Per scene and configuration: receiver-weighted mean |dV| over the lights, shadow ms."""
    by = {}
    for r in rows:
        k = (r["scene"], r["config"])
        e = by.setdefault(k, {"scene": r["scene"], "config": r["config"], "shadow_ms": r["shadow_ms"],
                              "frame_ms": r["frame_ms"], "w": 0, "err": 0.0, "default": r["default"]})
        e["w"] += r["receivers"]
        e["err"] += r["mean_abs"] * r["receivers"]
    out = []
    for e in by.values():
        e["mean_abs"] = e["err"] / e["w"] if e["w"] else float("nan")
        out.append(e)
    return out


def plot_and_report(rows, out, meta):
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        plt = None
        sys.stderr.write("penumbra-bench: no matplotlib (Debian: python3-matplotlib): no plots; "
                         "the report has the tables (--replot DIR draws them later)\n")

    summary = summarize(rows)
    lines = [f"# penumbra-bench: {meta['device']}", "",
             f"Commit {meta['commit']}, driver {meta['driver']}, {meta['size'] or 'scene sizes'}, "
             f"median GPU ms of {meta['frames']} frames (timestamp queries); error: the "
             "receiver-weighted mean |ΔV| over the scene's lights against the ray-traced reference.",
             ""]
    for scene in dict.fromkeys(s["scene"] for s in summary):
        pts = [s for s in summary if s["scene"] == scene and math.isfinite(s["mean_abs"])]
        if not pts:
            continue
        xy = [(max(p["shadow_ms"], 1e-4), max(p["mean_abs"], 1e-6)) for p in pts]
        front = frontier(xy)
        fx = [xy[i][0] for i in front]
        fy = [xy[i][1] for i in front]
        dflt = [i for i, p in enumerate(pts) if p["default"]]
        lines += [f"## {scene}", ""]
        if plt is not None:
            draw(plt, scene, meta, pts, xy, fx, fy, dflt, out)
            lines += [f"![{scene}]({scene}.png)", ""]
        lines += ["| configuration | shadow ms | frame ms | mean \\|ΔV\\| | on the frontier |",
                  "|---|---|---|---|---|"]
        for i, p in sorted(enumerate(pts), key=lambda t: t[1]["shadow_ms"]):
            tag = "yes" if i in front else ""
            lines.append(f"| {p['config']}{' (default)' if p['default'] else ''} | "
                         f"{p['shadow_ms']:.3f} | {p['frame_ms']:.3f} | {p['mean_abs']:.4f} | {tag} |")
        for i in dflt:
            x, y = xy[i]
            # Within 5% of the frontier's error at equal (or lower) cost counts as on it.
            best = min((fy_ for fx_, fy_ in zip(fx, fy) if fx_ <= x), default=math.inf)
            verdict = ("on the frontier" if i in front or y <= 1.05 * best else
                       f"**dominated**: the frontier reaches {best:.4f} at no more cost")
            lines += ["", f"Default: {verdict}."]
        lines += [""] + roofline_table(rows, scene, meta) + flicker_table(rows, scene, meta)
        lines.append("")
    write_atomic(os.path.join(out, "report.md"), "\n".join(lines) + "\n")


def parse_flicker(text):
    """{path: (changed, edge_pixels, excess_changed, truth_edge_pixels)} from a row's flicker
    column; the last two are None where the truth was not traced (--no-flicker-truth)."""
    out = {}
    for item in filter(None, (text or "").split(";")):
        path, value = item.split("=", 1)
        fields = value.split("/")
        changed, edges = int(fields[1]), int(fields[2])
        excess, truth_edges = ((int(fields[3]), int(fields[4])) if len(fields) >= 5
                               else (None, None))
        out[path] = (changed, edges, excess, truth_edges)
    return out


def flicker_table(rows, scene, meta):
    """Per configuration and camera path: the shadow-edge pixels that flickered, over the
    scene's lights."""
    by, paths, truth = {}, [], False
    for r in rows:
        if r["scene"] != scene:
            continue
        for path, (changed, edges, excess, truth_edges) in parse_flicker(
                r.get("flicker", "")).items():
            if path not in paths:
                paths.append(path)
            c = by.setdefault(r["config"], {}).setdefault(path, [0, 0, 0, 0, True])
            c[0] += changed
            c[1] += edges
            if excess is None:
                c[4] = False
            else:
                c[2] += excess
                c[3] += truth_edges
                truth = True
    if not by:
        return []
    frames = meta.get("flicker_frames", "")
    out = [f"Flicker: the fraction of shadow-edge pixels whose visibility changes by more than "
           f"8/255 between consecutive frames after reprojection ({frames} frames a path; "
           "docs/accuracy.md has the definition)."
           + (" After the slash, the flicker the truth does not share (the reference traced "
              "at every frame), over the truth's edge pixels: the number the budgets (0.5% "
              "translation, 2% rotation) apply to." if truth else ""), "",
           "| configuration | " + " | ".join(paths) + " |", "|---|" + "---|" * len(paths)]

    def cell(c):
        if not c or not c[1]:
            return "—"
        text = f"{100 * c[0] / c[1]:.2f}%"
        if c[4] and c[3]:
            text += f" / {100 * c[2] / c[3]:.2f}%"
        return text
    for config, per in by.items():
        out.append(f"| {config} | " + " | ".join(cell(per.get(p)) for p in paths) + " |")
    return out + [""]


def fmt(v, spec, missing="—"):
    """A number formatted by `spec`, or `missing` for None or NaN (an empty roofline cell)."""
    return missing if v is None or v != v else format(v, spec)


def roofline_table(rows, scene, meta):
    """The filters' resolve passes against the device's texel-rate floor: fetches per pixel,
    measured ms, floor ms (fetches / rate) and their ratio."""
    seen, out = set(), []
    filters = ("defaults",) + tuple(meta["filters"]) if meta.get("filters") else FILTER_CONFIGS
    for r in rows:
        k = (r["config"], r.get("resolve_pass", ""))
        if (r["scene"] != scene or not k[1] or k in seen
                or not r["config"].startswith(filters)):
            continue
        seen.add(k)
        per_light = ", ".join(
            f"{x['light']} {x['fetches_per_pixel']}" for x in rows
            if x["scene"] == scene and x["config"] == r["config"] and x["resolve_pass"] == k[1])
        out.append(f"| {r['config']} | {k[1]} | {per_light} | {r['resolve_ms']:.3f} | "
                   f"{fmt(r['resolve_floor_ms'], '.3f')} | {fmt(r['resolve_over_floor'], '.2f')} |")
    if not out:
        return []
    rate = meta.get("gfetch_per_s", float("nan"))
    # The marginal cost of a fetch: the slope of the resolve's time over the box-grid PCF radii
    # (hard = radius 0), against the floor's slope (receivers / rate).
    marginal = []
    for rpass in dict.fromkeys(r.get("resolve_pass", "") for r in rows if r["scene"] == scene):
        pts = {}
        for r in rows:
            if (r["scene"] == scene and r["resolve_pass"] == rpass and
                    (r["config"].startswith("pcf r=") or r["config"] == "hard")):
                f = pts.setdefault(r["config"], [r["resolve_ms"], 0, 0.0])
                f[1] += r["resolve_fetches"]
                f[2] = r["resolve_floor_ms"]
        if len(pts) < 3 or not rpass or any(v[2] is None for v in pts.values()):
            continue
        xs = [v[2] for v in pts.values()]  # floor ms: fetches / rate
        ys = [v[0] for v in pts.values()]
        n, sx, sy = len(xs), sum(xs), sum(ys)
        sxx, sxy = sum(x * x for x in xs), sum(x * y for x, y in zip(xs, ys))
        if n * sxx - sx * sx <= 0:
            continue
        slope = (n * sxy - sx * sy) / (n * sxx - sx * sx)
        marginal.append(f"{rpass}: each further fetch costs {slope:.2f}x its floor "
                        f"(slope of ms against floor ms over hard and PCF r = 0..5; the rest of "
                        f"the pass, {(sy - slope * sx) / n:.3f} ms, is the fixed part)")
    cube = meta.get("texel_rate", {}).get("kinds", {}).get("cube_compare", {}).get("gfetch_per_s")
    noise = [f"{kind}: {v['noise']}" for kind, v in meta.get("texel_rate", {}).get(
        "kinds", {}).items() if v.get("noise")]
    return [f"Roofline: each filter's resolve pass against the texel-rate floor "
            f"({fmt(rate, '.1f', 'no rate')} Gfetch/s of 2D compare taps, "
            f"{fmt(cube, '.1f', 'no rate')} of cube taps, measured by "
            "penumbra-texel-rate on this device): floor = receivers x fetches per pixel / rate; "
            "PCSS counts its worst case (search + filter)." + (
                " No floor where the rate was lost in the timing noise (" + "; ".join(noise) +
                "): those cells are empty." if noise else ""),
            "", "| configuration | pass | fetches per pixel | ms | floor ms | over the floor |",
            "|---|---|---|---|---|---|"] + out + [""] + [f"- {m}" for m in marginal] + (
                [""] if marginal else [])


def draw(plt, scene, meta, pts, xy, fx, fy, dflt, out):
    """One scene's plot: error against shadow GPU ms, log axes, frontier and default."""
    fig, ax = plt.subplots(figsize=(7, 4.5))
    ax.scatter([x for x, _ in xy], [y for _, y in xy], s=18, color="#4477aa")
    # Labels where they can be read: the default and the frontier first, then the rest, each
    # skipped when its point sits on top of one already labelled (the table lists every point).
    lx = [math.log10(x) for x, _ in xy]
    ly = [math.log10(y) for _, y in xy]
    span_x = (max(lx) - min(lx)) or 1.0
    span_y = (max(ly) - min(ly)) or 1.0
    frontier_ids = {i for i, (x, y) in enumerate(xy) if (x, y) in set(zip(fx, fy))}
    order = sorted(range(len(pts)), key=lambda i: (i not in dflt, i not in frontier_ids, i))
    placed = []
    for i in order:
        u, v = (lx[i] - min(lx)) / span_x, (ly[i] - min(ly)) / span_y
        if any(abs(u - pu) < 0.06 and abs(v - pv) < 0.035 for pu, pv in placed):
            continue
        placed.append((u, v))
        ax.annotate(pts[i]["config"], xy[i], fontsize=6, xytext=(3, 2), textcoords="offset points")
    xmax = max(x for x, _ in xy) * 1.05
    ax.step(fx + [xmax], fy + [fy[-1]], where="post", color="#cc3311", lw=1,
            label="Pareto frontier")
    ax.scatter(fx, fy, s=60, facecolors="none", edgecolors="#cc3311", zorder=4)
    if dflt:
        ax.scatter([xy[i][0] for i in dflt], [xy[i][1] for i in dflt], marker="*", s=160,
                   color="#ee7733", zorder=5, label="scene default")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("shadow passes, GPU ms (median)")
    ax.set_ylabel("mean |ΔV| against the reference")
    ax.set_title(f"{scene}: {meta['device']}", fontsize=9)
    ax.legend(fontsize=7)
    fig.tight_layout()
    png = os.path.join(out, f"{scene}.png")
    fig.savefig(png + ".tmp.png", dpi=110)
    os.replace(png + ".tmp.png", png)
    plt.close(fig)
