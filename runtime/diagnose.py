"""Why the mass matrix is singular, in the user's terms: which speeds meet no inertia.

A "singular mass matrix" status alone leaves the user to guess which body or joint
lacks inertia.  A mass matrix that is singular to rounding (a URDF link whose inertia is
1e-20, a head on two neck joints) is not refused by the LDLᵀ but makes the problem so
stiff that the step size collapses: that failure gets the same diagnosis.  When it happens (not on the hot path), the model's own
``mass_matrix`` at the failing state is decomposed: the eigenvector of its smallest
eigenvalue is the motion nothing resists, and its large components name the
speeds (for URDF and joint models the speed names carry the joint names).
"""
import numpy as np

from .cdef import STATUS_SINGULAR_MASS_MATRIX as SINGULAR_STATUS

__all__ = ["SINGULAR_STATUS", "singular_direction", "leaving_state", "no_ground", "gimbal_passed"]

# how near a URDF hinge triple's gimbal lock a run's rows may come before gimbal_passed says so (rad)
GIMBAL_NEAR = 0.01


def singular_direction(model, t, x, p=None, r=None, semidefinite=False):
    """'; nothing resists motion along u2 (1), u3 (-0.24) ...' (the null direction of M, its
    largest components first) or '' when it cannot tell.

    ``semidefinite``: say it only when M is positive semidefinite to rounding, i.e. when M
    is a plain mass matrix that is singular.  For a guess at a cause that is not M's own
    status (a collapsed step, the start of a build): a constrained system's mass_matrix is
    not symmetric positive (four-bar: eigenvalue -1.36) and is not evidence there."""
    if "mass_matrix" not in getattr(model, "functions", ()):
        return ""
    if isinstance(p, np.ndarray) and p.ndim == 1:
        p = p[:model.nparam]          # the integrators' parameter block may carry more after p
    try:
        M = np.asarray(model.mass_matrix(t, x, p=p, r=r), dtype=float)
        if not np.all(np.isfinite(M)):
            return ""
        w, V = np.linalg.eigh((M + M.T) / 2)
    except Exception:      # a diagnosis must never hide the original error
        return ""
    if w[-1] <= 0:
        return "; M is zero there: no speed meets any mass or inertia"
    if w[0] > 1e-10 * w[-1] or (semidefinite and w[0] < -1e-10 * w[-1]):
        return ""
    v = V[:, 0] / np.max(np.abs(V[:, 0]))
    v = v if v[np.argmax(np.abs(v))] > 0 else -v
    speeds = model.state_names[model.nq:model.nq + model.nu]
    parts = [f"{speeds[k]} ({v[k]:.2g})" for k in np.argsort(-np.abs(v)) if abs(v[k]) > 0.05][:4]
    return f"; nothing resists motion along {', '.join(parts)} (M's smallest eigenvalue " \
           f"{w[0]:.3g}, largest {w[-1]:.3g}): a body with no (or next to no) mass or inertia about those " \
           f"joints, or joint axes lined up (gimbal lock)" + _inertia_remedy(model, t, x, p, r, w[-1])


