"""The build's refusals for contact and joint-law parameters, applied where run-time values enter.

Why: the builders refuse a negative contact stiffness, a friction coefficient below 0,
lower > upper on a limit, a negative damping (compiler/contact/law.py check_value,
compiler/tree/joint_laws.py check_law), but the same numbers are parameters that
``simulate(p=...)``, ``--param``, ``simulate_many`` and sweep rows change without a
rebuild.  Unchecked, mu = -1 made a sliding ball gain 1440 J in 3 s and
limit_e = 0 ended in "a non-finite value appeared" (issue 29 R2, R4) -- with status 0
or without naming the parameter.  This module checks a parameter vector against the
same rules, found by the parameters' names (contacts: ``k_/c_/mu_/vs_/r_<name>`` of a
``contact_<name>`` event; joints: ``limit_*/damping/friction*_<joint>`` of a coordinate
``q_<joint>``; MJCF's ``d_<joint>``), and raises a ValueError naming the parameter.  A SymPy
model's bodies whose mass or inertia are parameters (NAME.json ``body_parameters``) are refused a
mass <= 0 or an inertia no body has, naming the parameter and the body.  runtime/ only: no
import of the compiler.
"""
import re

import numpy as np

from .switching import contact_parameter

__all__ = ["check_law_parameters", "check_body_parameters"]

# parameter prefix -> (what it is, strictly positive?)
_CONTACT = {"k": ("contact stiffness", False), "c": ("contact damping", False),
            "mu": ("friction coefficient", False), "vs": ("friction regularisation speed", True),
            "r": ("contact radius", False), "mut": ("torsional friction", False),
            "mur": ("rolling friction", False)}
_JOINT = {"limit_k": ("limit stiffness", False), "limit_c": ("limit damping", False),
          "limit_e": ("limit width", True), "limit_kd": ("limit entry stiffness", False),
          "limit_cd": ("limit entry damping", False), "limit_d": ("limit entry depth", False),
          "damping": ("damping", False),
          "friction": ("friction", False), "friction_v": ("friction speed", True)}

# the fluid forces' parameters (compiler/mjcf/fluid.py): negative, the drag would push energy in
_FLUID = {"fluid_density": "the fluid's density", "fluid_viscosity": "the fluid's viscosity"}


def _mjcf_damping(pname, states):
    """The joint whose MJCF damping ``pname`` is (compiler/mjcf/treeir.py: ``d_<joint>`` on a hinge or
    slide with its coordinate ``q_<joint>``, ``d_<joint>_<0|1|2>`` on a ball joint, whose coordinates
    are ``q_<joint>_...``), else None.  Negative, a damper pushes energy in, and the energy verdict
    would then blame the integrator for it."""
    if not pname.startswith("d_"):
        return None
    rest = pname[2:]
    if f"q_{rest}" in states:
        return rest
    ball = re.fullmatch(r"(.+)_[012]", rest)
    if ball and any(s.startswith(f"q_{ball.group(1)}_") for s in states):
        return ball.group(1)
    return None


def _rules(model):
    """[(parameter index, name, meaning, strict)] and [(joint, lo index, hi index)], cached."""
    cached = getattr(model, "_law_rules", None)
    if cached is not None:
        return cached
    index = {n: i for i, n in enumerate(model.param_names)}
    states = set(model.state_names)
    rules, pairs, taken = [], [], set()      # taken: the indices ruled (a set: dm_control's
    # humanoid_CMU has ~6000 contact rules, and a scan of the list per candidate took 1.2 s)
    for d in model.metadata.get("events", ()):
        name = d["name"]
        if not name.startswith("contact_"):
            continue
        contact = name[len("contact_"):]
        for key, (what, strict) in _CONTACT.items():
            i = contact_parameter(index, key, contact)
            if i >= 0 and i not in taken:
                rules.append((i, model.param_names[i], f"{what} of contact {contact}", strict))
                taken.add(i)
    for pname, i in index.items():
        for key in sorted(_JOINT, key=len, reverse=True):     # friction_v before friction
            if pname.startswith(key + "_") and f"q_{pname[len(key) + 1:]}" in states:
                joint = pname[len(key) + 1:]
                what, strict = _JOINT[key]
                rules.append((i, pname, f"{what} of joint {joint}", strict))
                taken.add(i)
                break
        mjcf = _mjcf_damping(pname, states)
        if mjcf is not None and i not in taken:
            rules.append((i, pname, f"damping of joint {mjcf}", False))
            taken.add(i)
        if pname in _FLUID:      # MJCF's <option density viscosity>: the energy verdict takes them >= 0
            rules.append((i, pname, _FLUID[pname], False))
        if pname.startswith("limit_lo_") and f"q_{pname[9:]}" in states:
            hi = index.get(f"limit_hi_{pname[9:]}")
            if hi is not None:
                pairs.append((pname[9:], i, hi))
    found = (tuple(rules), tuple(pairs))
    try:
        model._law_rules = found
    except AttributeError:
        pass
    return found


