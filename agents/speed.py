"""Old path of :mod:`agents.evaluation.speed`, kept for one version: an import gets that
module itself."""

import sys

from agents.evaluation import speed

sys.modules[__name__] = speed
