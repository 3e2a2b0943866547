"""Old path of :mod:`agents.evaluation.vehicle_validation`,
kept for one version: an import gets that module itself.
``python -m agents.vehicle_validation`` runs it."""

import sys

from agents.evaluation import vehicle_validation

if __name__ == "__main__":
    sys.exit(vehicle_validation.main())
sys.modules[__name__] = vehicle_validation
