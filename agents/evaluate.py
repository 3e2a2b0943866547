"""Old path of :mod:`agents.evaluation.evaluate`, kept for one version: an import gets that
module itself."""

import sys

from agents.evaluation import evaluate

sys.modules[__name__] = evaluate
