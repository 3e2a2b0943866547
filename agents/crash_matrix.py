"""Old path of :mod:`agents.evaluation.crash_matrix`, kept for one version: an import gets that
module itself."""

import sys

from agents.evaluation import crash_matrix

sys.modules[__name__] = crash_matrix
