"""Stage 2: movement primitives learned from the OC dataset (the paper's sec. III-C)."""

# Model-selection candidates.  S: the paper's 7 and 11, and 15; the bound rises with S (through
# 31), so the rule of selection.choose picks the smallest S explaining 99.9 % of every group.
DEFAULT_PRIMITIVES = (7, 11, 15)
# the time kernels of the primitives' GP priors (primitives/kernels.py); named here, where
# no JAX is imported, so the CLI checks them without the [train] extra
TIME_KERNELS = ("rbf", "matern32", "matern52")
DEFAULT_KERNELS = TIME_KERNELS
# EM rounds per fit, in the API and the CLI alike: the bundled model was trained with it
# (``cocomopl train``'s default), so the defaults reproduce it.  It keeps training with model
# selection within 5 minutes on 2 cores; what the rounds left, see docs/results.md#the-learner.
DEFAULT_MAX_ITERATIONS = 40
