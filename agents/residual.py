"""Old path of :mod:`agents.controllers.residual`, kept for one version: an import gets that
module itself."""

import sys

from agents.controllers import residual

sys.modules[__name__] = residual