def _inertia_remedy(model, t, x, p, r, largest):
    """'; body 'head' (1.34 kg) has no rotational inertia: ... --param Ixx_head=...' when giving
    point-mass bodies (mass, inertia parameters at rounding level: icub.urdf's head, 1.34 kg
    with inertia 1e-35 on a three-hinge neck) the inertia of a uniform sphere as large as their
    centre of mass is far from their joint lifts M's smallest eigenvalue out of rounding; ''
    otherwise.  One mass_matrix call per candidate body (at most 16), then one for them all."""
    names = list(getattr(model, "param_names", ()))
    if not names or not (p is None or isinstance(p, (np.ndarray, list, tuple))):
        return ""
    base = np.array(model.param_defaults if p is None else p, dtype=float)[:len(names)]
    if base.shape != (len(names),):
        return ""
    index = {n: k for k, n in enumerate(names)}
    candidates = []
    for name in names:
        body = name[4:] if name.startswith("Ixx_") else None
        keys = [f"I{a}_{body}" for a in ("xx", "yy", "zz", "xy", "xz", "yz")] if body else []
        if not body or f"m_{body}" not in index or any(k not in index for k in keys[:3]):
            continue
        mass = base[index[f"m_{body}"]]
        c = [base[index[k]] for k in (f"cx_{body}", f"cy_{body}", f"cz_{body}") if k in index]
        radius = float(np.linalg.norm(c)) if c else 0.0
        radius = radius if radius > 1e-3 else 0.05
        moment = 0.4 * mass * radius ** 2
        if mass > 0 and max(abs(base[index[k]]) for k in keys if k in index) <= 1e-9 * moment:
            candidates.append((body, mass, radius, moment, [k for k in keys if k in index]))
    if not candidates or len(candidates) > 16:
        return ""

    def lifted(chosen):
        q = base.copy()
        for _, _, _, moment, keys in chosen:
            for k in keys:
                q[index[k]] = moment if k[1] == k[2] else 0.0
        try:
            M = np.asarray(model.mass_matrix(t, x, p=q, r=r), dtype=float)
            w = np.linalg.eigvalsh((M + M.T) / 2)
        except Exception:      # a diagnosis must never hide the original error
            return None
        return w[0] if np.all(np.isfinite(w)) and w[0] > 1e-10 * w[-1] else None

    for chosen in [[c] for c in candidates] + ([candidates] if len(candidates) > 1 else []):
        smallest = lifted(chosen)
        if smallest is not None:
            break
    else:
        return ""
    what = ", ".join(f"'{body}' ({mass:.3g} kg)" for body, mass, _, _, _ in chosen)
    sizes = ", ".join(f"{radius:.3g} m" for _, _, radius, _, _ in chosen)
    params = " ".join(f"{k}={moment if k[1] == k[2] else 0:.3g}" for _, _, _, moment, keys in chosen
                      for k in keys)
    return (f"; bod{'ies' if len(chosen) > 1 else 'y'} {what} {'have' if len(chosen) > 1 else 'has'} no "
            f"rotational inertia in the file; given some (e.g. a uniform sphere's about the centre of mass, "
            f"radius {sizes}: the centre's distance from the joint), that motion meets inertia (M's smallest "
            f"eigenvalue then {smallest:.3g}): --param {params}")


def leaving_state(model, x, p=None, t=0.0, step=0.1):
    """The name of a state that, moved by ``step`` from the equilibrium ``x``, starts a motion
    (the rhs there is not 0): the first coordinate that does, else the first speed, else the
    first state.  For the hint after "nothing moved": SymPy's n_link_pendulum_on_cart starts at
    an equilibrium where its first coordinate, the cart's position, moves nothing when shifted
    (the hint "--x0 q0=0.1" led to the same still run)."""
    names = list(model.state_names)
    nq = int(getattr(model, "nq", 0) or 0)
    x = np.asarray(x, dtype=float)
    if isinstance(p, dict):     # {name: value}, as simulate takes it
        given, p = p, np.array(model.param_defaults, dtype=float)
        for k, v in given.items():
            if k in model.param_names:
                p[list(model.param_names).index(k)] = float(v)
    for i in range(min(nq, len(names))):
        moved = x.copy()
        moved[i] += step
        try:
            if np.any(np.asarray(model.rhs(t, moved, p=p)) != 0):
                return names[i]
        except Exception:       # noqa: BLE001 -- a hint only: try the next one
            continue
    return names[nq] if 0 < nq < len(names) else names[0]


# what a floating-base robot with nothing touching the ground is given, in the command line's words
GROUND_OPTIONS = ("--ground lets the robot's <collision> geometry touch the plane z = 0, "
                  "--contact LINK[:x,y,z[:radius]] puts a contact sphere on a link (its feet)")


