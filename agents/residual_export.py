"""Old path of :mod:`agents.policies.residual_export`, kept for one version: an import gets that
module itself."""

import sys

from agents.policies import residual_export

sys.modules[__name__] = residual_export
