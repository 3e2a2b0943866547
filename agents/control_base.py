"""Old path of :mod:`agents.controllers.control_base`, kept for one version: an import gets that
module itself."""

import sys

from agents.controllers import control_base

sys.modules[__name__] = control_base
