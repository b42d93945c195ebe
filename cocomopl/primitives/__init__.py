"""Stage 2: movement primitives learned from the OC dataset (the paper's sec. III-C)."""

# Model-selection candidates.  S: the paper's 7 and 11, and 15; the bound rises with S (through
# 31), so the rule of selection.choose picks the smallest S explaining 99.9 % of every group.
DEFAULT_PRIMITIVES = (7, 11, 15)
# the time kernels of the primitives' GP priors (primitives/kernels.py); named here, where
# no JAX is imported, so the CLI checks them without the [train] extra
TIME_KERNELS = ("rbf", "matern32", "matern52")
DEFAULT_KERNELS = TIME_KERNELS
# EM rounds per fit at most, in the API and the CLI alike: the bundled models were trained
# with it (``cocomopl train``'s default), so the defaults reproduce them.  A fit stops earlier
# at em.RELATIVE_TOLERANCE (14-19 rounds on the bundled sets); see docs/results.md#the-learner.
DEFAULT_MAX_ITERATIONS = 40
# Candidate widths of the weight kernels, log-spaced from 7 mm to 0.7 m (36 % apart); EM picks
# each kernel's width among them.  The bundled models were trained with it.  Generating a step
# costs one product with an n x n eigenbasis per distinct width picked, so fewer candidates
# (``cocomopl train --widths 9``) generate faster; see docs/experiments/generation-speed.md.
DEFAULT_WIDTHS = 31
