"""eomc.compiler: symbolic front end, optimizer and C lowering (uses SymPy)."""
