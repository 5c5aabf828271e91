"""The suite's element kernels compiled at -O0 (``$LATDYN_KERNEL_OPT``, :func:`latdyn.native.kernel_optimisation`).

The suite compiles every kernel of every generated variant into an empty kernel cache (``.ci/run``), and GCC
compiles the generated straight-line code 5-40x faster at -O0 than at the -O1 a user's units of up to
``OPT_LIMIT_OPS`` operations get (its register allocation is most of an -O1 compile), with the same results: each
operation rounded as the source says (``-ffp-contract=off``, no fast-math). Set here, in the environment, so that
the command-line runs the tests start in processes of their own compile the same libraries. Two tests check the
kernels as a user gets them: ``tests/test_backends.py`` compares every kernel of ``default`` built at its own level
with NumPy and SymPy, and ``tests/test_instruction_sets.py`` runs its scenes on both builds. Set the variable
empty (``LATDYN_KERNEL_OPT= python -m pytest``) to run the whole suite on the kernels as users get them."""
import os

from latdyn.native import OPTIMISATION_VARIABLE

os.environ.setdefault(OPTIMISATION_VARIABLE, "-O0")
