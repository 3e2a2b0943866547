"""Old path of :mod:`agents.controllers.semi_active_control`,
kept for one version: an import gets that module itself."""

import sys

from agents.controllers import semi_active_control

sys.modules[__name__] = semi_active_control
