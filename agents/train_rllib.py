"""Old path of :mod:`agents.training.train_rllib`, kept for one version: an import gets that
module itself.
``python -m agents.train_rllib`` runs it."""

import sys

from agents._extras import MissingExtraError, report_missing

try:
    from agents.training import train_rllib
except MissingExtraError as err:
    if __name__ == "__main__":
        sys.exit(
            report_missing(err.__cause__ or err, "python -m agents.train_rllib", "RLlib training")
        )
    raise

if __name__ == "__main__":
    sys.exit(train_rllib.main())
sys.modules[__name__] = train_rllib
