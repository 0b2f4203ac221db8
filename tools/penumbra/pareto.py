"""Pareto frontiers of points with objectives to minimise (a dict of name -> value)."""


def dominates(a, b, keys):
    """a is no worse than b on every key and better on one."""
    return all(a[k] <= b[k] for k in keys) and any(a[k] < b[k] for k in keys)


def frontier(points, keys):
    """The points no other point dominates (points: dicts holding every key)."""
    return [p for p in points if not any(dominates(q, p, keys) for q in points if q is not p)]


def beaten_by(d, points, cost, errors, relative=0.05, absolute=None, limits=None):
    """The points that beat `d` by more than the margin: no more costly (points[cost] <=
    d[cost]), no worse on any error objective beyond the margin (worse by at most `relative` of
    d's value plus that objective's `absolute` floor: 0.16% flicker against 0.13% is no real
    difference), and better than d on one by more than the margin. A `d` beaten by none sits
    on the frontier within the margin. `limits` (objective -> value, a scene's [tune] max_*):
    a point over one is no choice, so it beats nothing."""
    absolute = absolute or {}
    limits = limits or {}
    out = []
    for p in points:
        if p is d or p[cost] > d[cost] or any(p[k] > v for k, v in limits.items()):
            continue
        if any(p[k] > d[k] * (1.0 + relative) + absolute.get(k, 0.0) for k in errors):
            continue
        if any(p[k] < d[k] * (1.0 - relative) - absolute.get(k, 0.0) for k in errors):
            out.append(p)
    return out


def matched_by(p, points, cost, errors, relative=0.05, absolute=None):
    """The cheapest of `points` that matches or beats `p`: its cost no more than p's beyond the
    margin, and no error objective worse than p's beyond the margin plus its floor. None when no
    point does (p lies where the points have not reached)."""
    absolute = absolute or {}
    ok = [q for q in points if q[cost] <= p[cost] * (1.0 + relative) and
          all(q[k] <= p[k] * (1.0 + relative) + absolute.get(k, 0.0) for k in errors)]
    return min(ok, key=lambda q: q[cost]) if ok else None


def covered(sweep, points, cost, errors, relative=0.05, absolute=None):
    """For each point of a one-knob sweep, the cheapest search point that matches or beats it
    (matched_by), or None. Points marked 'seed' (the sweep's own, seeding the search) do not
    count: the coverage is the search's."""
    own = [q for q in points if not q.get("seed")]
    return [matched_by(p, own, cost, errors, relative, absolute) for p in sweep]