def _arrays(model, rules, pairs):
    """The rules as index arrays (parameter, strict?, limit lower, limit upper), cached."""
    cached = getattr(model, "_law_arrays", None)
    if cached is not None and cached[0] is rules:
        return cached[1]
    got = (np.array([r[0] for r in rules], dtype=np.intp), np.array([r[3] for r in rules], dtype=bool),
           np.array([q[1] for q in pairs], dtype=np.intp), np.array([q[2] for q in pairs], dtype=np.intp))
    try:
        model._law_arrays = (rules, got)
    except AttributeError:
        pass
    return got


def _entry(e, index, p):
    """A ``body_parameters`` entry (a number, or [coefficient, [[name, exponent], ...]]) at ``p``."""
    if not isinstance(e, list):
        return float(e)
    v = float(e[0])
    for name, exp in e[1]:
        v *= float(p[index[name]]) ** float(exp)
    return v


def _names_of(entries):
    return sorted({n for e in entries if isinstance(e, list) for n, _ in e[1]})


def _body_faults(body, index, p):
    """[(parameters, what is wrong)] of one ``body_parameters`` row at ``p``."""
    faults = []
    mass = body.get("mass")
    if mass is not None:
        m = _entry(mass, index, p)
        if not m > 0:
            faults.append((_names_of([mass]), f"body {body['body']} the mass {m:g}: a body's mass must be > 0"))
    inertia = body.get("inertia")
    if inertia is not None:
        matrix = np.array([[_entry(e, index, p) for e in row] for row in inertia])
        names = _names_of([e for row in inertia for e in row])
        if not np.isfinite(matrix).all():
            faults.append((names, f"body {body['body']} a non-finite central inertia"))
            return faults
        eig = np.linalg.eigvalsh((matrix + matrix.T) / 2)
        tol = 1e-9 * max(abs(eig).max(), 1e-300)
        moments = ", ".join(f"{v:g}" for v in eig)
        if eig.min() < -tol:
            faults.append((names, f"body {body['body']} a central inertia with principal moments {moments}: "
                                  f"a negative moment is not a body's (the inertia must be positive semi-definite)"))
        elif eig[2] > eig[0] + eig[1] + tol:
            faults.append((names, f"body {body['body']} a central inertia with principal moments {moments}, "
                                  f"which miss the triangle inequality (the largest must not exceed the "
                                  f"sum of the other two): no mass distribution has them"))
    return faults


def _body_rules(model):
    """The model's ``body_parameters`` rows whose parameters are all run-time parameters and
    whose defaults pass (a model built with, e.g., a slender rod's zero moments keeps them)."""
    cached = getattr(model, "_body_rules", None)
    if cached is not None:
        return cached
    index = {n: i for i, n in enumerate(model.param_names)}
    defaults = np.asarray(getattr(model, "param_defaults", None) if getattr(model, "param_defaults", None)
                          is not None else [np.nan] * len(index), dtype=np.float64)
    rules = []
    for body in (getattr(model, "metadata", None) or {}).get("body_parameters") or ():
        parts = {k: body[k] for k in ("mass", "inertia") if k in body}
        kept = {"body": body["body"]}
        for key, part in parts.items():
            flat = [part] if key == "mass" else [e for row in part for e in row]
            if not all(n in index for n in _names_of(flat)):
                continue
            with np.errstate(all="ignore"):
                if _body_faults({"body": body["body"], key: part}, index, defaults):
                    continue        # the build's own values already fail it: not this check's to refuse
            kept[key] = part
        if len(kept) > 1:
            rules.append(kept)
    found = (tuple(rules), index)
    try:
        model._body_rules = found
    except AttributeError:
        pass
    return found


