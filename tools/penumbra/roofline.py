"""penumbra-bench's roofline: each resolve pass's measured time against the device's texel-rate
floor (its shadow-map fetches per pixel over the fetch rate penumbra-texel-rate measured)."""
import math

# The resolve passes the roofline column covers, and which lights each one filters.
RESOLVE_PASSES = {"shadow-resolve": ("sun",), "local-shadow-resolve": ("spot", "point")}


def roofline(passes, m, s_per_fetch):
    """Per resolve pass: its fetches (receivers x fetches per pixel, summed over its lights), its
    floor at the device's fetch rates (the cube rate for point lights), and its measured time
    over that floor."""
    filters = m.get("filters", {})
    out = {}
    for name, kinds in RESOLVE_PASSES.items():
        if name not in passes:
            continue
        fetches, floor_s = 0, 0.0
        for l in m["lights"]:
            kind = l["light"].rstrip("0123456789")
            if kind not in kinds:
                continue
            n = l["receivers"] * filters.get(l["light"], {}).get("fetches_per_pixel", 0)
            fetches += n
            rate = s_per_fetch["cube" if kind == "point" else "2d"]
            # A rate the timing noise hid (penumbra-texel-rate's null) leaves the floor empty.
            floor_s = floor_s + n * rate if rate and floor_s is not None else None
        floor_ms = floor_s * 1e3 if floor_s is not None else None
        ratio = passes[name] / floor_ms if floor_ms else None
        out[name] = (fetches, floor_ms, ratio)
    return out


def rates_from(data):
    """Seconds per fetch by kind from penumbra-texel-rate's JSON (as texel_rate returns); None
    where the tool found no rate above the timing noise (its "gfetch_per_s" is null)."""
    def seconds(kind):
        rate = data["kinds"].get(kind, data["kinds"]["compare"])["gfetch_per_s"]
        if rate is None or not math.isfinite(rate) or rate <= 0:
            return None
        return 1.0 / (rate * 1e9)
    return {"2d": seconds("compare"), "cube": seconds("cube_compare")}


def recompute_roofline(rows, data):
    """The roofline columns of every row again, at the rates of `data` (--replot --texel-rate)."""
    s_per_fetch = rates_from(data)
    groups = {}
    for r in rows:
        groups.setdefault((r["scene"], r["config"]), []).append(r)
    for group in groups.values():
        m = {"lights": [{"light": r["light"], "receivers": r["receivers"]} for r in group],
             "filters": {r["light"]: {"fetches_per_pixel": r["fetches_per_pixel"]} for r in group}}
        passes = {r["resolve_pass"]: r["resolve_ms"] for r in group if r.get("resolve_pass")}
        roof = roofline(passes, m, s_per_fetch)
        for r in group:
            if r.get("resolve_pass") in roof:
                r["resolve_fetches"], r["resolve_floor_ms"], r["resolve_over_floor"] = \
                    roof[r["resolve_pass"]]
