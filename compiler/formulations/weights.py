"""The cost model of auto (select.py) as numbers and words, without SymPy: `eomc build` prints
COST_MODEL beside a model it found built before, and importing select.py (SymPy) cost that
build ~0.7 s of its ~1.1 s CPU (s28)."""

# The cost model of auto (issue 31 item 5), in units of one add or multiply of the recursive
# form.  Refitted in session 25 (task autocost) by least squares to both forms' rhs times of 18
# models (the cart System n = 1-6, UR10, Kinova, so100, hextilt's arm, Bolt, Iris, finger_edu,
# TwoDofs, borinot, the double pendulum URDF, SymPy's cart-pole and four-bar examples), measured
# with eomc's default flags (gcc -O2 -mavx2, thread CPU, pinned, interleaved rounds, 3 harness copies
# of different code placement; benchmarks/bench_auto_choice.py --fit, results/auto_choice.md).  The
# fit is of the difference Kane - recursive per model (what the pick decides), relative to the
# model's time.  The term the old model (Kane's flop 1.15, a call 25) missed: Kane's arithmetic
# costs more per operation the more speeds the model has (its dense mass matrix and forcing are
# long straight-line code whose values all stay live: spills), 0.78 + 0.13 per speed, i.e. 1.04 at
# 2 speeds, 1.17 at 3, 1.56 at 6; without it Bolt (6 speeds, two 3-joint legs) and finger_edu
# (3 speeds) have the same flop ratio (0.76) and opposite winners (Kane 10 % slower, 5 % faster).
# The calls (sin/cos of the joint angles, 36 flops each) are what the cart at n = 2 turns on.  The
# division's weight the fit leaves free (the forms differ by 1-4 divisions): 4, its latency.
KANE_OP_WEIGHT = 0.78            # one of Kane's adds/muls against one of the recursion's, at 0 speeds
KANE_OP_WEIGHT_PER_SPEED = 0.13  # ... plus this per speed of the model
DIV_WEIGHT = 4                   # a division (latency ~4 multiplies on x86-64)
CALL_WEIGHT = 36                 # a sin, cos, sqrt, ... call (libm or the lane routine)
COST_MODEL = (f"operations weighted: a call {CALL_WEIGHT}, a division {DIV_WEIGHT}, "
              f"Kane's {KANE_OP_WEIGHT} + {KANE_OP_WEIGHT_PER_SPEED} per speed")   # for eomc build/inspect
