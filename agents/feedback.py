"""Old path of :mod:`agents.controllers.feedback`, kept for one version: an import gets that
module itself."""

import sys

from agents.controllers import feedback

sys.modules[__name__] = feedback
