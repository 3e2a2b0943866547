"""Old path of :mod:`agents.controllers.crash_baselines`, kept for one version: an import gets that
module itself."""

import sys

from agents.controllers import crash_baselines

sys.modules[__name__] = crash_baselines
