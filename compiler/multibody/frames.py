"""TreeFrame: a SymPy ``ReferenceFrame`` whose path search between frames is linear.

Why: SymPy finds how two frames are related (``dcm``, ``ang_vel_in``, ``ang_acc_in``) by
``ReferenceFrame._dict_list``, which lists *every* simple path leaving the frame -- with a
list-membership test per new path -- and then keeps the shortest.  On a chain that is cheap.
eomc's URDF Systems set each body's angular velocity in the world frame N directly
(``urdf.system._set_velocities``, for body-frame expressions), so N is linked to every body
and the simple paths out of any frame run through N to every other body and down its
subtree: their number, and SymPy's time, grow like a high power of the body count.  Measured
(``system_from_tree`` alone, limits off): G1 29-dof 64 s, Talos reduced > 200 s, Talos full
body never finished (the derivative bench's 74 min), against 1.3 s / 1.9 s with this search.

The search here is a breadth-first walk that stops at the target: the same shortest path
SymPy returns (breadth-first discovery follows the same neighbour order, the frames'
``_dlist`` dicts, so ties break the same way), in time linear in the frames and links.
Frames made from a TreeFrame by SymPy (``orientnew``) are TreeFrames too.
"""
from collections import deque

from sympy.physics.vector import ReferenceFrame

__all__ = ["TreeFrame"]

_KINDS = {0: "orientation", 1: "angular velocity", 2: "angular acceleration"}


class TreeFrame(ReferenceFrame):
    """A ReferenceFrame with a breadth-first ``_dict_list`` (see the module docstring)."""

    def _dict_list(self, other, num):
        if num not in _KINDS:
            raise ValueError("Valid values for num are 0, 1, or 2.")
        previous = {self: None}
        queue = deque([self])
        while queue:
            frame = queue.popleft()
            if frame == other:
                path = []
                while frame is not None:
                    path.append(frame)
                    frame = previous[frame]
                return path[::-1]
            for adjacent in frame._dlist[num]:
                if adjacent not in previous:
                    previous[adjacent] = frame
                    queue.append(adjacent)
        raise ValueError(f"No connecting {_KINDS[num]} path found between {self.name} and {other.name}.")
