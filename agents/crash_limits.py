"""Old path of :mod:`agents.evaluation.crash_limits`, kept for one version: an import gets that
module itself.
``python -m agents.crash_limits`` runs it."""

import sys

from agents.evaluation import crash_limits

if __name__ == "__main__":
    sys.exit(crash_limits.main())
sys.modules[__name__] = crash_limits