def no_ground(model, t=None, x=None, p=None, t_span=None):
    """'no ground: ...' when ``model`` has a floating base (a ``*_floating_z`` coordinate) and no
    ground contact, so nothing stops its fall; None otherwise (or when it did not fall).

    With a run (``t``, ``x``: its times and states) the text gives how far the base fell; without
    one (``t_span``: the span the runs cover, ``eomc check``) the centre of mass's free fall
    g t^2 / 2, which is exact with no contact: gravity is then the only external force.
    First hour s25: ``eomc simulate solo12.urdf --floating-base`` fell 490 m in 10 s and said
    nothing (status 0); a robot dropped into the void is almost never what was meant."""
    names = list(model.state_names[:model.nq])
    zs = [k for k, n in enumerate(names) if n.endswith("_floating_z")]
    if len(zs) != 1:
        return None
    from .switching import find_switches
    if find_switches(model).contacts:
        return None
    where = "nothing touches the ground (a floating base with no contact)"
    if x is not None and t is not None and len(t) > 1:
        z = np.asarray(x)[:, zs[0]]
        fell = float(z[0] - z[-1])
        if not fell > 0.0:
            return None
        return (f"no ground: {model.name}'s base fell {fell:.4g} m in {t[-1] - t[0]:.4g} s "
                f"({names[zs[0]]} {z[0]:.4g} -> {z[-1]:.4g}): {where}; {GROUND_OPTIONS}")
    params = list(getattr(model, "param_names", ()))
    if "g" not in params or t_span is None:
        return None
    values = np.asarray(model.param_defaults if p is None else p, dtype=float)
    g = float(values[params.index("g")])
    fall = 0.5 * g * (t_span[1] - t_span[0]) ** 2
    if not fall > 0.0:
        return None
    return (f"no ground: {where}, so the runs follow a free fall (the centre of mass falls "
            f"g t^2/2 = {fall:.4g} m in {t_span[1] - t_span[0]:.4g} s); {GROUND_OPTIONS}")


def gimbal_passed(model, t, x):
    """A sentence when a run's rows crossed or came within GIMBAL_NEAR of a gimbal lock of the
    model's hinge triples (NAME.json ``gimbal_locks``: a URDF's three hinges with axes through one
    point and no inertia between them, whose lock the build warns of), else None.

    Why: there the mass matrix is singular, and a run either stops (human.urdf's default run, at
    its left hip) or steps across at status 0 (test_gimbal_lock's swing since the entry springs),
    the outer hinges' motion there undetermined by the model.  Only those triples: a free or ball
    joint's angles (speeds are angular velocities, the mass matrix stays regular) pass their lock
    correctly, and gymnasium's and dm_control's humanoids do so in their default runs (measured,
    session 27: lying within 1.9 deg of it for 3.3 s; tumbling through it)."""
    locks = (getattr(model, "metadata", None) or {}).get("gimbal_locks") or ()
    names = list(model.state_names)
    said = []
    for lock in locks:
        if lock.get("state") not in names or len(t) == 0:
            continue
        d = np.asarray(x)[:, names.index(lock["state"])] - float(lock["angle"])
        crossed = np.flatnonzero(d[:-1] * d[1:] < 0)
        k = int(crossed[0]) if crossed.size else int(np.argmin(np.abs(d)))
        if not crossed.size and abs(d[k]) >= GIMBAL_NEAR:
            continue
        P, J, K = lock["joints"]
        how = ("crossed" if crossed.size else f"came within {abs(d[k]):.2g} rad of")
        said.append(f"{lock['state']} {how} {float(lock['angle']):.6g} at t = {t[k]:.6g} (hinges {P}, {J}, {K})")
    if not said:
        return None
    return (f"{model.name}: the run passed a gimbal lock of hinges whose axes meet in one point with no "
            f"inertia between them: {'; '.join(said)}. There the first and last axes line up and the mass "
            f"matrix is singular: the hinges' motion across it is not determined by the model and depends "
            f"on where the steps fell; the build's warning gives the --param limits that keep runs clear")
