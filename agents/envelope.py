"""Old path of :mod:`agents.training.envelope`, kept for one version: an import gets that
module itself."""

import sys

from agents.training import envelope

sys.modules[__name__] = envelope
