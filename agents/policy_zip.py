"""Old path of :mod:`agents.policies.policy_zip`, kept for one version: an import gets that
module itself."""

import sys

from agents.policies import policy_zip

sys.modules[__name__] = policy_zip
