"""Old path of :mod:`agents.policies.policy_fmu`, kept for one version: an import gets that
module itself."""

import sys

from agents.policies import policy_fmu

sys.modules[__name__] = policy_fmu
