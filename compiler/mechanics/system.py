"""eomc's ``System`` and ``JointsMethod``: SymPy 1.14's, forming equations with eomc's methods.

Why subclasses of SymPy's classes: a ``System`` is mostly bookkeeping --
bodies, joints, loads, actuators, coordinates, speeds, kinematic equations,
constraints -- and that bookkeeping is exactly what users, SymPy's joints and
other eomc front ends (the URDF importer, the recursive O(n) formulation) read.
Keeping SymPy's code for it makes eomc's ``System`` a drop-in: the same
constructor, attributes and ``isinstance(system, sympy...System)``.  Only the
last step differs: which class forms the equations.  SymPy's ``form_eoms``
and ``validate_system`` decide that with ``issubclass(eom_method, <SymPy's
KanesMethod>)``, which eomc's classes are not, so those two methods are
overridden here and nothing else.  SymPy's own ``KanesMethod`` and
``LagrangesMethod`` passed as ``eom_method`` are replaced by eomc's (a user's
subclass of SymPy's is respected: it is the user's choice).

What eomc adds on top (bad input named, never a traceback from inside SymPy):
``add_joints`` refuses a body attached as the child of two joints, a joint
that closes a loop of joints (close loops with holonomic constraints instead),
and a joint whose coordinates or speeds another joint already uses;
``form_eoms`` names the actuator whose load acts on a point without a
velocity.  ``formed()`` hands the equations to the compiler, so a ``System``
is a model by itself (``system = ...`` in a model file, ``eomc.compile``).

``form_eoms()`` with eomc's KanesMethod forms nothing yet: it records the
equations (as ``kanes_equations`` does, the bodies and loads checked at once,
their velocities -- SymPy's frame-graph search, O(n^2) on a chain of joints --
left to forming, which reports a missing one by the same ModelError) and returns
them as a Matrix that forms them when first read (:class:`EquationsOnUse`).  Why: a model file written in SymPy's
documented style calls ``system.form_eoms()`` and hands ``system`` to eomc; when
the build takes the recursive formulation (auto, from about eight bodies) it
reads the joint tree instead, and forming Kane's equations there cost the file
most of its build (the n-link cart at n = 40: benchmarks/results/form_eoms_build.md).
``kane_pending()`` says whether the System still stands as it was recorded,
with nothing formed, so that the compiler may read its tree instead
(eomc.compiler.mechanics.unformed).
"""
from sympy.matrices.dense import MutableDenseMatrix
from sympy.physics.mechanics import kane as _sympy_kane
from sympy.physics.mechanics.body_base import BodyBase
from sympy.physics.mechanics.joint import Joint
from sympy.physics.mechanics import lagrange as _sympy_lagrange
from sympy.physics.mechanics.jointsmethod import JointsMethod as _SymPyJointsMethod
from sympy.physics.mechanics.system import System as _SymPySystem
from sympy.physics.vector import Point, ReferenceFrame
from sympy.utilities.exceptions import sympy_deprecation_warning

from eomc.runtime.errors import ModelError

from .convert import from_sympy, register_system_converter
from .energy import Lagrangian
from .kane import KanesMethod
from .lagrange import LagrangesMethod

__all__ = ["System", "JointsMethod", "EquationsOnUse"]

_SYMPY_KANE = _sympy_kane.KanesMethod
_SYMPY_LAGRANGE = _sympy_lagrange.LagrangesMethod
_OURS = {_SYMPY_KANE: KanesMethod, _SYMPY_LAGRANGE: LagrangesMethod}


def _our_method(eom_method):
    """SymPy's exact KanesMethod/LagrangesMethod -> eomc's; anything else unchanged."""
    try:
        return _OURS.get(eom_method, eom_method)
    except TypeError:  # unhashable
        return eom_method


def _family(eom_method):
    """'kane', 'lagrange' or None for the class passed as ``eom_method``."""
    if not isinstance(eom_method, type):
        return None
    if issubclass(eom_method, (KanesMethod, _SYMPY_KANE)):
        return "kane"
    if issubclass(eom_method, (LagrangesMethod, _SYMPY_LAGRANGE)):
        return "lagrange"
    return None


def _sympy_family(eom_method):
    """The SymPy class SymPy's own checks expect for ``eom_method``'s family."""
    return {"kane": _SYMPY_KANE, "lagrange": _SYMPY_LAGRANGE}.get(_family(eom_method), eom_method)


def _body_name(body):
    return getattr(body, "name", repr(body))


