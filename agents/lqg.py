"""Old path of :mod:`agents.controllers.lqg`, kept for one version: an import gets that
module itself."""

import sys

from agents.controllers import lqg

sys.modules[__name__] = lqg
