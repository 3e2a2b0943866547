"""Old path of :mod:`agents.policies.pretrained`, kept for one version: an import gets that
module itself.
``python -m agents.pretrained`` runs it."""

import sys

from agents.policies import pretrained

if __name__ == "__main__":
    sys.exit(pretrained.main())
sys.modules[__name__] = pretrained