def check_single_parents(joints):
    """Refuse a body that is the child of two joints, naming both: SymPy's System takes such
    joints, and then its equations fail far from the cause (a joint "without inertia")."""
    parent_of = {}
    for joint in joints or ():
        child = getattr(joint, "child", None)
        if child is None:
            continue
        if child in parent_of:
            raise ModelError(
                f"body {_body_name(child)} is the child of two joints, {parent_of[child].name} and "
                f"{joint.name}; a body can be the child of one joint only (a closed loop: leave one "
                f"of them out and close the loop with add_holonomic_constraints instead)")
        parent_of[child] = joint


def check_new_joints(old_joints, new_joints, root=None):
    """Refuse joints that break the tree of bodies, naming the joint and the body.

    * a body that is already the child of another joint (attached twice);
    * a joint whose child is an ancestor of its parent (a loop of joints), or
      the system's root body;
    * a coordinate or speed that another joint already uses.
    """
    parent_of = {}     # child body -> joint
    owner = {}         # coordinate/speed -> joint
    for joint in old_joints:
        parent_of.setdefault(joint.child, joint)
        for x in list(joint.coordinates) + list(joint.speeds):
            owner.setdefault(x, joint)
    for joint in new_joints:
        child, parent = joint.child, joint.parent
        if child is root:
            raise ModelError(f"joint {joint.name}: its child {_body_name(child)} is the system's "
                             "Newtonian (root) body, which no joint may move")
        if child in parent_of:
            raise ModelError(
                f"joint {joint.name}: body {_body_name(child)} is already attached as the child "
                f"of joint {parent_of[child].name}; a body can be the child of one joint only "
                "(close a kinematic loop with add_holonomic_constraints instead)")
        body, seen = parent, set()
        while body is not child and body in parent_of and body not in seen:
            seen.add(body)
            body = parent_of[body].parent
        if body is child:
            raise ModelError(
                f"joint {joint.name}: attaching {_body_name(child)} to {_body_name(parent)} closes "
                "a loop of joints, so the joints no longer form a tree (close a kinematic loop "
                "with add_holonomic_constraints instead)")
        for kind, items in (("coordinate", joint.coordinates), ("speed", joint.speeds)):
            for x in items:
                if x in owner and owner[x] is not joint:
                    raise ModelError(
                        f"joint {joint.name}: its {kind} {str(x).replace('(t)', '')} is already "
                        f"the {kind} of joint {owner[x].name}; give each joint its own")
        parent_of[child] = joint
        for x in list(joint.coordinates) + list(joint.speeds):
            owner.setdefault(x, joint)


def _actuator_loads(actuator, frame):
    """The loads of one actuator, each point's velocity checked, errors naming the actuator."""
    try:
        loads = list(actuator.to_loads())
    except Exception as exc:  # SymPy's message, but said where it comes from
        raise ModelError(f"actuator {actuator!r}: its loads cannot be formed "
                         f"({type(exc).__name__}: {exc})") from None
    for load in loads:
        where = load[0]
        try:
            if isinstance(where, Point):
                where.vel(frame)
            elif isinstance(where, ReferenceFrame):
                where.ang_vel_in(frame)
        except (ValueError, KeyError):
            kind = "point" if isinstance(where, Point) else "frame"
            raise ModelError(
                f"actuator {actuator!r} acts on {kind} {where.name}, whose "
                f"{'velocity' if kind == 'point' else 'angular velocity'} in the inertial frame "
                f"{frame.name} is undefined: attach the {kind} to a body (or set it with "
                f"{'set_vel/v2pt_theory' if kind == 'point' else 'set_ang_vel'})") from None
    return loads


class EquationsOnUse(MutableDenseMatrix):
    """What ``System.form_eoms()`` returns with eomc's KanesMethod: ``fr + frstar`` as a
    SymPy ``Matrix`` (a subclass: ``isinstance(eoms, Matrix)`` holds), formed the first time
    anything reads it -- its shape, entries, printing, arithmetic, ``xreplace``, pickling.
    Until then nothing is formed (see the module docstring)."""

    def __new__(cls, form):
        self = object.__new__(cls)
        self.__dict__["_form_now"] = form
        return self

    def _formed(self):
        d = self.__dict__
        if "_formed_rep" not in d:
            matrix = d["_form_now"]()
            d["_formed_rep"] = matrix._rep.copy()
            d["_formed_rows"], d["_formed_cols"] = matrix.shape
        return d

    def _setter(key):                 # noqa: N805 -- a helper of the class body
        def set_(self, value):
            self._formed()[key] = value
        return set_

    _rep = property(lambda self: self._formed()["_formed_rep"], _setter("_formed_rep"))
    rows = property(lambda self: self._formed()["_formed_rows"], _setter("_formed_rows"))
    cols = property(lambda self: self._formed()["_formed_cols"], _setter("_formed_cols"))
    del _setter

    @property
    def is_formed(self):
        return "_formed_rep" in self.__dict__

    @classmethod
    def _fromrep(cls, rep):
        """Results of operations on it are plain Matrices."""
        return MutableDenseMatrix._fromrep(rep)

    def __reduce__(self):
        rows, cols = self.rows, self.cols
        return (MutableDenseMatrix, (rows, cols, [self[i, j] for i in range(rows) for j in range(cols)]))


