"""Old path of :mod:`agents.evaluation.refine`, kept for one version: an import gets that
module itself."""

import sys

from agents.evaluation import refine

sys.modules[__name__] = refine
