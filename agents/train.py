"""Old path of :mod:`agents.training.train`, kept for one version: an import gets that
module itself.
``python -m agents.train`` runs it."""

import sys

from agents._extras import MissingExtraError, report_missing

try:
    from agents.training import train
except MissingExtraError as err:
    if __name__ == "__main__":
        sys.exit(report_missing(err.__cause__ or err, "python -m agents.train", "training"))
    raise

if __name__ == "__main__":
    sys.exit(train.main())
sys.modules[__name__] = train
