"""Old path of :mod:`agents.training.run_files`, kept for one version: an import gets that
module itself."""

import sys

from agents.training import run_files

sys.modules[__name__] = run_files