def _state_of(system):
    """What a System's equations are formed from (identities): changed after form_eoms(),
    the recorded equations no longer describe the System."""
    return tuple(tuple(getattr(system, name)) for name in (
        "joints", "bodies", "loads", "actuators", "q_ind", "q_dep", "u_ind", "u_dep", "u_aux",
        "kdes", "holonomic_constraints", "nonholonomic_constraints"))


def _same(a, b):
    """The same objects (identity: cheap, and a rebuilt equal one only costs the shortcut)."""
    return len(a) == len(b) and all(len(x) == len(y) and all(p is q for p, q in zip(x, y))
                                    for x, y in zip(a, b))


class System(_SymPySystem):
    """SymPy 1.14's ``System``, whose ``form_eoms`` uses eomc's KanesMethod/LagrangesMethod.

    Same constructor, attributes and methods as ``sympy.physics.mechanics.System``
    (it is a subclass); see the module docstring for what is overridden and why.
    """

    def add_joints(self, *joints):
        """SymPy's ``add_joints``, after checking that the joints keep a tree (module docstring)."""
        root = self.bodies[0] if self.bodies and self.bodies[0].masscenter is self.fixed_point else None
        fresh = [j for j in joints if isinstance(j, Joint) and j not in self.joints]
        check_new_joints(self.joints, fresh, root)  # (SymPy's checks name other objects)
        super().add_joints(*joints)

    def _loads_for_method(self):
        loads = tuple(self.loads)
        for act in self.actuators:
            loads += tuple(_actuator_loads(act, self.frame))
        return loads or None

    def form_eoms(self, eom_method=KanesMethod, **kwargs):
        """Form the equations of motion with eomc's ``KanesMethod`` (default) or ``LagrangesMethod``.

        As SymPy 1.14's ``System.form_eoms``: the same keyword arguments, the
        same ones refused, returns ``eom_method._form_eoms()``.  Passing SymPy's
        own classes selects eomc's.
        """
        eom_method = _our_method(eom_method)
        family = _family(eom_method)
        if family is None:
            raise NotImplementedError(f'{eom_method} has not been implemented.')
        loads = self._loads_for_method()
        if family == "kane":
            disallowed = {"frame", "q_ind", "u_ind", "kd_eqs", "q_dependent", "u_dependent",
                          "u_auxiliary", "configuration_constraints", "velocity_constraints",
                          "forcelist", "bodies"}
            base = {"frame": self.frame, "q_ind": self.q_ind, "u_ind": self.u_ind,
                    "kd_eqs": self.kdes, "q_dependent": self.q_dep, "u_dependent": self.u_dep,
                    "configuration_constraints": self.holonomic_constraints,
                    "velocity_constraints": self.velocity_constraints,
                    "u_auxiliary": self.u_aux, "forcelist": loads, "bodies": self.bodies,
                    "explicit_kinematics": False}
        else:
            disallowed = {"frame", "qs", "forcelist", "bodies", "hol_coneqs", "nonhol_coneqs",
                          "Lagrangian"}
            base = {"frame": self.frame, "qs": self.q, "forcelist": loads, "bodies": self.bodies,
                    "hol_coneqs": self.holonomic_constraints,
                    "nonhol_coneqs": self.nonholonomic_constraints}
        wrong = disallowed.intersection(kwargs)
        if wrong:
            raise ValueError(f"The following keyword arguments are not allowed to be "
                             f"overwritten in {eom_method.__name__}: {wrong}.")
        kwargs = {**base, **kwargs}
        if family == "lagrange" and "Lagrangian" not in kwargs:
            kwargs["Lagrangian"] = Lagrangian(kwargs["frame"], *kwargs["bodies"])
        self._eom_method = eom_method(**kwargs)
        _name_joints(self._eom_method, self.joints)
        method = self._eom_method
        if family == "kane" and type(method)._form_eoms is KanesMethod._form_eoms:
            # record now (malformed bodies or loads are refused here); the velocities and
            # the equations come on first use (the tree reader needs neither)
            method._record(method._bodylist, method._forcelist, kinematics_now=False)
            self._recorded = (_state_of(self), "acceleration_constraints" in kwargs)
            return EquationsOnUse(lambda: method.fr + method.frstar)
        return method._form_eoms()

    def kane_pending(self):
        """True when ``form_eoms()`` recorded eomc's Kane equations, nothing has read them
        (so they are not formed) and the System is as it was then: its joint tree may be
        read instead of forming them."""
        method, recorded = self.eom_method, self.__dict__.get("_recorded")
        return (isinstance(method, KanesMethod) and not method.is_formed and recorded is not None
                and not recorded[1] and _same(recorded[0], _state_of(self)))

    def validate_system(self, eom_method=KanesMethod, check_duplicates=False):
        """SymPy's checks, for eomc's classes as for SymPy's (see ``System.validate_system``)."""
        return super().validate_system(_sympy_family(eom_method), check_duplicates)

    def formed(self):
        """The compiler's :class:`FormedSystem`; forms the equations (Kane) if not yet done."""
        if self.eom_method is None:
            self.form_eoms()
        return _formed(self.eom_method)


