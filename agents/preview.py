"""Old path of :mod:`agents.controllers.preview`, kept for one version: an import gets that
module itself."""

import sys

from agents.controllers import preview

sys.modules[__name__] = preview