def _body_program(model, rules, index):
    """The rules' entries as arrays, cached: (coefficients (E,), parameter slots (E, K), exponents
    (E, K), the mass entries' rows, the inertias' rows (B, 9)); slot len(index) is a 1."""
    cached = getattr(model, "_body_program", None)
    if cached is not None and cached[0] is rules:
        return cached[1]
    entries, masses, inertias = [], [], []
    for body in rules:
        if "mass" in body:
            masses.append(len(entries))
            entries.append(body["mass"])
        if "inertia" in body:
            inertias.append(list(range(len(entries), len(entries) + 9)))
            entries += [e for row in body["inertia"] for e in row]
    width = max([len(e[1]) for e in entries if isinstance(e, list)] + [1])
    one = len(index)
    coef = np.array([float(e[0]) if isinstance(e, list) else float(e) for e in entries])
    slots = np.full((len(entries), width), one, dtype=np.intp)
    exps = np.zeros((len(entries), width))
    for k, e in enumerate(entries):
        for j, (name, exp) in enumerate(e[1] if isinstance(e, list) else ()):
            slots[k, j], exps[k, j] = index[name], float(exp)
    got = (coef, slots, exps, np.array(masses, dtype=np.intp), np.array(inertias, dtype=np.intp).reshape(-1, 9))
    try:
        model._body_program = (rules, got)
    except AttributeError:
        pass
    return got


def _bodies_pass(model, rules, index, p):
    """True when every rule holds at ``p`` (one vectorized pass: a robot's dozens of bodies cost
    one batched eigvalsh, ~0.5 ms a call by the loop below on HyQ's 12; rollout checks each p row);
    False sends the caller to the loop, which names the culprit."""
    coef, slots, exps, masses, inertias = _body_program(model, rules, index)
    with np.errstate(all="ignore"):
        values = coef * np.prod(np.append(p, 1.0)[slots] ** exps, axis=1)
        if not np.isfinite(values).all() or not (values[masses] > 0).all():
            return False
        if not inertias.size:
            return True
        matrix = values[inertias].reshape(-1, 3, 3)
        eig = np.linalg.eigvalsh((matrix + matrix.transpose(0, 2, 1)) / 2)
        tol = 1e-9 * np.maximum(np.abs(eig).max(axis=1), 1e-300)
        return bool((eig[:, 0] >= -tol).all() and (eig[:, 2] <= eig[:, 0] + eig[:, 1] + tol).all())


def check_body_parameters(model, p, where=""):
    """ValueError naming the parameters that give a body a mass <= 0 or an impossible inertia
    (NAME.json ``body_parameters``: eomc.compiler.mechanics.body_parameters)."""
    rules, index = _body_rules(model)
    if not rules:
        return
    p = np.asarray(p, dtype=np.float64)
    if _bodies_pass(model, rules, index, p):
        return
    at = f" ({where})" if where else ""
    for body in rules:
        with np.errstate(all="ignore"):
            faults = _body_faults(body, index, p)
        if faults:
            names, what = faults[0]
            given = ", ".join(f"{n} = {float(p[index[n]]):g}" for n in names)
            raise ValueError(f"{model.name}: parameter{'s' if len(names) > 1 else ''} {given}{at} "
                             f"give{'' if len(names) > 1 else 's'} {what} "
                             f"(the build refuses such a body too)")


def check_law_parameters(model, p, where=""):
    """ValueError naming the first contact or joint-law parameter in ``p`` that the build
    would refuse (negative, or 0 where the law divides by it; limit lower > upper)."""
    check_body_parameters(model, p, where)
    rules, pairs = _rules(model)
    p = np.asarray(p, dtype=np.float64)
    idx, strict, lo, hi = _arrays(model, rules, pairs)
    v = p[idx]
    if not ((v < 0) | (strict & (v == 0))).any() and not (p[lo] > p[hi]).any():
        return      # one gather per call (a robot has ~100 rules); the loop below names the culprit
    at = f" ({where})" if where else ""
    for i, name, what, strict in rules:
        v = float(p[i])
        if v < 0 or (strict and v == 0):
            need = "> 0" if strict else ">= 0"
            why = ("the law divides by it" if strict and v == 0
                   else "the build refuses a negative one too: the law would be unphysical")
            raise ValueError(f"{model.name}: parameter {name} = {v:g}{at} must be {need} "
                             f"({what}): {why}")
    for joint, lo, hi in pairs:
        if float(p[lo]) > float(p[hi]):
            raise ValueError(f"{model.name}: parameters limit_lo_{joint} = {float(p[lo]):g} > "
                             f"limit_hi_{joint} = {float(p[hi]):g}{at}: joint {joint}'s lower limit "
                             f"must not exceed its upper")
