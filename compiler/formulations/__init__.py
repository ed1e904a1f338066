"""eomc.compiler.formulations: the formulations as peers behind one interface, and the choice.

    select.py     kane, recursive or auto (both lowered from one reading, the cheaper rhs kept)
    recursive.py  the recursive formulation (ABA, RNEA, CRBA over the joint tree: tree/) as a
                  Formulation of eomc.compiler.emit.formulation, whose base class is Kane's
"""
