"""Old path of :mod:`agents.controllers.action_hold`, kept for one version: an import gets that
module itself."""

import sys

from agents.controllers import action_hold

sys.modules[__name__] = action_hold
