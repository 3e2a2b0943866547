"""Old path of :mod:`agents.evaluation.sweeps`, kept for one version: an import gets that
module itself."""

import sys

from agents.evaluation import sweeps

sys.modules[__name__] = sweeps
