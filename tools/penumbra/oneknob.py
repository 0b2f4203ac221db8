"""The one-knob sweep: a scene's defaults, then one setting changed at a time. penumbra-bench
measures it as its own trade; penumbra-tune measures it beside its search, scored the same way,
to show that the search's frontier covers it."""

# The local lights' map sizes: the scene format's defaults and upper limits (the parameter
# table's spot.resolution and point.resolution rows, docs/scenes.md).
LOCAL_RESOLUTION = {"spot": (1024, 16384), "point": (512, 8192)}


def local_map_sets(features, factor):
    """Every spot's and point light's shadow-map resolution times factor (the format's default
    where the file gives none, clamped to [16, the format's limit]), as the parameter table's
    per-light keys: [("spot[0].resolution", "2048"), ...]. The scene file is not rewritten."""
    sets = []
    for table, lights in (("spot", features.spots), ("point", features.points)):
        default, top = LOCAL_RESOLUTION[table]
        for i, light in enumerate(lights):
            scaled = max(16, min(top, int(round(int(light.get("resolution", default)) * factor))))
            sets.append((f"{table}[{i}].resolution", str(scaled)))
    return sets


# The filters this sweep knows how to vary; any other filter of the table (filters=) is measured
# once, with its keys as the scene has them.
SWEPT_FILTERS = ("hard", "pcf", "poisson", "pcss", "evsm2")


def configurations(has_sun, has_contact, quick, max_map, lights=None, filters=None):
    """(label, sets) pairs: the scene's defaults first, then one change at a time (sets: a list
    of (key, value text)). lights: the scene's scenefile.Features, for its local lights' maps.
    filters: the filter table's names (build.filter_names); each one not in SWEPT_FILTERS gets
    one configuration of its own."""
    c = [("defaults", [])]
    c += [("hard", [("shadows.filter", "hard")])]
    radii = [1] if quick else [0, 1, 2, 3, 5]
    c += [(f"pcf r={r}", [("shadows.filter", "pcf"), ("shadows.pcf_radius", str(r))]) for r in radii]
    # --quick (a smoke run): the defaults, hard, PCF and PCSS; no Poisson or EVSM2.
    taps = [] if quick else [8, 16, 32]
    c += [(f"poisson {t}", [("shadows.filter", "poisson"), ("shadows.poisson_taps", str(t))])
          for t in taps]
    tiers = ["medium"] if quick else ["low", "medium", "high"]
    c += [(f"pcss {q}", [("shadows.filter", "pcss"), ("shadows.pcss_quality", q)]) for q in tiers]
    if has_sun and not quick:
        # EVSM2 on the sun's cascades: the moments pass, its blur and the moment format.
        blurs = [0, 1, 2]
        c += [(f"evsm2 blur={b}", [("shadows.filter", "evsm2"), ("shadows.evsm_blur", str(b))])
              for b in blurs]
        c += [("evsm2 fp32", [("shadows.filter", "evsm2"), ("shadows.evsm_fp16", "false")])]
    if not quick:
        c += [(f, [("shadows.filter", f)]) for f in (filters or ()) if f not in SWEPT_FILTERS]
    if quick:
        return c
    if has_contact:
        c += [(f"contact {s}", [("contact.steps", str(s))]) for s in (0, 8, 16, 32)]
    if has_sun:
        c += [(f"cascades {n}", [("shadows.cascades", str(n))]) for n in (1, 2, 3, 4)]
        c += [(f"map {m}", [("shadows.resolution", str(m))])
              for m in (512, 1024, 2048, 4096, 8192) if m <= max_map]
        c += [(f"fit {f}", [("shadows.fit", f)]) for f in ("box", "camera_sphere", "slice_sphere")]
        c += [("constant width", [("shadows.constant_filter_width", "true")])]
    if lights is not None and (lights.spots or lights.points):
        c += [(f"local maps x{f:g}", local_map_sets(lights, f)) for f in (0.5, 2)]
    # The shadow-map cache, timed along a walk (measure.timing_sets; the other points are timed
    # drawing every map every frame).
    c += [("cache, walking", [("shadows.cache", "true")])]
    # The biases (every light): half and twice the defaults, and none.
    c += [(f"normal offset {t}", [("shadows.normal_offset_texels", t)]) for t in ("0", "0.75", "3")]
    c += [(f"slope bias {t}", [("shadows.slope_bias", t)]) for t in ("0", "1", "4")]
    c += [(f"constant bias {t}", [("shadows.constant_bias", t)]) for t in ("0", "0.002")]
    # Temporal accumulation: off, and the new frame's share (the error is the first frame's,
    # which has no history; the flicker column shows what it buys).
    c += [("temporal off", [("shadows.temporal", "false")])]
    c += [(f"temporal w={w}", [("shadows.temporal", "true"), ("shadows.temporal_weight", w)])
          for w in ("0.1", "0.3", "0.5")]
    return c
