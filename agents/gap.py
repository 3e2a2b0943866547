"""Old path of :mod:`agents.evaluation.gap`, kept for one version: an import gets that
module itself."""

import sys

from agents.evaluation import gap

sys.modules[__name__] = gap
