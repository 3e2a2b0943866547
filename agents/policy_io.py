"""Old path of :mod:`agents.policies.policy_io`, kept for one version: an import gets that
module itself."""

import sys

from agents.policies import policy_io

sys.modules[__name__] = policy_io