def _name_joints(method, joints):
    """Tell the method which joint each speed belongs to, for its error messages."""
    method._joint_of_speed = {s: j.name for j in joints for s in getattr(j, "speeds", ())}


def _formed(method):
    return from_sympy(method).formed()


class JointsMethod(_SymPyJointsMethod):
    """SymPy 1.14's (deprecated) ``JointsMethod``, forming equations with eomc's methods.

    Subclassed for the same reason as :class:`System`: SymPy's ``form_eoms``
    picks the method with ``issubclass`` against its own classes.
    """

    def __init__(self, newtonion, *joints):
        # SymPy's __init__, repeated rather than called: its deprecation warning
        # must point at the user's line, one frame above this one.
        sympy_deprecation_warning(
            """
            The JointsMethod class is deprecated.
            Its functionality has been replaced by the new System class.
            """,
            deprecated_since_version="1.13",
            active_deprecations_target="deprecated-mechanics-jointsmethod")
        check_new_joints([], [j for j in joints if isinstance(j, Joint)])
        self.frame = newtonion.frame if isinstance(newtonion, BodyBase) else newtonion
        self._joints = joints
        self._bodies = self._generate_bodylist()
        self._loads = self._generate_loadlist()
        self._q = self._generate_q()
        self._u = self._generate_u()
        self._kdes = self._generate_kdes()
        self._method = None

    def form_eoms(self, method=KanesMethod):
        """As SymPy's: Lagrange's method for LagrangesMethod (sub)classes, Kane's otherwise."""
        method = _our_method(method)
        bodylist = self._convert_bodies()
        if _family(method) == "lagrange":
            L = Lagrangian(self.frame, *bodylist)
            self._method = method(L, self.q, self.loads, bodylist, self.frame)
        else:
            self._method = method(self.frame, q_ind=self.q, u_ind=self.u, kd_eqs=self.kdes,
                                  forcelist=self.loads, bodies=bodylist)
            _name_joints(self._method, self._joints)
        return self.method._form_eoms()

    def formed(self):
        """The compiler's :class:`FormedSystem`; forms the equations (Kane) if not yet done."""
        if self.method is None:
            self.form_eoms()
        return _formed(self.method)


def sympy_to_eomc(obj):
    """An eomc System/JointsMethod sharing the state of SymPy's unformed ``obj``.

    Why a shallow copy of the instance dict: both classes keep all their state
    in attributes SymPy defines, and eomc's subclasses add none.
    """
    cls = System if isinstance(obj, _SymPySystem) else JointsMethod
    ours = cls.__new__(cls)
    ours.__dict__.update(obj.__dict__)
    return ours


def eomc_method_of(obj):
    """The formed eomc method of a System/JointsMethod, SymPy's or eomc's (see convert.from_sympy).

    One not formed yet is formed with eomc's KanesMethod (SymPy's default); a
    SymPy object is copied first (:func:`sympy_to_eomc`), so the user's stays as it was.
    """
    is_system = isinstance(obj, _SymPySystem)
    method = obj.eom_method if is_system else obj.method
    if method is None:
        if not isinstance(obj, (System, JointsMethod)):
            obj = sympy_to_eomc(obj)
        obj.form_eoms()
        method = obj.eom_method if is_system else obj.method
    return from_sympy(method)


register_system_converter(eomc_method_of)
