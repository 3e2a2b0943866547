"""Old path of :mod:`agents.evaluation.validity`, kept for one version: an import gets that
module itself.
``python -m agents.validity`` runs it."""

import sys

from agents.evaluation import validity

if __name__ == "__main__":
    sys.exit(validity.main())
sys.modules[__name__] = validity
